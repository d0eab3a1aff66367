"""``mcnkit explore`` on a small occupancy image: outputs, recording, re-running a summary, bad input."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from mcnkit.app.commands.explore import add_explore_parser
from mcnkit.app.main import main


def _run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser("mcnkit")
    add_explore_parser(parser.add_subparsers(required=True))
    args = parser.parse_args(["explore", *argv])
    return int(args.func(args))


@pytest.fixture
def plan(tmp_path: Path) -> Path:
    """Two rooms (4 m × 3 m and 3 m × 3 m at 0.05 m per pixel) and a 1 m door, as a PNG."""
    pixels = np.zeros((80, 170), np.uint8)
    pixels[10:70, 10:90] = 255
    pixels[10:70, 92:160] = 255
    pixels[30:50, 90:92] = 255
    path = tmp_path / "rooms.png"
    Image.fromarray(pixels).save(path)
    return path


def test_frontier_run_writes_its_outputs_and_reruns_from_its_summary(tmp_path: Path, plan: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    argv = ["--map", f"image:{plan}", "--planner", "frontier", "--out", str(out), "--no-progress",
            "--explore.budget-m", "1", "--seed", "2"]
    assert _run(argv) == 0
    assert {p.name for p in out.iterdir()} == {"summary.json", "map.pgm", "map.yaml", "map.png", "trajectory.tum",
                                               "ground_truth.tum", "coverage.csv"}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["planner"] == "frontier" and summary["stop_reason"] == "budget"
    assert 1.0 <= summary["path_length_m"] < 1.1 and 0 < summary["coverage"] < 1
    assert summary["explore"]["budget_m"] == 1.0 and summary["slam"]["updates"]["linear_m"] == 0.3
    assert summary["f_completed"] is None and 0 < summary["f_slam"] <= 1
    lines = (out / "coverage.csv").read_text().splitlines()
    assert lines[0] == "frame,path_length_m,coverage" and len(lines) == summary["frames"] + 1
    assert "path budget spent" in capsys.readouterr().out
    again = tmp_path / "again"
    assert _run(["--map", f"image:{plan}", "--planner", "frontier", "--out", str(again), "--no-progress",
                 "--config", str(out / "summary.json")]) == 0
    rerun = json.loads((again / "summary.json").read_text())
    assert rerun["seed"] == 2 and rerun["path_length_m"] == summary["path_length_m"]
    assert main(["explore", *argv]) == 2  # --out exists: refused without --overwrite
    assert "--overwrite" in capsys.readouterr().err


def test_mcn_run_is_recorded(tmp_path: Path, plan: Path) -> None:
    from rerun.chunk import RrdReader

    rrd = tmp_path / "run.rrd"
    out = tmp_path / "out"
    assert _run(["--map", f"image:{plan}", "--model", "unet-explore", "--gain.samples", "2", "--rrd", str(rrd),
                 "--out", str(out), "--no-progress", "--explore.budget-m", "2"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["planner"] == "mcn" and summary["model"] == "unet-explore" and summary["f_completed"] is not None
    entities = {chunk.entity_path for chunk in RrdReader(rrd).stream().collect().stream()}
    assert {"/world/plan/goal", "/world/plan/viewpoints", "/world/pred/window/sample1",
            "/world/pred/window/disagreement", "/metrics/coverage"} <= entities


def test_bad_input_is_one_line(tmp_path: Path, plan: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert _run(["--map", f"image:{plan}", "--model", "no-such-model", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no-such-model" in err[0]
    assert _run(["--map", "nowhere:3", "--no-progress"]) == 2
    assert _run(["--map", f"image:{plan}", "--explore.budget-m", "-1", "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "--explore.budget-m" in err[1]
