"""open_log on every fixture written by real ROS tools and on the three real-lab logs."""

from __future__ import annotations

import gzip
import warnings
from pathlib import Path

import numpy as np
import pytest

from mcnkit.io import CarmenLog, LogWarning, open_log
from mcnkit.io.info import describe

FIXTURES = [
    "rosbag_js/example.bag", "rosbag_js/example-bz2.bag", "rosbag_js/example-lz4.bag",
    "rosbag_js/example-unsorted-chunks.bag", "rosbag_js/no-messages.bag",
    "rosbag2/mcap_cdr_test", "rosbag2/mcap_convert_a", "rosbag2/mcap_talker", "rosbag2/mcap_wbag",
    "rosbag2/sqlite3_cdr_test", "rosbag2/sqlite3_convert_a", "rosbag2/sqlite3_talker", "rosbag2/sqlite3_wbag",
    "rosbag_analyzer_web/test_sample.bag", "rosbag_analyzer_web/test_sample.mcap",
    "rosbag_analyzer_web/test_sample.mcap.zstd", "rosbag_analyzer_web/test_sample_no_rosout.bag",
    "rosbag_analyzer_web/test_sample_no_rosout.mcap", "rosbag_analyzer_web/test_sample_truncated.mcap",
    "rosbag_analyzer_web/test_truncated.bag", "rosbag_analyzer_web/test_unindexed.bag",
]


def test_the_fixture_list_covers_every_fixture(shared_data: Path) -> None:
    root = shared_data / "fixtures"
    on_disk = {str(p.relative_to(root)) for p in root.glob("*/*") if p.name != "SOURCE_COMMIT.txt"}
    assert on_disk == set(FIXTURES)


@pytest.mark.parametrize("name", FIXTURES)
def test_info_reads_every_fixture(shared_data: Path, name: str) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        with open_log(shared_data / "fixtures" / name) as log:
            info = describe(log)
    assert info["format"] in {"ros1", "ros2-sqlite3", "ros2-mcap", "mcap-ros2", "mcap-ros1"}
    counts = {t["name"]: t["count"] for t in info["topics"]}  # type: ignore[index,union-attr]
    if name.startswith("rosbag_js/example") and "unsorted" not in name:
        assert counts["/turtle1/color_sensor"] == 1351 and counts["/tf_static"] == 1
        assert sum(counts.values()) == 8647
    if name.endswith("talker"):
        assert counts == {"/topic": 10, "/rosout": 10, "/parameter_events": 0}
    if name.endswith("wbag"):
        assert sum(counts.values()) == 6074


def test_looks_like_log_knows_every_format_by_its_signature_alone(shared_data: Path, tmp_path: Path) -> None:
    """``looks_like_log``: the signature check behind a command's "a robot log, not a trajectory file" hint."""
    from mcnkit.io import looks_like_log

    logs = [shared_data / "fixtures" / name for name in FIXTURES] + [
        shared_data / "reallab/radish/aces-corrected.log.gz", shared_data / "reallab/dpslam-loop5/loop5.log"]
    assert [p for p in logs if not looks_like_log(p)] == []
    (tmp_path / "t.tum").write_text("0.0 1 2 0 0 0 0 1\n")
    (tmp_path / "empty").write_bytes(b"")
    (tmp_path / "t.tum.gz").write_bytes(gzip.compress(b"0.0 1 2 0 0 0 0 1\n"))  # compressed, but no log inside
    (tmp_path / "folder").mkdir()
    assert not any(looks_like_log(tmp_path / n) for n in ("t.tum", "t.tum.gz", "empty", "folder", "missing.bag"))


def test_compressed_and_unsorted_bags_read_the_same_messages(shared_data: Path) -> None:
    root = shared_data / "fixtures" / "rosbag_js"

    def stamps(name: str, topic: str) -> list[int]:
        with open_log(root / name) as log:
            return [t for t, _ in log.messages(topic)]

    plain = stamps("example.bag", "/turtle1/pose")
    assert len(plain) == 1344 and plain == sorted(plain)
    assert stamps("example-bz2.bag", "/turtle1/pose") == plain == stamps("example-lz4.bag", "/turtle1/pose")
    unsorted = stamps("example-unsorted-chunks.bag", "foo")
    assert unsorted == sorted(unsorted) and len(unsorted) == 3


def test_damaged_files_are_read_as_far_as_the_data_goes(shared_data: Path) -> None:
    root = shared_data / "fixtures" / "rosbag_analyzer_web"
    for name, topic, n in [("test_truncated.bag", "/rosout_agg", 3), ("test_unindexed.bag", "/rosout_agg", 10),
                           ("test_sample_truncated.mcap", "/rosout", 10)]:
        with pytest.warns(LogWarning, match=name):
            log = open_log(root / name)
        with log:
            assert sum(1 for _ in log.messages(topic)) == n


def test_a_three_beam_laser_bag_without_odometry_is_read_lidar_only(shared_data: Path) -> None:
    with open_log(shared_data / "fixtures/rosbag_analyzer_web/test_sample_no_rosout.bag") as log:
        assert log.scan_topic == "/sensor/lidar/scan"
        assert log.lidar_spec.n_beams == 3
        assert log.odom_source == "" and log.lidar_only
        frames = list(log.frames())
    assert len(frames) == 3 and not any(f.odom_known for f in frames)
    assert all(f.odom == frames[0].odom for f in frames)


@pytest.mark.parametrize(
    ("path", "fmt", "scans", "beams"),
    [
        ("reallab/mit-csail/mit-csail.clf", "carmen", 1988, 361),
        ("reallab/intel/intel-corrected.log.gz", "carmen-corrected", 910, 180),
        ("reallab/dpslam-loop5/loop5.log", "dpslam", 551, 181),
    ],
)
def test_real_lab_logs_have_the_published_counts(shared_data: Path, path: str, fmt: str, scans: int, beams: int) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        with open_log(shared_data / path) as log:
            info = describe(log)
            frames = list(log.frames())
    assert info["format"] == fmt and info["scans"] == scans
    assert info["scanner"]["beams"] == beams  # type: ignore[index]
    assert len(frames) == scans
    assert all(f.scan.ranges_m.shape == (beams,) for f in frames)
    stamps = [f.stamp_ns for f in frames]
    assert stamps == sorted(stamps)


def test_mit_csail_geometry_and_no_return_sentinel(shared_data: Path) -> None:
    log = CarmenLog(shared_data / "reallab/mit-csail/mit-csail.clf")
    spec = log.lidar_spec
    assert np.isclose(np.degrees(spec.angle_min_rad), -90.0) and np.isclose(np.degrees(spec.angle_max_rad), 90.0)
    first = next(iter(log.frames()))
    assert not first.scan.valid[first.scan.ranges_m >= 81.9].any()  # 81.91 = no return
    assert first.stamp_ns == 1134864629_895182000  # exact, parsed from the decimal text


def test_intel_corrected_log_rebuilds_drifting_raw_odometry(shared_data: Path) -> None:
    with pytest.warns(LogWarning, match="4 earlier than the scan before; kept in log order"):
        log = open_log(shared_data / "reallab/intel/intel-corrected.log.gz")
    gt = log.ground_truth()
    assert gt is not None and len(gt) == 910
    odom = np.array([f.odom.as_array() for f in log.frames()])
    assert np.allclose(odom[0], gt.poses[0])
    drift = np.hypot(*(odom[-1, :2] - gt.poses[-1, :2]))
    assert 30.0 < drift < 120.0  # the well-known raw odometry ends tens of metres off


def test_dpslam_loop_has_no_timestamps_so_frames_are_evenly_stamped(shared_data: Path) -> None:
    with open_log(shared_data / "reallab/dpslam-loop5/loop5.log") as log:
        stamps = np.array([f.stamp_ns for f in log.frames()])
    assert (np.diff(stamps) == 200_000_000).all()
