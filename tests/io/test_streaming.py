"""Every read path streams: truncated, unindexed and whole-file compressed logs give the frames the indexed read
gives, holding a chunk at a time; a camera topic beside the scans is never read."""

from __future__ import annotations

import gzip
import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest
import zstandard
from mcap.writer import CompressionType, IndexType
from mcap.writer import Writer as McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer

from mcnkit.io import LogWarning, open_log
from mcnkit.io.decode import MessageDecoder
from mcnkit.io.writers import _Msgs
from mcnkit.types import Frame
from tests.conftest import make_frames

IMAGE = 640 * 120 * 3
CHUNK = 256 << 10
_TYPES = {"/scan": "sensor_msgs/msg/LaserScan", "/odom": "nav_msgs/msg/Odometry", "/camera": "sensor_msgs/msg/Image"}


def _messages(frames: list[Frame], b: _Msgs) -> list[tuple[str, int, object]]:
    """Scans and odometry at 10 Hz, a 230 KB camera image beside every second scan."""
    out: list[tuple[str, int, object]] = []
    for i, f in enumerate(frames):
        out.append(("/scan", f.stamp_ns, b.scan(f)))
        out.append(("/odom", f.stamp_ns, b.odometry(f.stamp_ns, f.odom, "odom")))
        if i % 2 == 0:
            pixels = np.frombuffer(np.random.default_rng(i).bytes(IMAGE), np.uint8)
            out.append(("/camera", f.stamp_ns + 1, b.T[_TYPES["/camera"]](
                header=b.header(f.stamp_ns + 1, "camera"), height=120, width=640, encoding="rgb8", is_bigendian=0,
                step=1920, data=pixels)))
    return out


def camera_bag(path: Path, frames: list[Frame], compression: str = "none") -> Path:
    ts = MessageDecoder().typestore("ros1")
    b = _Msgs(ts, ros1=True)
    w = Ros1Writer(path)
    w.chunk_threshold = CHUNK
    if compression != "none":
        w.set_compression(Ros1Writer.CompressionFormat[compression.upper()])
    with w:
        conns = {t: w.add_connection(t, k, typestore=ts) for t, k in _TYPES.items()}
        for topic, stamp, msg in _messages(frames, b):
            w.write(conns[topic], stamp, ts.serialize_ros1(msg, _TYPES[topic]))
    return path


def camera_mcap(path: Path, frames: list[Frame], indexed: bool = True,
                compression: CompressionType = CompressionType.ZSTD) -> Path:
    ts = MessageDecoder().typestore("cdr")
    b = _Msgs(ts, ros1=False)
    with open(path, "wb") as f:
        w = McapWriter(f, chunk_size=CHUNK, compression=compression,
                       index_types=IndexType.ALL if indexed else IndexType.NONE, use_statistics=indexed)
        w.start(profile="ros2", library="test")
        chans = {}
        for topic, kind in _TYPES.items():
            sid = w.register_schema(kind, "ros2msg", ts.generate_msgdef(kind, ros_version=2)[0].encode())
            chans[topic] = w.register_channel(topic, "cdr", sid)
        for seq, (topic, stamp, msg) in enumerate(_messages(frames, b)):
            w.add_message(chans[topic], log_time=stamp, publish_time=stamp,
                          data=bytes(ts.serialize_cdr(msg, _TYPES[topic])), sequence=seq)
        w.finish()
    return path


def _read(path: Path) -> tuple[list[Frame], int]:
    """The frames, and the peak of Python memory allocated while reading them."""
    tracemalloc.start()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", LogWarning)
            with open_log(path) as log:
                frames = list(log.frames())
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    return frames, peak


def _same(a: list[Frame], b: list[Frame], atol: float = 0.0) -> bool:
    """Same stamps and ranges, and odometry equal (to ``atol``: written frames come back through quaternions)."""
    return len(a) == len(b) and all(
        x.stamp_ns == y.stamp_ns and np.array_equal(x.scan.ranges_m, y.scan.ranges_m, equal_nan=True)
        and np.allclose(x.odom.as_array(), y.odom.as_array(), rtol=0, atol=atol) for x, y in zip(a, b, strict=True))


@pytest.fixture(scope="module")
def frames() -> list[Frame]:
    """200 scans, 100 images: 23 MB in chunks of 256 KiB."""
    return make_frames(n=200, beams=360)


def _cut(path: Path, to: Path, fraction: float) -> Path:
    to.write_bytes(path.read_bytes()[: int(path.stat().st_size * fraction)])
    return to


@pytest.mark.parametrize("compression", ["none", "lz4"])
def test_a_truncated_bag_streams_and_gives_the_indexed_read_s_frames(tmp_path: Path, frames: list[Frame],
                                                                     compression: str) -> None:
    full = camera_bag(tmp_path / "full.bag", frames, compression)
    indexed, _ = _read(full)
    assert _same(indexed, frames, 1e-12)
    cut = _cut(full, tmp_path / "cut.bag", 0.8)
    with pytest.warns(LogWarning, match=r"cut\.bag: .*record by record"):
        open_log(cut).close()
    got, peak = _read(cut)
    assert 100 < len(got) < 200 and _same(got, indexed[: len(got)])
    assert peak < 4 << 20 < cut.stat().st_size / 4  # a few chunks at a time, not the file


@pytest.mark.parametrize("kind", ["unindexed", "cut", "zstd", "gzip"])
def test_an_mcap_without_a_usable_summary_streams_and_gives_the_same_frames(tmp_path: Path, frames: list[Frame],
                                                                           kind: str) -> None:
    full = camera_mcap(tmp_path / "full.mcap", frames, indexed=kind != "unindexed",
                       compression=CompressionType.NONE if kind in ("zstd", "gzip") else CompressionType.ZSTD)
    indexed, _ = _read(camera_mcap(tmp_path / "ref.mcap", frames))
    assert _same(indexed, frames, 1e-12)
    path = full
    if kind == "cut":
        path = _cut(full, tmp_path / "cut.mcap", 0.8)
    elif kind == "zstd":
        path = tmp_path / "log.mcap.zstd"
        path.write_bytes(zstandard.ZstdCompressor().compress(full.read_bytes()))
    elif kind == "gzip":
        path = tmp_path / "log.mcap.gz"
        path.write_bytes(gzip.compress(full.read_bytes(), compresslevel=1))
    got, peak = _read(path)
    assert _same(got, indexed[: len(got)]) and len(got) > (100 if kind == "cut" else 199)
    assert peak < 6 << 20 < full.stat().st_size / 3  # a chunk and a stream's buffers, not the file


def test_an_indexed_bag_of_uncompressed_chunks_never_reads_the_camera(tmp_path: Path, frames: list[Frame],
                                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from mcnkit.io import streams

    bag = camera_bag(tmp_path / "cam.bag", frames)
    read: list[int] = []
    pread = streams.FileBytes.read_at

    def counted(self: streams.FileBytes, offset: int, n: int) -> bytes:
        read.append(n)
        return pread(self, offset, n)

    monkeypatch.setattr(streams.FileBytes, "read_at", counted)
    with open_log(bag) as log:
        assert _same(list(log.frames()), frames, 1e-12)
    assert sum(read) < bag.stat().st_size / 5  # the images are 95 % of the file


def test_the_message_index_merges_its_spilled_runs_in_file_order_for_equal_times(monkeypatch: pytest.MonkeyPatch) -> None:
    from mcnkit.io import msgindex

    monkeypatch.setattr(msgindex, "RUN_ROWS", 7)
    rng = np.random.default_rng(0)
    times = rng.integers(0, 20, 100).tolist()
    conns = rng.integers(0, 3, 100).tolist()
    index = msgindex.MessageIndex()
    for i in range(0, 100, 5):
        index.add(times[i : i + 5], conns[i : i + 5], -1, list(range(i, i + 5)), [1] * 5)
    assert index._runs  # it spilled
    got = [row[4] for row in index.entries({0, 2})]
    expected = sorted((i for i in range(100) if conns[i] in (0, 2)), key=lambda i: times[i])  # a stable sort
    assert got == expected
    assert index.counts == {c: conns.count(c) for c in set(conns)}
    index.close()


def test_a_carmen_log_too_large_to_keep_its_readings_parses_them_again_identically(
    shared_data: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from mcnkit.io import carmen_parse

    path = shared_data / "reallab/intel/intel-corrected.log.gz"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        kept = list(open_log(path).frames())
        monkeypatch.setattr(carmen_parse, "_CACHE_BYTES", 0)
        log = open_log(path)
        assert log._ranges is None  # type: ignore[attr-defined]
        streamed = list(log.frames())
    assert _same(streamed, kept) and [f.odom_known for f in streamed] == [f.odom_known for f in kept]
