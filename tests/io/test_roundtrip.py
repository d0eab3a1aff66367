"""write_log → open_log gives back identical frames in every format, including the real-lab logs."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from mcnkit.io import GroundTruthMap, LogContent, LogWarning, open_log, write_log
from mcnkit.types import Frame, Trajectory

ALL_FORMATS = {"ros1": "log.bag", "ros2-sqlite3": "log_sqlite3", "ros2-mcap": "log_mcap", "mcap": "log.mcap",
               "mcap-ros1": "log_ros1.mcap"}
EXPECTED_READ_FORMAT = {"ros1": "ros1", "ros2-sqlite3": "ros2-sqlite3", "ros2-mcap": "ros2-mcap",
                        "mcap": "mcap-ros2", "mcap-ros1": "mcap-ros1"}


def assert_same_frames(a: list[Frame], b: list[Frame]) -> None:
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert x.stamp_ns == y.stamp_ns
        assert x.scan.ranges_m.dtype == y.scan.ranges_m.dtype == np.float32
        assert np.array_equal(x.scan.ranges_m, y.scan.ranges_m, equal_nan=True)
        assert np.allclose(x.odom.as_array(), y.odom.as_array(), rtol=0, atol=1e-12)
    sa, sb = a[0].scan.spec, b[0].scan.spec
    assert sa.n_beams == sb.n_beams
    assert np.allclose([sa.angle_min_rad, sa.angle_increment_rad, sa.range_min_m, sa.range_max_m],
                       [sb.angle_min_rad, sb.angle_increment_rad, sb.range_min_m, sb.range_max_m], rtol=1e-6)
    assert np.allclose(sa.base_to_laser.as_array(), sb.base_to_laser.as_array(), atol=1e-12)


@pytest.mark.parametrize("fmt", list(ALL_FORMATS))
def test_generated_frames_round_trip(tmp_path: Path, frames: list[Frame], fmt: str) -> None:
    gt = Trajectory(np.array([f.stamp_ns for f in frames[::2]]), np.array([f.odom.as_array() for f in frames[::2]]))
    grid = np.full((3, 4), -1, np.int8)
    grid[1, 1:3] = 100
    grid[2] = 0
    gmap = GroundTruthMap(frames[0].stamp_ns, 0.05, -1.0, -2.0, grid)
    path = write_log(tmp_path / ALL_FORMATS[fmt], LogContent(frames, ground_truth=gt, ground_truth_map=gmap), fmt)
    with open_log(path) as log:
        assert log.format == EXPECTED_READ_FORMAT[fmt]
        assert log.scan_topic == "/scan" and log.odom_source == "/odom"
        assert_same_frames(frames, list(log.frames()))
        back = log.ground_truth()
        assert back is not None and np.array_equal(back.stamps_ns, gt.stamps_ns)
        assert np.allclose(back.poses, gt.poses, atol=1e-12)
        m = log.ground_truth_map()
        assert m is not None and np.array_equal(m.data, grid) and (m.resolution_m, m.origin_x_m) == (0.05, -1.0)
        counts = {t.name: t.count for t in log.topics}
    assert counts == {"/scan": 20, "/odom": 20, "/tf": 20, "/tf_static": 1, "/ground_truth": 10, "/map_gt": 1}


def test_odometry_from_tf_when_there_is_no_odometry_topic(tmp_path: Path, frames: list[Frame]) -> None:
    path = write_log(tmp_path / "tf_only.bag", LogContent(frames, odom_topic=None))
    with open_log(path) as log:
        assert log.odom_source == "tf:odom->base_link"
        assert_same_frames(frames, list(log.frames()))


def test_odometry_is_interpolated_at_the_scan_stamp(tmp_path: Path, frames: list[Frame]) -> None:
    # Keep odometry at even frames only: odd scans fall halfway between two odometry poses.
    path = write_log(tmp_path / "full.bag", LogContent(frames))
    with open_log(path, odom="/odom") as log:
        assert log.odom_source == "/odom"
    from rosbags.rosbag1 import Writer

    from mcnkit.io.decode import MessageDecoder
    from mcnkit.io.writers import _Msgs  # build a bag whose odometry is at half the scan rate

    ts = MessageDecoder().typestore("ros1")
    b = _Msgs(ts, ros1=True)
    half = tmp_path / "half.bag"
    with Writer(half) as w:
        cs = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        co = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
        for i, f in enumerate(frames):
            w.write(cs, f.stamp_ns, ts.serialize_ros1(b.scan(f), "sensor_msgs/msg/LaserScan"))
            if i % 2 == 0:
                w.write(co, f.stamp_ns, ts.serialize_ros1(b.odometry(f.stamp_ns, f.odom, "odom"), "nav_msgs/msg/Odometry"))
    with open_log(half) as log:
        back = list(log.frames())
    assert len(back) == len(frames)  # the last scan is 0.1 s past the last odometry: within the gap, held
    for i in range(1, len(frames) - 2, 2):
        assert np.allclose(back[i].odom.as_array(), frames[i].odom.as_array(), atol=1e-9)


@pytest.mark.parametrize("log_name", ["mit-csail/mit-csail.clf", "intel/intel-corrected.log.gz"])
def test_real_lab_logs_convert_to_all_four_formats_and_read_back_identical(
    tmp_path: Path, shared_data: Path, log_name: str
) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        src = open_log(shared_data / "reallab" / log_name)
    original = list(src.frames())
    content = LogContent(original, ground_truth=src.ground_truth())
    for fmt in ("ros1", "ros2-sqlite3", "ros2-mcap", "mcap"):
        path = write_log(tmp_path / ALL_FORMATS[fmt], content, fmt)
        with open_log(path) as log:
            assert_same_frames(original, list(log.frames()))
            if content.ground_truth is not None:
                back = log.ground_truth()
                assert back is not None and np.array_equal(back.stamps_ns, content.ground_truth.stamps_ns)


def test_writer_refuses_to_overwrite_and_never_leaves_partial_files(tmp_path: Path, frames: list[Frame]) -> None:
    from mcnkit.io import LogError

    path = write_log(tmp_path / "a.bag", LogContent(frames))
    with pytest.raises(LogError, match="exists already"):
        write_log(path, LogContent(frames))
    write_log(path, LogContent(frames[:3]), overwrite=True)
    with open_log(path) as log:
        assert sum(1 for _ in log.frames()) == 3
    with pytest.raises(LogError, match="no frames"):
        write_log(tmp_path / "b.bag", LogContent([]))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.bag"]
