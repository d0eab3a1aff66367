"""Hostile inputs for the fuzz benchmark: files no recorder writes, built to exhaust memory or time, or to pass
impossible motion on.  :func:`write_hostile` writes each into a folder and says what a reader must do with it:

* ``refuse``: ``mcnkit info`` and the frame read end with one line and exit 2;
* ``read``: the log is read (exit 0), with a warning, and no frame carries a step of known motion longer than
  ``MAX_KNOWN_STEP_M`` (the clean source log's steps are at most 1.2 m);
* ``either``: refused or read with warnings, as the damage falls.

Whatever a case expects, every line ``mcnkit info`` writes to stderr is one message (``warning: ...`` or
``mcnkit info: ...``).

Every case must also end within ``TIME_LIMIT_S`` with a peak RSS of at most ``MAX_RSS_MB`` (checked by
:mod:`benchmarks.bench_fuzz`, which runs each in a child process of its own).
"""

from __future__ import annotations

import gzip
import os
import sqlite3
import zlib
from collections.abc import Callable
from pathlib import Path

import zstandard

from mcnkit.io import LogContent, write_log

__all__ = ["CASES", "MAX_KNOWN_STEP_M", "MAX_RSS_MB", "TIME_LIMIT_S", "write_hostile"]

TIME_LIMIT_S = 10.0
MAX_RSS_MB = 500.0
MAX_KNOWN_STEP_M = 3.0
_GIB = 1 << 30


def _dev_zero(folder: Path, name: str) -> Path:
    path = folder / name
    path.symlink_to("/dev/zero")
    return path


def _rosbag2_to_dev_zero(folder: Path, content: LogContent) -> Path:
    bag = write_log(folder / "bag", content, "ros2-mcap")
    mcap = next(bag.glob("*.mcap"))
    mcap.unlink()
    mcap.symlink_to("/dev/zero")
    return bag


def _one_line_gz(folder: Path, start: bytes) -> Path:
    """A .log.gz holding one 3 GiB line without a newline: one gzip member of 1 MiB repeated (a multi-member gzip)."""
    path = folder / "one-line.log.gz"
    piece = zlib.compressobj(9, zlib.DEFLATED, 31)
    member = piece.compress((start * ((1 << 20) // len(start) + 1))[: 1 << 20]) + piece.flush()
    with open(path, "wb") as f:
        for _ in range(3 * _GIB >> 20):
            f.write(member)
    return path


def _mcap_bomb(folder: Path) -> Path:
    """An .mcap.gz that decompresses to 2 GiB of valid, empty MCAP records."""
    path = folder / "bomb.mcap.gz"
    record = b"\x10" + bytes(8)
    piece = zlib.compressobj(9, zlib.DEFLATED, 31)
    member = piece.compress(record * ((1 << 20) // len(record))) + piece.flush()
    with open(path, "wb") as f:
        f.write(gzip.compress(b"\x89MCAP0\r\n"))
        for _ in range(2 * _GIB >> 20):
            f.write(member)
    return path


def _sparse_mcap(folder: Path) -> Path:
    """A 10 GiB MCAP that is its magic followed by zeros (a sparse file: no disk used)."""
    path = folder / "zeros.mcap"
    with open(path, "wb") as f:
        f.write(b"\x89MCAP0\r\n")
        f.truncate(10 * _GIB)
    return path


def _huge_record(folder: Path, content: LogContent) -> Path:
    """A ROS1 bag whose first chunk claims 3 GiB (a damaged length field, the file holding far less)."""
    path = write_log(folder / "huge.bag", content, "ros1")
    raw = bytearray(path.read_bytes())
    at = raw.index(b"op=\x05")  # the first chunk's header; its data length follows the header
    start = raw.rindex(b"\x00\x00", 0, at) - 2  # header length u32 before the header's fields
    hlen = int.from_bytes(raw[start : start + 4], "little")
    raw[start + 4 + hlen : start + 8 + hlen] = (3 * _GIB).to_bytes(4, "little")
    path.write_bytes(bytes(raw))
    return path


def _fifo(folder: Path) -> Path:
    path = folder / "pipe.bag"
    os.mkfifo(path)
    return path


def _damaged_sqlite(folder: Path, content: LogContent) -> Path:
    """A rosbag2 sqlite3 bag whose b-tree pages are damaged: sqlite's integrity report spans several lines."""
    bag = write_log(folder / "sq", content, "ros2-sqlite3")
    db = next(bag.glob("*.db3"))
    with sqlite3.connect(db) as conn:
        page = conn.execute("PRAGMA page_size").fetchone()[0]
    raw = bytearray(db.read_bytes())
    for p in range(1, len(raw) // page):
        raw[p * page] = 0x55
    db.write_bytes(bytes(raw))
    return bag


def _rosbag2_file_bomb(folder: Path, content: LogContent) -> Path:
    """A file-compressed rosbag2 sqlite3 bag whose ``.db3.zstd`` decompresses to 2 GiB (a valid header, then
    zeros): it would fill the temporary folder the reader decompresses it into."""
    bag = write_log(folder / "zb", content, "ros2-sqlite3", compression="file")
    packed = next(bag.glob("*.db3.zstd"))
    header = zstandard.ZstdDecompressor().stream_reader(open(packed, "rb")).read(4096)
    cctx = zstandard.ZstdCompressor(level=1)
    with open(packed, "wb") as f, cctx.stream_writer(f) as w:
        w.write(header)
        zeros = bytes(1 << 20)
        for _ in range(2 * _GIB >> 20):
            w.write(zeros)
    return bag


def _rosbag2_message_bomb(folder: Path, content: LogContent) -> Path:
    """A message-compressed rosbag2 sqlite3 bag one of whose scans decompresses to 1 GiB of zeros."""
    bag = write_log(folder / "mb", content, "ros2-sqlite3", compression="message")
    db = next(bag.glob("*.db3"))
    bomb = zstandard.ZstdCompressor(level=1).compress(bytes(_GIB))
    with sqlite3.connect(db) as conn:
        (tid,) = conn.execute("SELECT id FROM topics WHERE name = '/scan'").fetchone()
        conn.execute("UPDATE messages SET data = ? WHERE id = (SELECT min(id) FROM messages WHERE topic_id = ?)",
                     (bomb, tid))
    return bag


def _misparsed_carmen(folder: Path, source: Path) -> Path:
    """The clean CARMEN log with one FLASER line that lost a field: its pose fields shift, its stamp reads as a
    heading, the robot would jump tens of metres (the 21 m step of issue 31)."""
    lines = source.read_text().splitlines(keepends=True)
    k = [i for i, line in enumerate(lines) if line.startswith("FLASER")][150]
    tok = lines[k].split()
    n = int(tok[1])
    del tok[2 + n]  # the first pose field
    lines[k] = " ".join(tok) + "\n"
    path = folder / "misparsed.log"
    path.write_text("".join(lines))
    return path


CASES: dict[str, tuple[str, Callable[[Path, LogContent, Path], Path]]] = {
    "log -> /dev/zero": ("refuse", lambda d, c, s: _dev_zero(d, "run.log")),
    "bag -> /dev/zero": ("refuse", lambda d, c, s: _dev_zero(d, "run.bag")),
    "rosbag2 .mcap -> /dev/zero": ("refuse", lambda d, c, s: _rosbag2_to_dev_zero(d, c)),
    "FIFO": ("refuse", lambda d, c, s: _fifo(d)),
    ".log.gz: one 3 GiB line (FLASER)": ("refuse", lambda d, c, s: _one_line_gz(d, b"FLASER 181 1.0 ")),
    ".log.gz: one 3 GiB line (text)": ("refuse", lambda d, c, s: _one_line_gz(d, b"a")),
    ".mcap.gz: 2 GiB of empty records": ("refuse", lambda d, c, s: _mcap_bomb(d)),
    ".mcap: magic and 10 GiB of zeros": ("refuse", lambda d, c, s: _sparse_mcap(d)),
    ".bag: a chunk claiming 3 GiB": ("either", lambda d, c, s: _huge_record(d, c)),
    "rosbag2 sqlite3: damaged pages": ("either", lambda d, c, s: _damaged_sqlite(d, c)),
    "rosbag2 .db3.zstd: 2 GiB of zeros": ("refuse", lambda d, c, s: _rosbag2_file_bomb(d, c)),
    "rosbag2 message compression: a 1 GiB scan": ("refuse", lambda d, c, s: _rosbag2_message_bomb(d, c)),
    "CARMEN: a misparsed line": ("read", lambda d, c, s: _misparsed_carmen(d, s)),
}
"""Name -> (what a reader must do, writer(folder, clean content, clean CARMEN source))."""


def write_hostile(name: str, folder: Path, content: LogContent, carmen: Path) -> tuple[str, Path]:
    """Writes the case ``name`` into ``folder``: (what a reader must do, the path to open)."""
    expect, write = CASES[name]
    return expect, write(folder, content, carmen)
