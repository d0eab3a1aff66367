"""Experiment 2's targets: data, checked on the rows; a missing row is an error, not a skipped check."""

from __future__ import annotations

import pytest

from mcnkit.completion.scores import Scores
from mcnkit.experiments.rows import FILLS, ITERATIONS, SLAM_ALONE, Exp2Row
from mcnkit.experiments.targets import (
    TARGETS,
    AboveFills,
    AtLeast,
    MissingRowError,
    check_targets,
    find_row,
    target_models,
)


def _row(it: str, method: str, variant: str, f: float, miou: float, inside: float) -> Exp2Row:
    s = Scores(positive_class="free", n_maps=2, accuracy=0.9, precision=0.8, recall=0.7, f_measure=f, f_ci95=0.0,
               miou_unknown=miou, miou_ci95=0.0, pooled_accuracy=0.9, pooled_precision=0.8, pooled_recall=0.7,
               pooled_f_measure=f, pooled_miou_unknown=miou)
    return Exp2Row(it, method, variant, s, inside, 0.0, 0.5, 0.4)


def _table(unet_f: float = 0.6, labels: tuple[str, ...] = ("(B) U-net",)) -> list[Exp2Row]:
    rows = []
    for it in ITERATIONS:
        rows += [_row(it, lab, "mean of 4", unet_f + (0.1 if it == "T-5" else 0.0), 0.5, 0.6) for lab in labels]
        rows += [_row(it, SLAM_ALONE, "-", 0.3, 0.0, 0.0)]
        rows += [_row(it, f, "-", 0.4, 0.45, 0.55) for f in FILLS]
    return rows


def test_the_unet_targets_on_a_table() -> None:
    checks = check_targets(_table(0.6), ("unet",), 4)
    assert [c.text for c in checks] == [
        "U-net F at iteration 1 ≥ 0.53 (paper 0.5275)",
        "U-net F at iteration 1 ≥ 1.3 × SLAM alone",
        "U-net F at T−5 ≥ 0.64 (paper 0.6429)",
        "U-net mIoU on the unknown cells m_T knows (as in Exp 3) above both trivial fills, iteration 1",
        "same, with the cells m_T never saw counted occupied, iteration 1",
        "U-net mIoU on the unknown cells m_T knows (as in Exp 3) above both trivial fills, iteration T-5",
        "same, with the cells m_T never saw counted occupied, iteration T-5",
    ]
    assert all(c.met for c in checks)
    assert checks[1].value == "0.6000 / 0.3000 = 2.00×" and checks[3].value == "0.6000 vs 0.5500"
    low = check_targets(_table(0.35), ("unet",), 4)
    assert [c.met for c in low[:3]] == [False, False, False]


def test_a_network_without_targets_is_not_checked_and_one_with_targets_must_have_its_rows() -> None:
    assert check_targets(_table(labels=("tiny",)), ("tiny",), 4) == []
    # renamed: the table's U-net row carries another label than the model's, so the check cannot find it
    with pytest.raises(MissingRowError, match="U-net, exploration-trained"):
        check_targets(_table(labels=("(B) U-net",)), ("unet", "unet-explore"), 4)
    with pytest.raises(MissingRowError, match="mean of 8"):
        check_targets(_table(), ("unet",), 8)
    no_fills = [r for r in _table() if r.method not in FILLS]
    with pytest.raises(MissingRowError, match="all free"):
        check_targets(no_fills, ("unet",), 4)


def test_targets_are_data_on_columns_of_the_table() -> None:
    assert set(TARGETS) == {"unet", "unet-explore"}
    assert target_models(("pix2pix", "unet-explore", "unet")) == ["(B) U-net", "(B') U-net, exploration-trained"]
    assert find_row(_table(), "T-5", SLAM_ALONE, "-").scores.f_measure == 0.3
    with pytest.raises(ValueError, match="not a column"):
        AtLeast("{name}", "1", "f_mesure", 0.5, 0.5)
    with pytest.raises(ValueError, match="not a column"):
        AboveFills("{name}", "1", "miou")
