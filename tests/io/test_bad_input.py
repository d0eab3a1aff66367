"""Bad input: a clear one-line LogError naming the file, or a warning saying what was skipped."""

from __future__ import annotations

import gzip
import warnings
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag1 import Writer

from mcnkit.io import LogContent, LogError, LogWarning, open_log, write_log
from mcnkit.io.decode import MessageDecoder
from mcnkit.types import Frame
from tests.conftest import make_frames


def test_a_missing_path(tmp_path: Path) -> None:
    with pytest.raises(LogError, match=r"nope\.bag: no such file or folder"):
        open_log(tmp_path / "nope.bag")


def test_a_folder_that_is_not_a_bag(tmp_path: Path) -> None:
    (tmp_path / "notes.txt").write_text("hello")
    with pytest.raises(LogError, match="a folder that is not a ROS2 bag"):
        open_log(tmp_path)


def test_an_empty_file_and_a_text_file(tmp_path: Path) -> None:
    (tmp_path / "empty.bag").write_bytes(b"")
    (tmp_path / "readme.log").write_text("this is not a robot log\n")
    with pytest.raises(LogError, match=r"empty\.bag: empty file"):
        open_log(tmp_path / "empty.bag")
    with pytest.raises(LogError, match=r"readme\.log: not a robot log"):
        open_log(tmp_path / "readme.log")


def test_a_log_without_a_laser_topic(shared_data: Path) -> None:
    with open_log(shared_data / "fixtures/rosbag_js/example.bag") as log:
        assert log.scan_topic == ""
        with pytest.raises(LogError, match=r"no sensor_msgs/LaserScan \(or MultiEchoLaserScan\) topic"):
            next(iter(log.frames()))
    with pytest.raises(LogError, match="no LaserScan or MultiEchoLaserScan topic '/laser'"):
        open_log(shared_data / "fixtures/rosbag_js/example.bag", scan_topic="/laser")


def test_nan_inf_and_out_of_range_ranges_are_no_return(frames: list[Frame]) -> None:
    scan = frames[0].scan
    r = scan.ranges_m.copy()
    r[:4] = [np.nan, np.inf, 0.05, 10.5]  # range interval is [0.1, 10]
    from mcnkit.types import Scan

    assert Scan(r, scan.spec).valid[:4].tolist() == [False, False, False, False]
    assert Scan(r, scan.spec).valid[4:].all()


def _bag_with_scan_stamps(path: Path, frames: list[Frame], stamps_ns: list[int]) -> None:
    """Record order as given, header stamps as given (a sensor clock that jumps back)."""
    from mcnkit.io.writers import _Msgs

    ts = MessageDecoder().typestore("ros1")
    b = _Msgs(ts, ros1=True)
    with Writer(path) as w:
        cs = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        co = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
        for f, stamp in zip(frames, stamps_ns, strict=True):
            w.write(co, f.stamp_ns, ts.serialize_ros1(b.odometry(f.stamp_ns, f.odom, "odom"), "nav_msgs/msg/Odometry"))
            moved = Frame(stamp, f.scan, f.odom)
            w.write(cs, f.stamp_ns, ts.serialize_ros1(b.scan(moved), "sensor_msgs/msg/LaserScan"))


def test_scan_stamps_going_backwards_are_skipped_with_a_count(tmp_path: Path, frames: list[Frame]) -> None:
    stamps = [f.stamp_ns for f in frames]
    stamps[10] = stamps[5]  # one scan stamped half a second in the past
    _bag_with_scan_stamps(tmp_path / "back.bag", frames, stamps)
    with open_log(tmp_path / "back.bag") as log, pytest.warns(LogWarning, match=r"1 \(stamp went backwards\)"):
        back = list(log.frames())
    assert len(back) == len(frames) - 1
    assert [f.stamp_ns for f in back] == sorted(f.stamp_ns for f in back)


def test_carmen_lines_out_of_time_order_stay_in_log_order_restamped(tmp_path: Path) -> None:
    ranges = " ".join(["1.0"] * 181)
    lines = [f"FLASER 181 {ranges} 0 0 0 {x} 0 0 {t} host {t}" for x, t in [(0, "1.0"), (1, "3.0"), (2, "2.0"), (3, "4.0")]]
    lines.insert(1, "FLASER 181 1.0 garbage")
    path = tmp_path / "run.clf.gz"
    path.write_bytes(gzip.compress("\n".join(lines).encode()))
    with pytest.warns(LogWarning) as record:
        log = open_log(path)
    messages = " ".join(str(w.message) for w in record)
    assert "malformed line(s) skipped: 1 FLASER (first at line 2)" in messages
    assert "1 earlier than the scan before; kept in log order" in messages
    frames = list(log.frames())
    assert [f.odom.x_m for f in frames] == [0.0, 1.0, 2.0, 3.0]
    assert [f.stamp_ns for f in frames] == [1_000_000_000, 3_000_000_000, 3_500_000_000, 4_000_000_000]
    assert log.laser_lines == 5


def test_a_bag_cut_in_the_middle_reads_its_whole_chunks(tmp_path: Path) -> None:
    frames = make_frames(n=1500, beams=360)  # several LZ4 chunks: the ones before the cut survive
    path = write_log(tmp_path / "full.bag", LogContent(frames), "ros1")
    data = path.read_bytes()
    cut = tmp_path / "cut.bag"
    cut.write_bytes(data[: len(data) // 2])
    with pytest.warns(LogWarning, match=r"cut\.bag: .*record by record"):
        log = open_log(cut)
    with log:
        assert log.topics  # connections before the cut are known
        got = list(log.frames())
    assert 0 < len(got) < len(frames)
    assert all(np.array_equal(a.scan.ranges_m, b.scan.ranges_m, equal_nan=True) for a, b in zip(got, frames, strict=False))


def test_an_mcap_cut_in_the_middle_reads_its_whole_messages(tmp_path: Path, frames: list[Frame]) -> None:
    path = write_log(tmp_path / "full.mcap", LogContent(frames), "mcap")
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: int(len(data) * 0.8)])
    with pytest.warns(LogWarning, match=r"cut\.mcap: no usable summary"):
        log = open_log(cut)
    with log:
        assert sum(1 for _ in log.frames()) <= len(frames)


def test_a_rosbag2_folder_with_a_missing_file(tmp_path: Path, frames: list[Frame]) -> None:
    path = write_log(tmp_path / "bag2", LogContent(frames), "ros2-sqlite3")
    (path / "bag2.db3").unlink()
    with pytest.raises(LogError, match="missing"):
        open_log(path)


def test_a_map_beyond_its_memory_limit_is_a_clear_error() -> None:
    from mcnkit.slam.maps import MapLimitError, TiledHitMaps

    maps = TiledHitMaps(30, 0.05)
    maps.integrate(np.array([[0.0, 1.0]] * 30), np.array([[0.0, 1.0]] * 30))
    with pytest.raises(MapLimitError, match="the map would span"):
        maps.integrate(np.array([[0.0, 1e5]] * 30), np.array([[0.0, 1e5]] * 30))


def _moved(frames: list[Frame], i: int, dx: float) -> list[Frame]:
    from mcnkit.types import Pose2D

    out = list(frames)
    f = out[i]
    out[i] = Frame(f.stamp_ns, f.scan, Pose2D(f.odom.x_m + dx, f.odom.y_m, f.odom.yaw_rad))
    return out


def test_one_odometry_outlier_is_dropped_with_one_warning(frames: list[Frame]) -> None:
    from mcnkit.io.plausible import plausible_frames

    with pytest.warns(LogWarning, match=r"skipped scans: 1 \(odometry a robot cannot reach\)") as record:
        out = list(plausible_frames("x.bag", _moved(frames, 7, 50.0)))
    assert len(record) == 1
    assert [f.stamp_ns for f in out] == [f.stamp_ns for i, f in enumerate(frames) if i != 7]
    assert all(a.odom == b.odom for a, b in zip(out, [f for i, f in enumerate(frames) if i != 7], strict=True))


def test_a_lasting_odometry_jump_is_re_anchored_as_unknown_motion(frames: list[Frame]) -> None:
    from mcnkit.io.plausible import plausible_frames

    jumped = list(frames)
    for i in range(8, len(jumped)):
        jumped = _moved(jumped, i, 1e5)
    with pytest.warns(LogWarning, match=r"re-anchored after 1 jump"):
        out = list(plausible_frames("x.bag", jumped))
    assert len(out) == len(frames)
    assert out[8].odom == out[7].odom  # the pose repeats across the jump ...
    assert [i for i, f in enumerate(out) if not f.odom_known] == [8]  # ... and the motion there is unknown
    later = np.array([[f.odom.x_m, f.odom.y_m] for f in out[8:]])
    orig = np.array([[f.odom.x_m, f.odom.y_m] for f in frames[8:]])
    step = np.hypot(*np.diff(later, axis=0).T)
    assert np.allclose(step, np.hypot(*np.diff(orig, axis=0).T), atol=1e-9)  # the motion after it is kept


def test_a_stamp_that_jumped_ahead_does_not_hide_the_scans_after_it(frames: list[Frame]) -> None:
    from mcnkit.io.plausible import plausible_frames

    bad = list(frames)
    bad[3] = Frame(bad[3].stamp_ns + 10**12, bad[3].scan, bad[3].odom)
    with pytest.warns(LogWarning, match=r"1 \(stamp out of order\)"):
        out = list(plausible_frames("x.bag", bad))
    assert len(out) == len(frames) - 1


def test_every_reading_out_of_range_is_no_return_and_no_scan_is_dropped_for_it(frames: list[Frame]) -> None:
    from mcnkit.io.plausible import plausible_frames
    from mcnkit.types import Scan

    def with_range(f: Frame, v: float) -> Frame:
        r = f.scan.ranges_m.copy()
        r[0] = v
        return Frame(f.stamp_ns, Scan(r, f.scan.spec), f.odom)

    # REP 117: +inf nothing within range, -inf too close, NaN invalid; beyond range_max or below range_min: no return
    mixed = [with_range(f, v) for f, v in zip(frames, [np.inf, -np.inf, np.nan, 10.5, -3.0, 1e30, 0.05] * 3, strict=False)]
    with warnings.catch_warnings():
        warnings.simplefilter("error", LogWarning)
        got = list(plausible_frames("x.bag", mixed))
    assert len(got) == len(mixed)
    assert all(np.array_equal(a.scan.ranges_m, b.scan.ranges_m, equal_nan=True) for a, b in zip(got, mixed, strict=True))
    assert not any(f.scan.valid[0] for f in got)


def test_a_carmen_log_with_a_1e38_range_reads_and_maps(tmp_path: Path) -> None:
    from mcnkit.slam import FastSlam, SlamConfig

    lines = []
    for k in range(30):
        ranges = [f"{1.0 + 0.01 * i:.2f}" for i in range(181)]
        if k == 12:
            ranges[40] = "1e38"
        lines.append(f"FLASER 181 {' '.join(ranges)} {0.05 * k} 0 0 {0.05 * k} 0 0 {1 + 0.1 * k:.1f} host 0")
    path = tmp_path / "big.log"
    path.write_text("\n".join(lines) + "\n")
    with open_log(path) as log:
        assert log.lidar_spec.range_max_m < 3.0  # the 1e38 reading does not set the limit
        got = list(log.frames())
    assert len(got) == 30 and not got[12].scan.valid[40]  # read as no return
    slam = FastSlam(SlamConfig(n_particles=3), np.random.default_rng(0))
    for f in got:
        slam.step(f)
    assert slam.best_ternary().image.size < 10**6


def test_a_sqlite_row_with_a_non_integer_timestamp_is_skipped(tmp_path: Path, frames: list[Frame]) -> None:
    import sqlite3

    from mcnkit.io.info import describe

    path = write_log(tmp_path / "bag2", LogContent(frames), "ros2-sqlite3")
    db = sqlite3.connect(path / "bag2.db3")
    db.execute("UPDATE messages SET timestamp = X'0102' WHERE id = (SELECT min(id) FROM messages)")
    db.execute("UPDATE messages SET timestamp = 1.5 WHERE id = (SELECT max(id) FROM messages)")
    db.commit()
    db.close()
    with open_log(path) as log, pytest.warns(LogWarning, match=r"message row\(s\) whose timestamp is not an integer"):
        info = describe(log)
        start, end = info["start_ns"], info["end_ns"]
        assert isinstance(start, int) and isinstance(end, int) and start <= end
        assert 0 < len(list(log.frames())) <= len(frames)


def test_an_mcap_chunk_that_fails_its_crc_is_skipped_with_a_count(tmp_path: Path) -> None:
    frames = make_frames(n=1500, beams=360)  # four chunks
    path = write_log(tmp_path / "a.mcap", LogContent(frames), "mcap")
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x40  # inside the second compressed chunk
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    with open_log(bad) as log, pytest.warns(LogWarning, match=r"damaged chunk"):
        got = list(log.frames())
    clean = {f.stamp_ns: f for f in frames}
    assert len(got) < len(frames)
    assert all(np.array_equal(f.scan.ranges_m, clean[f.stamp_ns].scan.ranges_m, equal_nan=True) for f in got)


def _unchunked_copy(src: Path, dst: Path) -> Path:
    """``src`` rewritten without chunks but with a data-section CRC (what some MCAP writers produce)."""
    from mcap.reader import make_reader
    from mcap.writer import Writer

    with open(src, "rb") as f, open(dst, "wb") as out:
        reader = make_reader(f)
        summary = reader.get_summary()
        assert summary is not None
        w = Writer(out, use_chunking=False, enable_data_crcs=True)
        w.start(profile=reader.get_header().profile, library="test")
        schemas = {sid: w.register_schema(s.name, s.encoding, s.data) for sid, s in summary.schemas.items()}
        channels = {cid: w.register_channel(c.topic, c.message_encoding, schemas[c.schema_id])
                    for cid, c in summary.channels.items()}
        for _, channel, message in reader.iter_messages():
            w.add_message(channels[channel.id], log_time=message.log_time, publish_time=message.publish_time,
                          data=message.data, sequence=message.sequence)
        w.finish()
    return dst


def test_an_unchunked_mcap_failing_its_data_crc_is_refused(tmp_path: Path) -> None:
    """Without chunks the data section's CRC is the only check: damage anywhere in it refuses the file (there is
    no smaller unit to drop), instead of passing changed values on."""
    path = _unchunked_copy(write_log(tmp_path / "a.mcap", LogContent(make_frames(n=200, beams=90)), "mcap"),
                           tmp_path / "unchunked.mcap")
    with open_log(path) as log:
        assert len(list(log.frames())) == 200
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01  # one bit of one range, somewhere in the middle of the data section
    bad = tmp_path / "bad.mcap"
    bad.write_bytes(bytes(data))
    with pytest.raises(LogError, match=r"bad\.mcap: damaged: the data section does not match its CRC"):
        with open_log(bad) as log:
            list(log.frames())


def test_nan_ranges_in_a_carmen_log_are_no_returns_with_one_warning(tmp_path: Path) -> None:
    """CARMEN writes numbers: a ``nan`` there is damage, read as "no return" and counted in one warning."""
    lines = []
    for k in range(10):
        ranges = [f"{2.0 + 0.01 * i:.2f}" for i in range(181)]
        if k in (3, 4):
            ranges[10:13] = ["nan", "inf", "nan"]
        lines.append(f"FLASER 181 {' '.join(ranges)} {0.05 * k} 0 0 {0.05 * k} 0 0 {1 + 0.1 * k:.1f} host 0")
    path = tmp_path / "nan.log"
    path.write_text("\n".join(lines) + "\n")
    with pytest.warns(LogWarning, match=r"nan\.log: 6 range reading\(s\) in 2 scan\(s\) are not numbers"):
        with open_log(path) as log:
            got = list(log.frames())
    assert len(got) == 10
    assert np.isfinite(got[0].scan.ranges_m).all()


def test_a_converted_rosbag2_mcap_carries_crcs_so_a_damaged_chunk_is_dropped(tmp_path: Path) -> None:
    """rosbags stores CRC 0; mcnkit's writer adds chunk and data CRCs, so damage reads as a counted skip."""
    frames = make_frames(n=1500, beams=360)
    folder = write_log(tmp_path / "bag", LogContent(frames), "ros2-mcap", mcap_chunk_bytes=256 << 10)
    data_file = next(folder.glob("*.mcap"))
    data = bytearray(data_file.read_bytes())
    data[len(data) // 2] ^= 0x40
    data_file.write_bytes(bytes(data))
    with open_log(folder) as log, pytest.warns(LogWarning, match=r"damaged chunk"):
        got = list(log.frames())
    clean = {f.stamp_ns: f for f in frames}
    assert 0 < len(got) < len(frames)
    assert all(np.array_equal(f.scan.ranges_m, clean[f.stamp_ns].scan.ranges_m, equal_nan=True) for f in got)
