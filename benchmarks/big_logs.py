"""Large robot logs in every format a user records: MIT CSAIL's scans and odometry beside a camera topic.

:func:`write_big` writes one log of about ``size`` bytes: the 1,988 scans (361 beams) and raw odometry of the MIT
CSAIL log (``reallab/mit-csail/mit-csail.clf``), as LaserScan, Odometry and /tf, plus a camera-sized topic
(``sensor_msgs/Image``, 640 × 320 RGB, 614,400 bytes a message) spread evenly over the log's 424 s, as many images
as make up the size.  The images are noise (incompressible, like a real camera's under a fast compressor): the
file's size is the size named, compressed or not.  Formats (``FORMATS``):

* ``ros1``: a ROS1 bag as ``rosbag record`` writes it (uncompressed 1 MiB chunks, indexed); ``ros1-cut``: the same
  bag cut at 90 % (no index: the reader walks it record by record);
* ``mcap``: a ROS2-profile MCAP as ``ros2 bag record`` writes its storage (zstd chunks of 768 KiB, summary with
  chunk and message indexes); ``mcap-unindexed``: the same without chunk or message indexes and statistics;
  ``mcap-cut``: the chunked one cut at 90 %; ``mcap-zstd``: an uncompressed-chunk MCAP compressed as a whole
  (``.mcap.zstd``);
* ``ros2-sqlite3`` and ``ros2-mcap``: rosbag2 folders as rosbags writes them;
* ``carmen-gz``: the MIT CSAIL log's lines with camera images logged as hex text lines
  (``BUMBLEBEE_BASIC_STEREOIMAGE1 640 320 614400 ... <hex> ts host ts``, as CARMEN's camera logger does), gzip'd.
"""

from __future__ import annotations

import gzip
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import zstandard
from mcap.writer import CompressionType, IndexType
from mcap.writer import Writer as McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer

from mcnkit.io import open_log
from mcnkit.io.decode import MessageDecoder
from mcnkit.io.writers import _Msgs
from mcnkit.types import Frame

__all__ = ["FORMATS", "IMAGE_BYTES", "mit_frames", "write_big"]

FORMATS = {"ros1": "log.bag", "ros1-cut": "cut.bag", "mcap": "log.mcap", "mcap-unindexed": "unindexed.mcap",
           "mcap-cut": "cut.mcap", "mcap-zstd": "log.mcap.zstd", "ros2-sqlite3": "sqlite3", "ros2-mcap": "ros2mcap",
           "carmen-gz": "log.clf.gz"}
"""Format -> file (or folder) name."""
WIDTH, HEIGHT = 640, 320
IMAGE_BYTES = WIDTH * HEIGHT * 3
_TYPES = {"scan": "sensor_msgs/msg/LaserScan", "odom": "nav_msgs/msg/Odometry", "tf": "tf2_msgs/msg/TFMessage",
          "image": "sensor_msgs/msg/Image"}
_TOPICS = {"/scan": "scan", "/odom": "odom", "/tf": "tf", "/camera/image_raw": "image"}


def mit_frames(clf: Path) -> list[Frame]:
    """MIT CSAIL's frames as mcnkit reads them."""
    with open_log(clf) as log:
        return list(log.frames())


def _image_stamps(frames: list[Frame], n: int) -> list[int]:
    t0, t1 = frames[0].stamp_ns, frames[-1].stamp_ns
    return [int(t0 + (t1 - t0) * (i + 0.5) / n) for i in range(n)]


def _timeline(frames: list[Frame], n_images: int) -> Iterator[tuple[int, str, Any]]:
    """(stamp, kind, frame or image number) in time order."""
    images = iter(enumerate(_image_stamps(frames, n_images)))
    nxt = next(images, None)
    for f in frames:
        while nxt is not None and nxt[1] <= f.stamp_ns:
            yield nxt[1], "image", nxt[0]
            nxt = next(images, None)
        yield f.stamp_ns, "frame", f
    while nxt is not None:
        yield nxt[1], "image", nxt[0]
        nxt = next(images, None)


def _pixels(i: int) -> np.ndarray:
    return np.frombuffer(np.random.default_rng(i).bytes(IMAGE_BYTES), np.uint8)


def _messages(frames: list[Frame], n_images: int, b: _Msgs) -> Iterator[tuple[str, int, Any]]:
    """(topic, stamp, message) of the whole log in time order."""
    T = b.T
    for stamp, kind, item in _timeline(frames, n_images):
        if kind == "image":
            yield "/camera/image_raw", stamp, T[_TYPES["image"]](
                header=b.header(stamp, "camera"), height=HEIGHT, width=WIDTH, encoding="rgb8", is_bigendian=0,
                step=WIDTH * 3, data=_pixels(item))
        else:
            yield "/scan", stamp, b.scan(item)
            yield "/odom", stamp, b.odometry(stamp, item.odom, "odom")
            yield "/tf", stamp, b.tf(stamp, "odom", "base_link", item.odom)


def _ros1(path: Path, frames: list[Frame], n: int) -> None:
    ts = MessageDecoder().typestore("ros1")
    b = _Msgs(ts, ros1=True)
    with Ros1Writer(path) as w:
        conns = {t: w.add_connection(t, _TYPES[k], typestore=ts) for t, k in _TOPICS.items()}
        for topic, stamp, msg in _messages(frames, n, b):
            w.write(conns[topic], stamp, ts.serialize_ros1(msg, _TYPES[_TOPICS[topic]]))


def _mcap(path: Path, frames: list[Frame], n: int, compression: CompressionType, indexed: bool) -> None:
    ts = MessageDecoder().typestore("cdr")
    b = _Msgs(ts, ros1=False)
    with open(path, "wb") as f:
        w = McapWriter(f, chunk_size=768 << 10, compression=compression,
                       index_types=IndexType.ALL if indexed else IndexType.NONE, use_statistics=indexed,
                       use_summary_offsets=indexed)
        w.start(profile="ros2", library="mcnkit-bench")
        channels = {}
        for topic, kind in _TOPICS.items():
            sid = w.register_schema(_TYPES[kind], "ros2msg", ts.generate_msgdef(_TYPES[kind], ros_version=2)[0].encode())
            channels[topic] = w.register_channel(topic, "cdr", sid)
        for seq, (topic, stamp, msg) in enumerate(_messages(frames, n, b)):
            w.add_message(channels[topic], log_time=stamp, publish_time=stamp,
                          data=bytes(ts.serialize_cdr(msg, _TYPES[_TOPICS[topic]])), sequence=seq)
        w.finish()


def _ros2(path: Path, frames: list[Frame], n: int, storage: StoragePlugin) -> None:
    ts = MessageDecoder().typestore("cdr")
    b = _Msgs(ts, ros1=False)
    with Ros2Writer(path, version=9, storage_plugin=storage) as w:
        conns = {t: w.add_connection(t, _TYPES[k], typestore=ts) for t, k in _TOPICS.items()}
        for topic, stamp, msg in _messages(frames, n, b):
            w.write(conns[topic], stamp, ts.serialize_cdr(msg, _TYPES[_TOPICS[topic]]))


def _carmen(path: Path, clf: Path, frames: list[Frame], n: int) -> None:
    images = iter(enumerate(_image_stamps(frames, n)))
    nxt = next(images, None)
    with gzip.open(path, "wb", compresslevel=1) as out, open(clf, "rb") as src:
        for line in src:
            tok = line.split()
            stamp = int(float(tok[-3]) * 1e9) if len(tok) > 3 else 0
            while nxt is not None and nxt[1] <= stamp:
                t = f"{nxt[1] / 1e9:.6f}"
                out.write(f"BUMBLEBEE_BASIC_STEREOIMAGE1 {WIDTH} {HEIGHT} {IMAGE_BYTES} 0 ".encode()
                          + _pixels(nxt[0]).tobytes().hex().encode() + f" {t} bench {t}\n".encode())
                nxt = next(images, None)
            out.write(line)


def _cut(path: Path, fraction: float) -> None:
    size = path.stat().st_size
    with open(path, "r+b") as f:
        f.truncate(int(size * fraction))


def write_big(fmt: str, path: Path, size: int, clf: Path, frames: list[Frame] | None = None) -> Path:
    """Writes the ``fmt`` log of about ``size`` bytes at ``path`` (see the module docstring); returns ``path``."""
    frames = frames if frames is not None else mit_frames(clf)
    n = max(1, size // IMAGE_BYTES)  # noise as hex text, gzip'd: about one byte per byte of image too
    if fmt in ("ros1", "ros1-cut"):
        _ros1(path, frames, int(n / 0.9) if fmt == "ros1-cut" else n)
    elif fmt in ("mcap", "mcap-cut"):
        _mcap(path, frames, int(n / 0.9) if fmt == "mcap-cut" else n, CompressionType.ZSTD, indexed=True)
    elif fmt == "mcap-unindexed":
        _mcap(path, frames, n, CompressionType.ZSTD, indexed=False)
    elif fmt == "mcap-zstd":
        plain = path.with_name(path.name + ".plain")
        _mcap(plain, frames, n, CompressionType.NONE, indexed=True)
        with open(plain, "rb") as src, open(path, "wb") as dst:
            zstandard.ZstdCompressor(level=1, threads=-1).copy_stream(src, dst)
        plain.unlink()
    elif fmt in ("ros2-sqlite3", "ros2-mcap"):
        _ros2(path, frames, n, StoragePlugin.SQLITE3 if fmt == "ros2-sqlite3" else StoragePlugin.MCAP)
    elif fmt == "carmen-gz":
        _carmen(path, clf, frames, n)
    else:
        raise ValueError(f"unknown format {fmt!r}")
    if fmt.endswith("-cut"):
        _cut(path, 0.9)
    return path


def remove(path: Path) -> None:
    """Removes a written log (file or folder)."""
    if path.is_dir():
        shutil.rmtree(path)
    else:
        path.unlink(missing_ok=True)
