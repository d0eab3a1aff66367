"""``mcnkit slam`` and ``mcnkit eval`` on a tiny generated CARMEN log and on bad input."""

import argparse
import json
from collections.abc import Iterator
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


def _leaves(cls: type, path: str = "") -> Iterator[tuple[str, str]]:
    """(dest, flag) of every field of a config dataclass, its sections' fields included."""
    import dataclasses

    for f in dataclasses.fields(cls):  # type: ignore[arg-type]
        if dataclasses.is_dataclass(f.default_factory):
            yield from _leaves(f.default_factory, f"{path}{f.name}.")  # type: ignore[arg-type]
        else:
            yield f"slam.{path}{f.name}", f"--slam.{path.replace('_', '-')}{f.name.rstrip('_').replace('_', '-')}"


def test_every_slam_config_field_has_a_flag_with_help() -> None:
    from mcnkit.slam.config import SlamConfig

    parser = argparse.ArgumentParser("mcnkit")
    slam = add_slam_parser(parser.add_subparsers(required=True))
    options = {a.dest: a for a in slam._actions}
    leaves = list(_leaves(SlamConfig))
    assert len(leaves) == 131
    for dest, flag in leaves:
        action = options[dest]
        assert flag in action.option_strings
        assert action.help and "(default" in action.help and action.help.split(" (default")[0] != dest
    args = parser.parse_args(["slam", "x.clf", "--out", "o", "--slam.n-particles", "7", "--no-slam.loops.closure",
                              "--slam.matching.max-range-m", "none", "--slam.matching.sigma-m2", "0.1",
                              "--slam.motion.str", "0.3"])
    assert vars(args)["slam.n_particles"] == 7 and vars(args)["slam.loops.closure"] is False
    assert vars(args)["slam.matching.max_range_m"] is None and vars(args)["slam.motion.str_"] == 0.3
    assert "slam.motion.srr" not in vars(args)  # only what was given


def _flat(config: dict[str, object]) -> dict[str, object]:
    """A sectioned SlamConfig table with the flat names it had before its sections (fields added since left out)."""
    from mcnkit.slam.config import FLAT_NAMES

    where = {new: old for old, new in FLAT_NAMES.items()}
    out: dict[str, object] = {}
    for key, value in config.items():
        if isinstance(value, dict):
            out.update({where[f"{key}.{name}"]: v for name, v in value.items() if f"{key}.{name}" in where})
        else:
            out[key] = value
    return out


def test_odometry_ignore_has_the_short_forms_info_and_the_issue_use() -> None:
    from mcnkit.app.runconfig import resolve_slam_config
    from mcnkit.slam.config import SlamConfig

    parser = argparse.ArgumentParser("mcnkit")
    add_slam_parser(parser.add_subparsers(required=True))

    def config(*flags: str) -> SlamConfig:
        return resolve_slam_config(parser.parse_args(["slam", "x.bag", "--out", "o", *flags]))[0]

    long = config("--slam.motion.odometry", "ignore")
    assert long.motion.odometry == "ignore"
    assert config("--slam.odometry", "ignore") == long == config("--odometry", "ignore")
    assert config("--odometry", "ignore", "--slam.motion.odometry", "use").motion.odometry == "use"  # the long wins
    assert config("--odometry", "ignore").motion.noise_from_log == SlamConfig().motion.noise_from_log  # nothing else
    for bad in (["--slam.odometry", "none"], ["--odometry", "none"]):  # values checked as the long flag's are
        with pytest.raises(SystemExit):
            parser.parse_args(["slam", "x.bag", "--out", "o", *bad])


def test_section_flags_and_a_toml_file_with_sections_rerun_bit_for_bit(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "corridor.clf"
    _write_clf(log)
    toml = tmp_path / "run.toml"
    toml.write_text("seed = 3\n[slam]\nn_particles = 6\n[slam.updates]\nlinear_m = 0.3\n[slam.loops]\n"
                    "closure = false\n[recording]\nmap_every = 3\nflush_updates = 4\n")
    first = tmp_path / "first"
    assert _run(["slam", str(log), "--config", str(toml), "--slam.n-particles", "5", "--slam.motion.srr", "0.2",
                 "--out", str(first), "--no-progress"]) == 0
    summary = json.loads((first / "summary.json").read_text())
    assert summary["seed"] == 3
    cfg = summary["config"]
    assert (cfg["n_particles"], cfg["updates"]["linear_m"], cfg["loops"]["closure"], cfg["motion"]["srr"]) == \
        (5, 0.3, False, 0.2)
    assert cfg["matching"]["sigma_m2"] == 0.05 and len(cfg) == 10  # every section, defaults included
    again = tmp_path / "again"
    assert _run(["slam", str(log), "--config", str(first / "summary.json"), "--out", str(again), "--no-progress"]) == 0
    assert (again / "trajectory.tum").read_bytes() == (first / "trajectory.tum").read_bytes()
    assert summary["recording"]["map_every"] == 3 and summary["recording"]["flush_updates"] == 4
    assert json.loads((again / "summary.json").read_text())["config"] == cfg
    assert json.loads((again / "summary.json").read_text())["recording"] == summary["recording"]
    flags = tmp_path / "flags"  # the same settings as flags alone
    assert _run(["slam", str(log), "--seed", "3", "--particles", "5", "--slam.updates.linear-m", "0.3",
                 "--no-slam.loops.closure", "--slam.motion.srr", "0.2", "--recording.map-every", "3",
                 "--out", str(flags), "--no-progress"]) == 0
    assert (flags / "trajectory.tum").read_bytes() == (first / "trajectory.tum").read_bytes()
    other = tmp_path / "other"  # the settings matter: the defaults give another trajectory
    assert _run(["slam", str(log), "--out", str(other), "--no-progress"]) == 0
    assert (other / "trajectory.tum").read_bytes() != (first / "trajectory.tum").read_bytes()
    old = dict(summary, config=_flat(cfg))  # a summary.json written before SlamConfig had sections
    assert "linear_update_m" in old["config"] and "loop_closure" in old["config"]
    (tmp_path / "old.json").write_text(json.dumps(old))
    flat = tmp_path / "flat"
    assert _run(["slam", str(log), "--config", str(tmp_path / "old.json"), "--out", str(flat), "--no-progress"]) == 0
    assert (flat / "trajectory.tum").read_bytes() == (first / "trajectory.tum").read_bytes()
    assert json.loads((flat / "summary.json").read_text())["config"] == cfg


def test_bad_settings_are_reported_by_the_name_given(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = tmp_path / "corridor.clf"
    _write_clf(log)
    out = ["--out", str(tmp_path / "x"), "--no-progress"]
    for flags, message in ((["--particles", "0"], "--particles must be > 0, got 0"),
                           (["--slam.n-particles", "0"], "--slam.n-particles must be > 0, got 0"),
                           (["--slam.updates.resample-threshold", "2"],
                            "--slam.updates.resample-threshold must be in [0, 1], got 2.0"),
                           (["--slam.map.tile-cells", "12"], "--slam.map.tile-cells must be a power of two, got 12"),
                           (["--rrd-map-every", "-1"],
                            "--rrd-map-every must be >= 0 and --recording.flush-updates >= 1, got -1, 50")):
        assert _run(["slam", str(log), *flags, *out]) == 2
        assert capsys.readouterr().err.strip() == f"mcnkit slam: {message}", flags
    bad = tmp_path / "bad.toml"
    bad.write_text("[slam.motion]\nsrr = -1.0\n")
    assert _run(["slam", str(log), "--config", str(bad), *out]) == 2
    assert capsys.readouterr().err.strip() == f"mcnkit slam: {bad}: slam.motion.srr must be >= 0, got -1.0"
    bad = tmp_path / "bad.toml"
    bad.write_text("[slam]\nn_particle = 6\n")
    assert _run(["slam", str(log), "--config", str(bad), "--out", str(tmp_path / "x"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("mcnkit slam: ") and err.endswith(f"{bad}: unknown SlamConfig setting: n_particle"), err
    bad.write_text("[slam]\nn_particles = 'six'\n")
    assert _run(["slam", str(log), "--config", str(bad), "--out", str(tmp_path / "x"), "--no-progress"]) == 2
    assert "n_particles: expected int" in capsys.readouterr().err


def test_the_whole_log_graph_is_asked_for_by_a_flag_and_its_edges_go_into_the_summary(tmp_path: Path) -> None:
    from mcnkit.metrics import read_tum

    log = tmp_path / "corridor.clf"
    _write_clf(log)
    runs = {}
    for name, flags in [("default", []), ("graph", ["--slam.offline.whole-graph"])]:
        out = tmp_path / name
        assert _run(["slam", str(log), "--particles", "4", "--out", str(out), "--no-progress", *flags]) == 0
        runs[name] = (json.loads((out / "summary.json").read_text()), read_tum(out / "trajectory.tum").poses)
    assert runs["default"][0]["whole_graph"] is None and not runs["default"][0]["config"]["offline"]["whole_graph"]
    summary, poses = runs["graph"]
    assert summary["config"]["offline"]["whole_graph"]
    assert summary["whole_graph"]["nodes"] == summary["filter_updates"] and summary["whole_graph"]["step_edges"] > 0
    assert len(poses) == len(runs["default"][1])
    # the log's robot drives 0.1 m a scan along x towards an end wall that pins every step
    assert np.abs(poses[:, 0] - 0.1 * np.arange(len(poses))).max() < 0.05 and np.abs(poses[:, 1:]).max() < 0.05


def test_a_scan_only_bag_runs_lidar_only_and_any_log_can(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from mcnkit.geometry import compose, relative
    from mcnkit.io import LogContent, write_log
    from mcnkit.metrics import read_tum
    from mcnkit.types import Frame, Pose2D, Scan
    from tests.slam.test_fastslam import LIDAR, cast, true_path

    rng = np.random.default_rng(0)
    truth = true_path()[:80]
    frames = [Frame(10**9 + k * 10**8, Scan(cast(p, rng), LIDAR), Pose2D.from_array(p)) for k, p in enumerate(truth)]
    bag = write_log(tmp_path / "scan_only", LogContent(frames, odometry=False), "ros2-mcap")
    out = tmp_path / "out"
    assert _run(["slam", str(bag), "--particles", "5", "--out", str(out), "--no-progress"]) == 0
    assert "lidar-only" in capsys.readouterr().out
    summary = json.loads((out / "summary.json").read_text())
    assert summary["lidar_only"] and summary["unknown_motion_scans"] == len(frames) - 1
    est = read_tum(out / "trajectory.tum").poses
    moved = compose(truth[0], relative(est[0], est))  # from the true start: a log without odometry has no frame
    # along the 8 m drive the walls pin the robot's motion to within 1-2 % (the room's far walls, seen end-on)
    assert np.hypot(*(moved[:, :2] - truth[:, :2]).T).max() < 0.15
    clf = tmp_path / "corridor.clf"  # a log with odometry, run with it ignored
    _write_clf(clf)
    ignored = tmp_path / "ignored"
    argv = ["slam", str(clf), "--particles", "4", "--out", str(ignored), "--no-progress"]
    assert _run([*argv, "--slam.motion.odometry", "ignore"]) == 0
    summary = json.loads((ignored / "summary.json").read_text())
    assert summary["lidar_only"] and summary["config"]["motion"]["odometry"] == "ignore"
    assert summary["unknown_motion_scans"] == 29
