"""Logs without odometry are read, not refused: every frame's motion is unknown; odometry can be ignored; gaps in
the odometry are unknown motion, not zero."""

from __future__ import annotations

import contextlib
import io
import warnings
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer

from mcnkit.io import LogContent, LogWarning, open_log, write_log
from mcnkit.io.decode import MessageDecoder
from mcnkit.types import Frame, Pose2D
from tests.conftest import make_frames


@pytest.fixture(scope="module")
def mit_first_scans(shared_data: Path) -> list[Frame]:
    """The first 60 scans of MIT CSAIL, with their odometry."""
    with open_log(shared_data / "reallab/mit-csail/mit-csail.clf") as log:
        frames = []
        for f in log.frames():
            frames.append(f)
            if len(frames) == 60:
                break
    return frames


@pytest.mark.parametrize(("fmt", "name"), [("ros1", "scan_only.bag"), ("mcap", "scan_only.mcap"),
                                           ("ros2-sqlite3", "scan_only_sqlite3")])
def test_a_scan_only_log_reads_lidar_only(tmp_path: Path, mit_first_scans: list[Frame], fmt: str, name: str) -> None:
    path = write_log(tmp_path / name, LogContent(mit_first_scans, odometry=False), fmt)
    with warnings.catch_warnings():
        warnings.simplefilter("error", LogWarning)
        with open_log(path) as log:
            assert {t.name for t in log.topics} == {"/scan", "/tf_static"}
            assert log.odom_source == "" and log.lidar_only
            got = list(log.frames())
    assert len(got) == len(mit_first_scans)
    assert not any(f.odom_known for f in got) and all(f.odom == Pose2D() for f in got)
    assert all(np.array_equal(a.scan.ranges_m, b.scan.ranges_m) and a.stamp_ns == b.stamp_ns
               for a, b in zip(got, mit_first_scans, strict=True))


def test_info_says_no_odometry_lidar_only(tmp_path: Path, mit_first_scans: list[Frame]) -> None:
    from mcnkit.app.main import main

    path = write_log(tmp_path / "scan_only.bag", LogContent(mit_first_scans, odometry=False))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["info", str(path)]) == 0
    assert "odometry  no odometry: lidar-only" in out.getvalue()


@pytest.mark.parametrize("log", ["reallab/mit-csail/mit-csail.clf", "reallab/intel/intel-corrected.log.gz"])
def test_any_log_reads_lidar_only_with_its_odometry_ignored(shared_data: Path, log: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        with open_log(shared_data / log) as used:
            plain = list(used.frames())
        with open_log(shared_data / log, odometry="ignore") as ignored:
            assert ignored.lidar_only and ignored.odom_source
            got = list(ignored.frames())
    assert [f.stamp_ns for f in got] == [f.stamp_ns for f in plain]
    assert not any(f.odom_known for f in got) and all(f.odom == Pose2D() for f in got)


def test_convert_with_odometry_ignored_writes_a_scan_only_log(tmp_path: Path, shared_data: Path) -> None:
    from mcnkit.app.main import main

    out = tmp_path / "scan_only.mcap"
    with contextlib.redirect_stdout(io.StringIO()) as said:
        assert main(["convert", str(shared_data / "reallab/mit-csail/mit-csail.clf"), str(out), "--odometry", "ignore",
                     "--quiet"]) == 0
    assert "1988 scans without odometry (lidar-only)" in said.getvalue()
    with open_log(out) as log:
        assert log.lidar_only and log.odom_source == ""
        assert sum(1 for f in log.frames() if not f.odom_known) == 1988


def _bag_with_odometry_gaps(path: Path, frames: list[Frame], missing: range) -> None:
    """Scans at 10 Hz, odometry with each except for ``missing`` (an odometry stream that stopped for a while)."""
    from mcnkit.io.writers import _Msgs

    ts = MessageDecoder().typestore("ros1")
    b = _Msgs(ts, ros1=True)
    with Writer(path) as w:
        cs = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        co = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
        for i, f in enumerate(frames):
            w.write(cs, f.stamp_ns, ts.serialize_ros1(b.scan(f), "sensor_msgs/msg/LaserScan"))
            if i not in missing:
                w.write(co, f.stamp_ns, ts.serialize_ros1(b.odometry(f.stamp_ns, f.odom, "odom"), "nav_msgs/msg/Odometry"))


def test_a_gap_in_the_odometry_is_unknown_motion_and_the_poses_after_it_keep_their_steps(tmp_path: Path) -> None:
    from mcnkit.geometry import relative

    frames = make_frames(n=40)
    _bag_with_odometry_gaps(tmp_path / "gaps.bag", frames, range(15, 25))  # a second without odometry
    with pytest.warns(LogWarning, match=r"no odometry within 0\.25 s of 7 of 40 scans .*read as unknown motion"):
        with open_log(tmp_path / "gaps.bag") as log:
            got = list(log.frames())
    assert len(got) == 40
    # farther than 0.25 s from any odometry: 17-22; 23 is the first scan after them, its motion since 22 unknown too
    assert [i for i, f in enumerate(got) if not f.odom_known] == list(range(17, 24))
    assert all(got[i].odom == got[16].odom for i in range(17, 24))  # unknown motion carries no step
    for i in range(24, 40):  # then the odometry's own steps again
        assert np.allclose(relative(got[i - 1].odom.as_array(), got[i].odom.as_array()),
                           relative(frames[i - 1].odom.as_array(), frames[i].odom.as_array()), atol=1e-9)


def test_scans_before_the_odometry_starts_are_read_as_unknown_motion(tmp_path: Path) -> None:
    frames = make_frames(n=20)
    _bag_with_odometry_gaps(tmp_path / "late.bag", frames, range(0, 5))  # odometry from 1.5 s, scans from 1.0 s
    with pytest.warns(LogWarning, match=r"of 4 of 20 scans .*read as unknown motion"):
        with open_log(tmp_path / "late.bag") as log:
            got = list(log.frames())
    assert len(got) == 20
    assert [f.odom_known for f in got[:5]] == [False, False, False, False, True] and all(f.odom_known for f in got[5:])


def test_rawlaser_lines_without_an_odom_stream_are_a_lidar_only_log(tmp_path: Path) -> None:
    ranges = " ".join(["2.5"] * 181)
    lines = [f"RAWLASER1 0 -1.5708 3.14159 0.0174533 81.9 0.01 0 181 {ranges} 0 {1 + 0.2 * k:.1f} host {1 + 0.2 * k:.1f}"
             for k in range(10)]
    path = tmp_path / "raw.log"
    path.write_text("\n".join(lines) + "\n")
    with open_log(path) as log:
        assert log.lidar_only and log.odom_source == ""
        assert [t.name for t in log.topics] == ["/scan"]
        got = list(log.frames())
    assert len(got) == 10 and not any(f.odom_known for f in got)
