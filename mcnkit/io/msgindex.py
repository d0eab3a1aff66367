"""Where each message of an unindexed log lies, so that it can be read in time order without holding the data.

A ROS1 bag or MCAP file without a usable index (truncated, never indexed, or a whole-file compressed MCAP) is
walked once, record by record (:mod:`mcnkit.io.ros1_records`, :mod:`mcnkit.io.mcap_records`); each message
becomes one row of a :class:`MessageIndex`: record time, connection, and where its bytes are (an offset in the
file, or in a compressed chunk, a :class:`Block`).  ``entries(conns)`` then gives the rows of some connections
in time order (ties in file order, as a stable sort of the whole log would), and :class:`BlockCache` reads each
message's bytes, decompressing a chunk once for the messages in it.

Rows are kept in runs of ``RUN_ROWS``; a full run is sorted and written to a temporary file, and runs are merged
when read, so memory stays bounded whatever the number of messages (40 bytes a row, ``RUN_ROWS`` rows at most).
"""

from __future__ import annotations

import heapq
import tempfile
from collections import OrderedDict
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import numpy as np

from mcnkit.io.limits import check_size
from mcnkit.io.streams import ByteSource

__all__ = ["RUN_ROWS", "Block", "BlockCache", "MessageIndex", "read_indexed"]

RUN_ROWS = 1 << 20
_READ_ROWS = 1 << 16
_ROW = np.dtype([("t", "<i8"), ("seq", "<i8"), ("conn", "<i4"), ("block", "<i4"), ("off", "<i8"), ("len", "<i8")])
_CACHE_BLOCKS = 4

Entry = tuple[int, int, int, int, int, int]
"""A row: (time ns, sequence in the file, connection id, block (-1: the file itself), offset, length)."""


@dataclass(frozen=True)
class Block:
    """A compressed chunk whose messages are indexed by their offset in its decompressed bytes."""

    offset: int
    """Where the chunk's compressed bytes start in the file."""
    length: int
    """How many compressed bytes it stores (fewer when the file is cut off inside it)."""
    compression: str
    size: int
    """The decompressed size the chunk declares."""
    partial: bool = False
    """Cut off by the end of the file: decompress what is there."""


class MessageIndex:
    """Rows of messages in file order; see the module docstring."""

    def __init__(self) -> None:
        self._rows: list[np.ndarray] = []  # pieces of the current run
        self._n_current = 0
        self._spill: BinaryIO | None = None
        self._runs: list[tuple[int, int]] = []  # (byte offset in the spill file, rows) of sorted runs
        self._seq = 0
        self.counts: dict[int, int] = {}
        self._ranges: dict[int, tuple[int, int]] = {}

    def __len__(self) -> int:
        return self._seq

    def add(self, times: list[int], conns: list[int], block: int, offsets: list[int], lengths: list[int]) -> None:
        """Adds messages in file order (one chunk's, or one record's)."""
        n = len(times)
        if n == 0:
            return
        rows = np.empty(n, _ROW)
        rows["t"], rows["conn"], rows["off"], rows["len"] = times, conns, offsets, lengths
        rows["seq"] = np.arange(self._seq, self._seq + n)
        rows["block"] = block
        self._seq += n
        for cid in np.unique(rows["conn"]).tolist():
            t = rows["t"][rows["conn"] == cid]
            lo, hi = self._ranges.get(cid, (int(t.min()), int(t.max())))
            self._ranges[cid] = (min(lo, int(t.min())), max(hi, int(t.max())))
            self.counts[cid] = self.counts.get(cid, 0) + len(t)
        self._rows.append(rows)
        self._n_current += n
        if self._n_current >= RUN_ROWS:
            self._flush()

    def time_range(self, conns: set[int]) -> tuple[int, int]:
        """First and last record time of the messages of ``conns``; (0, 0) when there are none."""
        ranges = [self._ranges[c] for c in conns if c in self._ranges]
        return (min(r[0] for r in ranges), max(r[1] for r in ranges)) if ranges else (0, 0)

    def _current(self) -> np.ndarray:
        run = np.concatenate(self._rows) if self._rows else np.empty(0, _ROW)
        run = run[np.argsort(run["t"], kind="stable")]
        self._rows, self._n_current = [run], len(run)
        return run

    def _flush(self) -> None:
        run = self._current()
        if self._spill is None:
            self._spill = tempfile.TemporaryFile(prefix="mcnkit-index-")
        self._spill.seek(0, 2)
        self._runs.append((self._spill.tell(), len(run)))
        self._spill.write(run.tobytes())
        self._rows, self._n_current = [], 0

    def entries(self, conns: set[int] | None = None) -> Iterator[Entry]:
        """Rows of ``conns`` (all when None) in time order, ties in file order."""
        current = self._current()
        streams = [self._run_rows(off, n, conns) for off, n in self._runs]
        streams.append(_selected(current, conns))
        if len(streams) == 1:
            yield from streams[0]
        else:
            yield from heapq.merge(*streams)

    def _run_rows(self, offset: int, n: int, conns: set[int] | None) -> Iterator[Entry]:
        assert self._spill is not None
        for start in range(0, n, _READ_ROWS):
            self._spill.seek(offset + start * _ROW.itemsize)
            rows = np.frombuffer(self._spill.read(min(_READ_ROWS, n - start) * _ROW.itemsize), _ROW)
            yield from _selected(rows, conns)

    def close(self) -> None:
        """Removes the spill file."""
        if self._spill is not None:
            self._spill.close()
            self._spill = None


def _selected(rows: np.ndarray, conns: set[int] | None) -> Iterator[Entry]:
    if conns is not None:
        rows = rows[np.isin(rows["conn"], list(conns))]
    for start in range(0, len(rows), _READ_ROWS):
        part = rows[start : start + _READ_ROWS]
        yield from zip(part["t"].tolist(), part["seq"].tolist(), part["conn"].tolist(), part["block"].tolist(),
                       part["off"].tolist(), part["len"].tolist(), strict=True)


class BlockCache:
    """Decompressed chunks by block number, the ``_CACHE_BLOCKS`` most recently used kept (time-ordered reading goes
    through the chunks in file order, so each is decompressed about once, and chunks whose times overlap a few
    neighbours still are)."""

    def __init__(self, load: Callable[[int], bytes]) -> None:
        self._load = load
        self._cache: OrderedDict[int, bytes] = OrderedDict()

    def get(self, block: int) -> bytes:
        """The decompressed bytes of ``block``."""
        data = self._cache.get(block)
        if data is not None:
            self._cache.move_to_end(block)
            return data
        data = self._load(block)
        self._cache[block] = data
        if len(self._cache) > _CACHE_BLOCKS:
            self._cache.popitem(last=False)
        return data


def read_indexed(path: Path, src: ByteSource, index: MessageIndex, load: Callable[[int], bytes],
                 limits: dict[int, tuple[str, int]]) -> Iterator[tuple[int, int, bytes]]:
    """``(time ns, connection id, raw)`` in time order for the connections in ``limits`` (id -> (topic, the largest
    message it may hold)): messages outside chunks read from ``src``, the others from their chunk (``load`` gives a
    block's decompressed bytes).  Raises :class:`~mcnkit.io.errors.LogError` for a message over its limit."""
    cache = BlockCache(load)
    for t, _seq, conn, block, off, n in index.entries(set(limits)):
        topic, limit = limits[conn]
        check_size(path, f"a message on {topic} at {t} ns", n, limit)
        if block < 0:
            yield t, conn, src.read_at(off, n)
        else:
            yield t, conn, cache.get(block)[off : off + n]
