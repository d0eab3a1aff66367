"""Experiment tables: dataclass rows to CSV and back."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pytest

from mcnkit.completion.scores import Scores
from mcnkit.experiments.rows import EXP1_COLUMNS, EXP2_COLUMNS, Exp1Row, Exp2Row
from mcnkit.experiments.tables import columns, flatten, read_csv, read_rows, write_rows


def _scores(f: float = 0.5, positive: str = "free") -> Scores:
    return Scores(positive_class=positive, n_maps=3, accuracy=0.9, precision=0.8, recall=0.7, f_measure=f,
                  f_ci95=0.01, miou_unknown=0.4, miou_ci95=0.02, pooled_accuracy=0.91, pooled_precision=0.81,
                  pooled_recall=0.71, pooled_f_measure=0.51, pooled_miou_unknown=0.41)


def test_columns_flatten_nested_rows_in_field_order() -> None:
    assert columns(Exp1Row)[:4] == ["method", "train_domain", "test_domain", "positive_class"]
    assert sorted(columns(Exp1Row)) == sorted(EXP1_COLUMNS) and sorted(columns(Exp2Row)) == sorted(EXP2_COLUMNS)
    row = Exp2Row("1", "(B) U-net", "mean of 8", _scores(), 0.3, 0.03, 0.2, 0.6)
    flat = flatten(row)
    assert list(flat) == columns(Exp2Row) and flat["f_measure"] == 0.5 and flat["iteration"] == "1"


def test_rows_round_trip_with_the_table_column_order(tmp_path: Path) -> None:
    rows = [Exp2Row("1", "(B) U-net", "mean of 8", _scores(1 / 3), 0.3, 0.03, float("nan"), 0.6),
            Exp2Row("T-5", "(C) SLAM alone", "-", _scores(0.25, "occupied"), 0.1, 0.0, 0.0, 0.1)]
    path = tmp_path / "t.csv"
    write_rows(path, rows, Exp2Row, EXP2_COLUMNS)
    lines = path.read_text().splitlines()
    assert lines[0].split(",") == list(EXP2_COLUMNS)
    assert lines[1].startswith("1,(B) U-net,mean of 8,3,free,0.900000,0.800000,0.700000,0.333333,")
    assert ",nan," in lines[1]
    back = read_rows(path, Exp2Row)
    assert back[1] == rows[1]
    assert back[0].scores.f_measure == pytest.approx(1 / 3, abs=1e-6) and math.isnan(back[0].exterior_predicted_free)
    assert read_csv(path, {"iteration", "method", "variant", "positive_class"})[1]["n_maps"] == 3.0


def test_a_table_refuses_what_is_not_its_rows(tmp_path: Path) -> None:
    row = Exp1Row("(B) U-net", "houseexpo", "houseexpo", _scores())
    with pytest.raises(ValueError, match="does not name the fields"):
        write_rows(tmp_path / "a.csv", [row], Exp1Row, EXP1_COLUMNS[:-1])
    with pytest.raises(TypeError, match="a Exp1Row in a table of Exp2Row"):
        write_rows(tmp_path / "b.csv", [row], Exp2Row)
    write_rows(tmp_path / "c.csv", [row], Exp1Row, EXP1_COLUMNS)
    with pytest.raises(ValueError, match=r"not a table of Exp2Row .*no column.*iteration"):
        read_rows(tmp_path / "c.csv", Exp2Row)


def test_a_column_name_may_not_repeat() -> None:
    @dataclass(frozen=True)
    class Clash:
        f_measure: float
        scores: Scores

    with pytest.raises(TypeError, match="repeats"):
        columns(Clash)
