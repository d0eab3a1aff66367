"""A scanner that reports several echoes per beam (``sensor_msgs/MultiEchoLaserScan``, as in Cartographer's backpack
logs) is read as the LaserScan of its first echoes, and a beam without an echo is no return."""

from __future__ import annotations

import contextlib
import io
import json
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_typestore

from mcnkit.io import LogWarning, open_log
from mcnkit.types import Frame, Pose2D

MULTI = "sensor_msgs/msg/MultiEchoLaserScan"
SCAN = "sensor_msgs/msg/LaserScan"


@pytest.fixture(scope="module")
def mit_scans(shared_data: Path) -> list[Frame]:
    """The first 120 scans of MIT CSAIL (180 beams, 1°): a turn in place, then 5 m of driving."""
    frames = []
    with open_log(shared_data / "reallab/mit-csail/mit-csail.clf") as log:
        for f in log.frames():
            frames.append(f)
            if len(frames) == 120:
                break
    return frames


def _header(types: dict, stamp: int, ros1: bool) -> object:
    time = types["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9)
    if ros1:
        return types["std_msgs/msg/Header"](seq=0, stamp=time, frame_id="horizontal_laser_link")
    return types["std_msgs/msg/Header"](stamp=time, frame_id="horizontal_laser_link")


def _messages(frames: list[Frame], types: dict, ros1: bool) -> list[tuple[int, object, object]]:
    """Per frame: its stamp, the scan as a MultiEchoLaserScan (each return's first echo its range, a second echo 2 m
    behind it; no echo where the scanner saw nothing) and as a LaserScan of the same first echoes."""
    out = []
    for f in frames:
        spec, r = f.scan.spec, f.scan.ranges_m
        seen = f.scan.valid
        echo = types["sensor_msgs/msg/LaserEcho"]
        beams = [echo(echoes=np.array([v, v + 2.0] if ok else [], np.float32)) for v, ok in zip(r, seen, strict=True)]
        common = {"angle_min": spec.angle_min_rad, "angle_increment": spec.angle_increment_rad,
                  "angle_max": spec.angle_min_rad + (spec.n_beams - 1) * spec.angle_increment_rad,
                  "time_increment": 0.0, "scan_time": 0.0, "range_min": spec.range_min_m, "range_max": spec.range_max_m}
        multi = types[MULTI](header=_header(types, f.stamp_ns, ros1), ranges=beams,
                             intensities=[echo(echoes=np.zeros(0, np.float32)) for _ in beams], **common)
        first = types[SCAN](header=_header(types, f.stamp_ns, ros1), ranges=np.where(seen, r, np.nan).astype(np.float32),
                            intensities=np.zeros(0, np.float32), **common)
        out.append((f.stamp_ns, multi, first))
    return out


def write_multi_echo(path: Path, frames: list[Frame], fmt: str, with_laserscan: bool = False,
                     with_vertical: bool = False) -> Path:
    """A scan-only log of ``frames`` on ``/horizontal_laser_2d`` as MultiEchoLaserScan (``fmt`` ros1 or mcap); with
    ``with_laserscan`` the same first echoes as LaserScan on ``/scan``; with ``with_vertical`` a second scanner on
    ``/vertical_laser_2d`` that sends twice as many scans (a backpack's)."""
    ros1 = fmt == "ros1"
    store = get_typestore(Stores.ROS1_NOETIC if ros1 else Stores.ROS2_HUMBLE)
    ser = store.serialize_ros1 if ros1 else store.serialize_cdr
    writer = Ros1Writer(path) if ros1 else Ros2Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    with writer as w:
        c_multi = w.add_connection("/horizontal_laser_2d", MULTI, typestore=store)
        c_scan = w.add_connection("/scan", SCAN, typestore=store) if with_laserscan else None
        c_vertical = w.add_connection("/vertical_laser_2d", MULTI, typestore=store) if with_vertical else None
        for stamp, multi, first in _messages(frames, store.types, ros1):
            w.write(c_multi, stamp, ser(multi, MULTI))
            if c_vertical is not None:
                w.write(c_vertical, stamp, ser(multi, MULTI))
                w.write(c_vertical, stamp + 1000, ser(multi, MULTI))
            if c_scan is not None:
                w.write(c_scan, stamp, ser(first, SCAN))
    return path


@pytest.mark.parametrize(("fmt", "name"), [("ros1", "backpack.bag"), ("mcap", "backpack")])
def test_a_multi_echo_scanner_reads_as_its_first_echoes(tmp_path: Path, mit_scans: list[Frame], fmt: str,
                                                        name: str) -> None:
    path = write_multi_echo(tmp_path / name, mit_scans, fmt)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)  # no odometry, no mount: said once each
        with open_log(path) as log:
            assert log.scan_topic == "/horizontal_laser_2d" and log.lidar_only
            spec = log.lidar_spec
            got = list(log.frames())
    first = mit_scans[0].scan.spec
    assert (spec.n_beams, spec.angle_min_rad, spec.range_max_m) == (first.n_beams, pytest.approx(first.angle_min_rad),
                                                                     pytest.approx(first.range_max_m))
    assert len(got) == len(mit_scans) and not any(f.odom_known for f in got)
    for a, b in zip(got, mit_scans, strict=True):
        assert a.stamp_ns == b.stamp_ns and a.odom == Pose2D()
        np.testing.assert_array_equal(a.scan.valid, b.scan.valid)  # a beam without an echo is no return
        np.testing.assert_array_equal(a.scan.ranges_m[a.scan.valid], b.scan.ranges_m[b.scan.valid])


def test_a_backpacks_vertical_scanner_is_not_read_and_the_choice_is_said(tmp_path: Path,
                                                                         mit_scans: list[Frame]) -> None:
    path = write_multi_echo(tmp_path / "backpack.bag", mit_scans[:5], "ros1", with_vertical=True)
    with pytest.warns(LogWarning, match="2 scan topics: reading /horizontal_laser_2d "
                                        r"\(not /vertical_laser_2d; --scan-topic chooses\)"):
        with open_log(path) as log:
            assert log.scan_topic == "/horizontal_laser_2d"


def test_a_laserscan_topic_is_preferred_and_both_read_the_same_frames(tmp_path: Path, mit_scans: list[Frame]) -> None:
    path = write_multi_echo(tmp_path / "both.bag", mit_scans, "ros1", with_laserscan=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        with open_log(path) as log:
            assert log.scan_topic == "/scan"
            plain = list(log.frames())
        with open_log(path, scan_topic="/horizontal_laser_2d") as log:
            echoes = list(log.frames())
    assert all(np.array_equal(a.scan.ranges_m, b.scan.ranges_m, equal_nan=True) and a.stamp_ns == b.stamp_ns
               for a, b in zip(plain, echoes, strict=True))


def test_info_names_the_multi_echo_topic_and_slam_runs_lidar_only_on_the_topic_chosen(
        tmp_path: Path, mit_scans: list[Frame]) -> None:
    from mcnkit.app.main import main

    path = write_multi_echo(tmp_path / "backpack.bag", mit_scans, "ros1", with_laserscan=True)
    run = tmp_path / "run"
    with contextlib.redirect_stdout(io.StringIO()) as said, warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        assert main(["info", str(path), "--scan-topic", "/horizontal_laser_2d"]) == 0
        assert main(["slam", str(path), "--scan-topic", "/horizontal_laser_2d", "--out", str(run), "--no-progress"]) == 0
    text = said.getvalue()
    assert "scan      /horizontal_laser_2d" in text and "MultiEchoLaserScan" in text and "lidar-only" in text
    summary = json.loads((run / "summary.json").read_text())
    assert summary["scan_topic"] == "/horizontal_laser_2d" and summary["lidar_only"]
    poses = np.loadtxt(run / "trajectory.tum")[:, 1:3]
    a, b = mit_scans[0].odom, mit_scans[-1].odom  # the odometry the log left out says how far the robot went
    driven = math.hypot(b.x_m - a.x_m, b.y_m - a.y_m)
    assert len(poses) == len(mit_scans) and driven > 4.0
    assert abs(math.hypot(*(poses[-1] - poses[0])) - driven) < 0.2


def test_a_scan_topic_the_log_lacks_is_one_line_naming_the_flag(tmp_path: Path, mit_scans: list[Frame],
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    from mcnkit.app.main import main

    path = write_multi_echo(tmp_path / "backpack.bag", mit_scans[:5], "ros1")
    assert main(["slam", str(path), "--scan-topic", "/vertical_laser_2d", "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "/vertical_laser_2d" in err[0] and "/horizontal_laser_2d" in err[0]
    assert not (tmp_path / "run").exists()
