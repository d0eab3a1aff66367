"""``mcnkit slam`` and ``mcnkit eval`` on a tiny generated CARMEN log and on bad input."""

import argparse
import json
from pathlib import Path

import numpy as np
import pytest

from mcnkit.app.commands.eval import add_eval_parser
from mcnkit.app.commands.slam import add_slam_parser


def _run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser("mcnkit")
    sub = parser.add_subparsers(required=True)
    add_slam_parser(sub)
    add_eval_parser(sub)
    args = parser.parse_args(argv)
    return int(args.func(args))


def _write_clf(path: Path, n: int = 30) -> None:
    """A robot driving +x at 0.1 m per scan in a 4 m wide corridor with a door frame every metre."""
    lines = []
    angles = np.radians(np.linspace(-90, 90, 181))
    for k in range(n):
        x = 0.1 * k
        side = np.where(np.sin(angles) > 0, 2.0, -2.0)
        with np.errstate(divide="ignore"):
            r = np.abs(side / np.sin(angles))
        r = np.minimum(r, (8.0 - x) / np.maximum(np.cos(angles), 1e-3))  # end wall at x = 8
        r = np.minimum(r, 81.91)
        ranges = " ".join(f"{v:.3f}" for v in r)
        t = 1000.0 + 0.2 * k
        lines.append(f"FLASER 181 {ranges} {x:.3f} 0.0 0.0 {x:.3f} 0.0 0.0 {t:.6f} host {t:.6f}")
    path.write_text("\n".join(lines) + "\n")


def test_slam_writes_outputs_and_eval_reads_them(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "corridor.clf"
    _write_clf(log)
    out = tmp_path / "out"
    assert _run(["slam", str(log), "--particles", "4", "--out", str(out), "--no-progress"]) == 0
    for name in (
        "trajectory.tum",
        "trajectory_tracked.tum",
        "trajectory_online.tum",
        "trajectory_gmapping.tum",
        "trajectory_matched.tum",
        "trajectory_smoothed.tum",
        "map.pgm",
        "map.yaml",
        "map.png",
        "summary.json",
    ):
        assert (out / name).is_file(), name
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scans"] == 30 and summary["filter_updates"] >= 2
    assert {"cpu_s", "wall_s", "peak_rss_mb", "final_neff"} <= summary.keys()
    assert summary["trajectory"] == "refined"  # trajectory.tum: the tracked one refined offline, one row per scan
    assert len((out / "trajectory.tum").read_text().splitlines()) == len(
        (out / "trajectory_tracked.tum").read_text().splitlines())
    assert (out / "map.pgm").read_bytes().startswith(b"P5\n")
    assert "resolution: 0.05" in (out / "map.yaml").read_text()
    rel = tmp_path / "r.relations"
    rel.write_text("1000.0 1001.0 0.5 0.0 0 0 0 0\n")  # scans 0 and 5: 0.5 m apart
    capsys.readouterr()
    # This corridor barely changes along x (only the end wall does), so scan tracking has nothing to hold on to:
    # check the relation on gmapping's convention, which follows the (here perfect) odometry between updates.
    assert _run(["eval", "relations", str(out / "trajectory_gmapping.tum"), str(rel), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["n_relations"] == 1 and result["translation_mean_m"] < 0.05
    assert _run(["eval", "ate", str(out / "trajectory.tum"), str(out / "trajectory.tum"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["ate"]["rmse_m"] == pytest.approx(0.0, abs=1e-6)


def test_unreadable_log_is_one_line_and_exit_code_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "garbage.clf"
    bad.write_text("this is not a log\n")
    assert _run(["slam", str(bad), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err and "\n" not in err
    assert _run(["slam", str(tmp_path / "missing.clf"), "--out", str(tmp_path / "o")]) == 2
    assert _run(["eval", "relations", str(tmp_path / "missing.tum"), str(bad)]) == 2


def test_slam_records_every_step_to_rerun_when_asked(tmp_path: Path) -> None:
    from rerun.chunk import RrdReader

    log = tmp_path / "corridor.clf"
    _write_clf(log)
    rrd = tmp_path / "run.rrd"
    assert _run(["slam", str(log), "--particles", "4", "--out", str(tmp_path / "out"), "--no-progress",
                 "--rrd", str(rrd)]) == 0
    store = RrdReader(rrd).stream().collect()
    table = store.reader(index="step", contents="/world/particles").to_arrow_table()
    assert table.num_rows == 30
    assert "/world/map/estimate" in {chunk.entity_path for chunk in store.stream()}


def test_every_slam_config_field_has_a_flag_with_help() -> None:
    import dataclasses

    from mcnkit.slam.config import SlamConfig

    parser = argparse.ArgumentParser("mcnkit")
    slam = add_slam_parser(parser.add_subparsers(required=True))
    options = {a.dest: a for a in slam._actions}
    for f in dataclasses.fields(SlamConfig):
        action = options[f"slam.{f.name}"]
        assert f"--slam.{f.name.rstrip('_').replace('_', '-')}" in action.option_strings
        assert action.help and "(default" in action.help and action.help.split(" (default")[0] != f.name
    args = parser.parse_args(["slam", "x.clf", "--out", "o", "--slam.n-particles", "7", "--no-slam.loop-closure",
                              "--slam.max-range-m", "none", "--slam.sigma-m2", "0.1", "--slam.str", "0.3"])
    assert vars(args)["slam.n_particles"] == 7 and vars(args)["slam.loop_closure"] is False
    assert vars(args)["slam.max_range_m"] is None and vars(args)["slam.str_"] == 0.3
    assert "slam.srr" not in vars(args)  # only what was given


def test_config_file_flags_and_rerun_from_summary_reproduce_the_trajectory(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "corridor.clf"
    _write_clf(log)
    toml = tmp_path / "run.toml"
    toml.write_text("seed = 3\n[slam]\nn_particles = 6\nlinear_update_m = 0.3\nloop_closure = false\n"
                    "[recording]\nmap_every = 3\nflush_updates = 4\n")
    first = tmp_path / "first"
    assert _run(["slam", str(log), "--config", str(toml), "--slam.n-particles", "5", "--slam.srr", "0.2",
                 "--out", str(first), "--no-progress"]) == 0
    summary = json.loads((first / "summary.json").read_text())
    assert summary["seed"] == 3
    cfg = summary["config"]
    assert (cfg["n_particles"], cfg["linear_update_m"], cfg["loop_closure"], cfg["srr"]) == (5, 0.3, False, 0.2)
    assert cfg["sigma_m2"] == 0.05 and len(cfg) > 24  # every field, defaults included
    again = tmp_path / "again"
    assert _run(["slam", str(log), "--config", str(first / "summary.json"), "--out", str(again), "--no-progress"]) == 0
    assert (again / "trajectory.tum").read_bytes() == (first / "trajectory.tum").read_bytes()
    assert summary["recording"]["map_every"] == 3 and summary["recording"]["flush_updates"] == 4
    assert json.loads((again / "summary.json").read_text())["config"] == cfg
    assert json.loads((again / "summary.json").read_text())["recording"] == summary["recording"]
    other = tmp_path / "other"  # the settings matter: the defaults give another trajectory
    assert _run(["slam", str(log), "--out", str(other), "--no-progress"]) == 0
    assert (other / "trajectory.tum").read_bytes() != (first / "trajectory.tum").read_bytes()
    capsys.readouterr()
    bad = tmp_path / "bad.toml"
    bad.write_text("[slam]\nn_particle = 6\n")
    assert _run(["slam", str(log), "--config", str(bad), "--out", str(tmp_path / "x"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("mcnkit slam: ") and err.endswith(f"{bad}: unknown SlamConfig setting: n_particle"), err
    bad.write_text("[slam]\nn_particles = 'six'\n")
    assert _run(["slam", str(log), "--config", str(bad), "--out", str(tmp_path / "x"), "--no-progress"]) == 2
    assert "n_particles: expected int" in capsys.readouterr().err
