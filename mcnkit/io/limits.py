"""How much of a log a reader holds in memory at once, and what it refuses before memory grows.

Every reader streams: it holds one chunk (or one message, or one text line) at a time, never the file.  What it
is asked to hold is checked against the limits below first, so a damaged length field or a hostile file ends in
one :class:`~mcnkit.io.errors.LogError` line instead of a process that grows until the machine stops it.

* ``MAX_MESSAGE_BYTES``: a message a frame is built from (LaserScan, Odometry, /tf, ground-truth poses).  The
  largest LaserScan a scanner makes is ``MAX_BEAMS`` ranges and as many intensities, float32 each; 1 MiB more
  covers its header and the largest /tf lists and covariances.
* ``MAX_MAP_BYTES``: a ground-truth ``nav_msgs/OccupancyGrid`` (an 8192 × 8192 grid: 400 m square at 5 cm).
* ``MAX_CHUNK_BYTES``: a chunk of a ROS1 bag or MCAP file (compressed or not), and any other single message
  handed out by ``messages()``.  Writers chunk at about 1 MB (``rosbag record`` 768 KiB, rosbag2's MCAP 768 KiB,
  the ``mcap`` tool 4 MiB); a chunk holding one large message (a point cloud, an uncompressed 4K image) is tens
  of MB.  Messages that no frame needs (a camera beside the lidar) are skipped without being read wherever the
  format allows (uncompressed chunks, records outside chunks), so their size costs nothing.
* ``MAX_DEFINITION_BYTES``: a record header, a connection or channel record, a message definition.
* ``MAX_LINE_BYTES``: a line of a text (CARMEN) log: a ``ROBOTLASER`` line with ``MAX_BEAMS`` ranges and
  remissions, at most 16 characters each.  Lines of keywords no frame needs (a camera image logged as text) are
  read and dropped; a longer line of any keyword is refused after ``MAX_LINE_BYTES``, so a file without newlines
  is refused at once.
* ``MAX_RATIO``: a whole-file compressed log (``.mcap.zstd``, ``.log.gz``) decompresses to at most this many times
  its size.  Real logs compress 1–5× (measured: the CARMEN logs of ``../shared`` 3.6–4.9× under gzip, their
  conversions to MCAP and ROS1 bags 1.0–1.4× under zstd); a larger ratio is a file of near-constant bytes, built to
  exhaust time (a bomb is stopped after a few MiB of output).

A log path must be a regular file (or a folder of regular files): a link to ``/dev/zero``, a FIFO or a device is
refused (:func:`check_regular`) before anything is read from it.
"""

from __future__ import annotations

import stat
from pathlib import Path

from mcnkit.io.errors import LogError
from mcnkit.io.plausible import MAX_BEAMS

__all__ = [
    "MAX_CHUNK_BYTES",
    "MAX_DEFINITION_BYTES",
    "MAX_LINE_BYTES",
    "MAX_MAP_BYTES",
    "MAX_MESSAGE_BYTES",
    "MAX_RATIO",
    "check_regular",
    "check_size",
    "message_limit",
    "mib",
]

MAX_MESSAGE_BYTES = 2 * 4 * MAX_BEAMS + (1 << 20)
MAX_MAP_BYTES = 8192 * 8192
MAX_CHUNK_BYTES = 1 << 27
MAX_DEFINITION_BYTES = 1 << 24
MAX_LINE_BYTES = 2 * 16 * MAX_BEAMS + (1 << 16)
MAX_RATIO = 200

_FRAME_TYPES = ("sensor_msgs/msg/LaserScan", "nav_msgs/msg/Odometry", "tf2_msgs/msg/TFMessage", "tf/msg/tfMessage",
                "geometry_msgs/msg/PoseStamped")


def mib(n: int) -> str:
    """A byte count as people read it: ``"1,848,576 bytes"``, from 10 MiB on ``"128.0 MiB"``."""
    return f"{n / (1 << 20):.1f} MiB" if n >= 10 << 20 else f"{n:,} bytes"


def message_limit(msgtype: str) -> int:
    """The largest message of ``msgtype`` (``pkg/msg/Type``) a reader holds."""
    if msgtype in _FRAME_TYPES:
        return MAX_MESSAGE_BYTES
    if msgtype == "nav_msgs/msg/OccupancyGrid":
        return MAX_MAP_BYTES
    return MAX_CHUNK_BYTES


def check_size(path: Path | str, what: str, n: int, limit: int) -> None:
    """Raises :class:`LogError` when ``what`` (``"a /scan message"``) of ``n`` bytes exceeds ``limit``."""
    if n > limit:
        raise LogError(path, f"{what} of {mib(n)} is larger than this reader holds ({mib(limit)}): damaged, or not "
                             "a log of a robot's sensors")


def check_regular(path: Path) -> None:
    """Raises :class:`LogError` unless ``path`` is (links to) a regular file: reading a device, FIFO or socket
    never ends (``/dev/zero``) or blocks."""
    try:
        mode = path.stat().st_mode
    except OSError as err:
        raise LogError(path, f"cannot read: {err.strerror or type(err).__name__}") from err
    if stat.S_ISREG(mode):
        return
    kinds = {stat.S_ISCHR: "a character device", stat.S_ISBLK: "a block device", stat.S_ISFIFO: "a FIFO",
             stat.S_ISSOCK: "a socket", stat.S_ISDIR: "a folder"}
    kind = next((name for test, name in kinds.items() if test(mode)), "not a file")
    target = f" (links to {path.resolve()})" if path.is_symlink() else ""
    raise LogError(path, f"not a regular file: {kind}{target}")
