"""Bytes of a log read in pieces: plain files by offset, whole-file compressed logs (gzip, bz2, zstd) as a stream.

* :func:`open_decompressed` decompresses a ``.gz``/``.bz2``/``.zst`` file as it is read, refusing (one
  :class:`~mcnkit.io.errors.LogError` line) a file that decompresses to more than ``MAX_RATIO`` times the
  compressed bytes read so far: a compression bomb is stopped after a few MB instead of running for hours.
* :class:`FileBytes` and :class:`StreamBytes` give ``read_at(offset, n)`` over a plain file (``os.pread``: no
  shared file position, so several readers of one log may interleave) and over a compressed one (read forward;
  a read before the current position starts the stream again, which time-ordered reading almost never does).
* :func:`text_lines` yields the lines of a text log, each at most ``limit`` characters: a longer line (or a file
  without newlines) is flagged after ``limit`` characters, never read whole.
"""

from __future__ import annotations

import bz2
import gzip
import io
import os
from collections.abc import Iterator
from pathlib import Path
from typing import BinaryIO, Protocol

import zstandard

from mcnkit.io.errors import LogError
from mcnkit.io.limits import MAX_RATIO, mib

__all__ = ["ByteSource", "FileBytes", "StreamBytes", "compression_of", "open_decompressed", "text_lines"]

_MAGICS = {b"\x1f\x8b": "gzip", b"BZh": "bz2", b"\x28\xb5\x2f\xfd": "zstd"}
_RATIO_FLOOR = 1 << 20  # output bytes before the ratio is judged (a small file of one repeated value is harmless)
_READ_SIZE = 1 << 14  # compressed bytes read at a time: the ratio is judged on what was consumed, not read ahead
_SKIP_PIECE = 1 << 20
_KEEP = 1 << 20  # decompressed bytes kept behind the read position of a stream


def compression_of(head: bytes) -> str | None:
    """``"gzip"``, ``"bz2"`` or ``"zstd"`` when ``head`` (a file's first bytes) starts with that magic."""
    return next((kind for magic, kind in _MAGICS.items() if head.startswith(magic)), None)


class _Counting(io.RawIOBase):
    """A raw file that counts the bytes read from it."""

    def __init__(self, f: BinaryIO) -> None:
        self._f, self.n = f, 0

    def readable(self) -> bool:
        return True

    def readinto(self, b: bytearray | memoryview) -> int:  # type: ignore[override]
        data = self._f.read(len(b))
        b[: len(data)] = data
        self.n += len(data)
        return len(data)

    def close(self) -> None:
        self._f.close()
        super().close()


class _Guarded(io.RawIOBase):
    """Decompressed bytes, refused once they outgrow ``MAX_RATIO`` times the compressed bytes read."""

    def __init__(self, path: Path, inner: BinaryIO, counting: _Counting) -> None:
        self._path, self._inner, self._counting, self.out = path, inner, counting, 0

    def readable(self) -> bool:
        return True

    def readinto(self, b: bytearray | memoryview) -> int:  # type: ignore[override]
        n = self._inner.readinto(b)  # type: ignore[attr-defined]
        self.out += n
        if self.out > _RATIO_FLOOR and self.out > MAX_RATIO * max(self._counting.n, 1):
            raise LogError(self._path, f"decompresses to more than {MAX_RATIO} times its size ({mib(self.out)} from "
                                       f"{mib(self._counting.n)}): no robot log compresses that well")
        return int(n)

    def close(self) -> None:
        self._inner.close()
        self._counting.close()
        super().close()


def open_decompressed(path: Path, kind: str) -> BinaryIO:
    """A buffered stream of ``path`` decompressed (``kind`` from :func:`compression_of`), ratio-guarded."""
    counting = _Counting(open(path, "rb"))
    inner: BinaryIO
    if kind == "gzip":
        inner = gzip.GzipFile(fileobj=counting, mode="rb")  # type: ignore[assignment]
    elif kind == "bz2":
        inner = bz2.BZ2File(counting, mode="rb")  # type: ignore[assignment]
    else:
        inner = zstandard.ZstdDecompressor().stream_reader(counting, read_size=_READ_SIZE,  # type: ignore[arg-type]
                                                           read_across_frames=True)
    return io.BufferedReader(_Guarded(path, inner, counting), buffer_size=1 << 16)


class ByteSource(Protocol):
    """Bytes of one file by offset; ``read_at`` returns fewer than ``n`` bytes only at the end of the data."""

    def read_at(self, offset: int, n: int) -> bytes:
        """``n`` bytes from ``offset`` (fewer at the end)."""
        ...

    def close(self) -> None:
        """Releases the file."""
        ...


class FileBytes:
    """A plain file read by offset (``os.pread``)."""

    def __init__(self, path: Path) -> None:
        self._fd = os.open(path, os.O_RDONLY)
        self.size = os.fstat(self._fd).st_size

    def read_at(self, offset: int, n: int) -> bytes:
        """``n`` bytes from ``offset`` (fewer at the end of the file)."""
        return os.pread(self._fd, max(0, min(n, self.size - offset)), offset)

    def close(self) -> None:
        """Closes the file."""
        if self._fd >= 0:
            os.close(self._fd)
            self._fd = -1


class StreamBytes:
    """A whole-file compressed log read by offset in its decompressed bytes: forward reads continue the stream, a
    read within the last ``_KEEP`` bytes is served from them (messages a little out of file order), a read before
    them opens the stream again."""

    def __init__(self, path: Path, kind: str) -> None:
        self._path, self._kind = path, kind
        self._stream = open_decompressed(path, kind)
        self._pos = 0
        self._kept = bytearray()  # the bytes just before _pos

    def read_at(self, offset: int, n: int) -> bytes:
        """``n`` bytes from ``offset`` of the decompressed data (fewer at its end)."""
        kept_from = self._pos - len(self._kept)
        if offset < kept_from:
            self._stream.close()
            self._stream, self._pos, self._kept = open_decompressed(self._path, self._kind), 0, bytearray()
        elif offset < self._pos:
            head = bytes(self._kept[offset - kept_from : offset - kept_from + n])
            return head + (self.read_at(self._pos, n - len(head)) if len(head) < n else b"")
        while self._pos < offset:
            if not self._take(min(_SKIP_PIECE, offset - self._pos)):
                return b""
        return self._take(n)

    def _take(self, n: int) -> bytes:
        data = self._stream.read(n)
        self._pos += len(data)
        self._kept += data
        if len(self._kept) > 2 * _KEEP:
            del self._kept[: len(self._kept) - _KEEP]
        return data

    def close(self) -> None:
        """Closes the stream."""
        self._stream.close()


def text_lines(stream: BinaryIO, limit: int) -> Iterator[tuple[str, bool]]:
    """``(text, whole)`` for each line of an ASCII log (universal newlines; undecodable bytes replaced).

    A line longer than ``limit`` characters comes as its first ``limit + 1`` characters with ``whole`` False and
    ends the iteration: the caller refuses the file (a file without newlines never sits in memory whole).
    """
    text = io.TextIOWrapper(stream, encoding="ascii", errors="replace")
    try:
        while True:
            line = text.readline(limit + 1)
            if not line:
                return
            if len(line) > limit and not line.endswith("\n"):
                yield line, False
                return
            yield line, True
    finally:
        if not stream.closed:
            text.detach()  # the caller closes the stream
