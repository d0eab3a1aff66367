"""Raw message sources: one per container format, each yielding ``(connection, record time ns, bytes)``.

* :class:`Ros1BagSource` — ROS1 ``.bag`` through its index (any chunk compression, unsorted chunks);
  an unindexed or truncated bag is walked record by record instead (:mod:`mcnkit.io.ros1_records`).
* :class:`~mcnkit.io.sqlite_source.SqliteSource` — the ``.db3`` files of a ROS2 bag folder.
* :class:`McapSource` — MCAP files (plain, whole-file compressed, or the storage of a ROS2 bag folder), either
  profile: through the summary's chunk index (:mod:`mcnkit.io.mcap_chunks`), or, for a file without a usable
  summary, unchunked, or compressed as a whole, record by record as far as its data goes
  (:mod:`mcnkit.io.mcap_records`).

Every source holds one chunk (or one message) at a time, and refuses a message over its type's limit
(:func:`mcnkit.io.limits.message_limit`) with one :class:`~mcnkit.io.errors.LogError` line.
"""

from __future__ import annotations

import heapq
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path

import zstandard

from mcnkit.io.decode import normalize_msgtype
from mcnkit.io.errors import PARSE_ERRORS, LogError, warn_skipped
from mcnkit.io.limits import check_size, message_limit
from mcnkit.io.mcap_chunks import Summary, iter_chunk_messages, read_summary
from mcnkit.io.mcap_records import McapWalk, walk_mcap_records
from mcnkit.io.mcap_records import read_walked as read_mcap_walked
from mcnkit.io.ros1_records import ChunkInfo, Ros1Walk, iter_indexed_messages, read_ros1_index, walk_ros1_records
from mcnkit.io.ros1_records import read_walked as read_ros1_walked
from mcnkit.io.streams import ByteSource, FileBytes, StreamBytes

__all__ = ["Connection", "McapSource", "RawMessage", "RawSource", "Ros1BagSource"]


@dataclass(frozen=True)
class Connection:
    """A topic as stored: message type (``pkg/msg/Type``), wire encoding (``ros1``/``cdr``), stored definition."""

    key: tuple[str, int]  # (file, id within the file)
    topic: str
    msgtype: str
    encoding: str
    definition: str = ""
    definition_format: str = "msg"
    count: int = 0


RawMessage = tuple[Connection, int, bytes | memoryview]

# What reading a damaged MCAP chunk raises.
_MCAP_ERRORS: tuple[type[BaseException], ...] = (*PARSE_ERRORS, RuntimeError, zstandard.ZstdError)


class RawSource:
    """Base of the raw sources: ``connections`` and time-ordered ``messages(topics)``."""

    path: Path
    connections: list[Connection]
    compression: str | None = None
    """What the log's files or messages are compressed with beyond the container's own chunks (see
    :attr:`mcnkit.io.base.LogReader.compression`)."""

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Messages of the given topics (all when None), in record-time order."""
        raise NotImplementedError

    def time_range_ns(self) -> tuple[int, int]:
        """First and last record time; (0, 0) for an empty log."""
        stamps = [t for _, t, _ in self.messages()]
        return (min(stamps), max(stamps)) if stamps else (0, 0)

    def close(self) -> None:
        """Releases open files."""


def _limits(conns: dict[int, Connection]) -> dict[int, tuple[str, int]]:
    return {cid: (c.topic, message_limit(c.msgtype)) for cid, c in conns.items()}


def _checked(path: Path, by_id: dict[int, Connection], messages: Iterable[tuple[int, int, bytes]]
             ) -> Iterator[RawMessage]:
    """Messages read from chunks in memory, each checked against its type's limit."""
    limits = _limits(by_id)
    for stamp, cid, raw in messages:
        if len(raw) > limits[cid][1]:
            check_size(path, f"a message on {limits[cid][0]} at {stamp} ns", len(raw), limits[cid][1])
        yield by_id[cid], stamp, raw


class Ros1BagSource(RawSource):
    """A ROS1 bag: read through its index (any chunk compression, unsorted chunks); an unindexed or
    truncated bag is walked record by record, as far as its data goes."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._src = FileBytes(path)
        self._chunks: list[ChunkInfo] = []
        self._walk: Ros1Walk | None = None
        try:
            conns, self._chunks = read_ros1_index(path, self._src)
        except (ValueError, KeyError, IndexError, struct.error) as err:
            self._recover(str(err))
            return
        counts: dict[int, int] = {}
        for chunk in self._chunks:
            for cid, n in chunk.connection_counts.items():
                counts[cid] = counts.get(cid, 0) + n
        self.connections = [
            Connection((str(path), c.conn_id), c.topic, normalize_msgtype(c.msgtype), "ros1", c.definition, "msg",
                       counts.get(c.conn_id, 0))
            for c in conns
        ]

    def _recover(self, why: str) -> None:
        walk = walk_ros1_records(self.path, self._src)  # raises LogError when this is no bag at all
        if walk.stopped_at is not None and not walk.connections and not len(walk.index):
            raise LogError(self.path, f"{why.rstrip('.')}; nothing readable record by record: damaged or cut off from "
                                      f"byte {walk.stopped_at} on ({walk.stop_reason})")
        self.connections = [
            Connection((str(self.path), c.conn_id), c.topic, normalize_msgtype(c.msgtype), "ros1", c.definition,
                       "msg", walk.index.counts.get(c.conn_id, 0))
            for c in walk.connections
        ]
        self._walk = walk
        what = f"{why.rstrip('.')}; read {len(walk.index)} message(s) record by record"
        if walk.stopped_at is not None:
            what += f", the rest from byte {walk.stopped_at} on is unreadable ({walk.stop_reason})"
        warn_skipped(self.path, what)

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Time-ordered messages."""
        wanted = None if topics is None else set(topics)
        by_id = {c.key[1]: c for c in self.connections if wanted is None or c.topic in wanted}
        if not by_id:
            return
        if self._walk is not None:
            for stamp, conn_id, raw in read_ros1_walked(self.path, self._src, self._walk, _limits(by_id)):
                yield by_id[conn_id], stamp, raw
            return
        damaged: list[str] = []
        try:
            yield from _checked(self.path, by_id, iter_indexed_messages(self.path, self._src, self._chunks, set(by_id),
                                                                        damaged.append))
        except (ValueError, KeyError, OSError, RuntimeError, struct.error) as err:
            warn_skipped(self.path, f"stopped reading at a damaged chunk: {err}")
        if damaged:
            warn_skipped(self.path, f"{len(damaged)} damaged chunk(s): read the messages before the damage "
                                    f"({damaged[0]})")

    def time_range_ns(self) -> tuple[int, int]:
        """From the bag's index (or the walk's)."""
        if self._walk is not None:
            return self._walk.index.time_range({c.key[1] for c in self.connections})
        if not self._chunks:
            return (0, 0)
        return min(c.start_time for c in self._chunks), max(c.end_time for c in self._chunks)

    def close(self) -> None:
        """Closes the file and removes the walk's spilled index."""
        if self._walk is not None:
            self._walk.index.close()
        self._src.close()


class McapSource(RawSource):
    """One or more MCAP files (a split ROS2 bag folder has several), merged in time order.  ``compression``: the
    files are compressed as a whole (``gzip``/``bz2``/``zstd``; or one per file, by path) and are read as streams."""

    def __init__(self, path: Path, files: list[Path], compression: str | dict[str, str | None] | None = None) -> None:
        self.path = path
        self._files = files
        self._compression = compression if isinstance(compression, dict) else {str(f): compression for f in files}
        kinds = sorted({k for k in self._compression.values() if k is not None})
        self.compression = f"{', '.join(kinds)}, whole file" if kinds else None
        self.connections = []
        self._plain: dict[str, FileBytes] = {}
        self._summaries: dict[str, Summary] = {}
        self._walks: dict[str, McapWalk] = {}
        for f in files:
            self.connections.extend(self._scan_connections(f))

    def _bytes(self, f: Path) -> ByteSource:
        """A reader of ``f``'s bytes: the shared one of a plain file, a new stream of a compressed one."""
        kind = self._compression.get(str(f))
        if kind is not None:
            return StreamBytes(f, kind)
        if str(f) not in self._plain:
            self._plain[str(f)] = FileBytes(f)
        return self._plain[str(f)]

    def _scan_connections(self, f: Path) -> list[Connection]:
        src = self._bytes(f)
        if isinstance(src, FileBytes):
            summary, crc_ok = read_summary(src)
            if crc_ok is False:
                warn_skipped(f, "the summary section does not match its CRC; read record by record instead")
            if summary is not None and summary.channel_message_counts is not None and summary.chunk_indexes:
                self._summaries[str(f)] = summary
                counts = summary.channel_message_counts
                return [_mcap_connection(f, cid, ch, summary.schemas.get(ch[2]), counts.get(cid, 0))
                        for cid, ch in summary.channels.items()]
        # No usable summary (truncated, unindexed, unchunked, compressed as a whole): walk it record by record.
        try:
            walk = walk_mcap_records(f, src)
        finally:
            if not isinstance(src, FileBytes):
                src.close()
        self._walks[str(f)] = walk
        if walk.stopped_at is not None and not walk.channels and not len(walk.index):
            raise LogError(f, f"nothing readable: damaged or cut off from byte {walk.stopped_at} on ({walk.stop_reason})")
        if walk.stopped_at is not None:
            warn_skipped(f, f"no usable summary; read {len(walk.index)} message(s) record by record, the rest "
                         f"from byte {walk.stopped_at} on is unreadable ({walk.stop_reason})")
        if walk.damaged_chunks:
            warn_skipped(f, f"skipped {walk.damaged_chunks} damaged chunk(s) (CRC mismatch or undecodable)")
        if walk.chunks == 0 and walk.data_crc_ok is False:
            raise LogError(f, "damaged: the data section does not match its CRC (an unchunked MCAP: no telling which "
                              "messages changed)")
        if walk.data_crc_ok is False and not walk.damaged_chunks:
            warn_skipped(f, "the data section does not match its CRC (damage outside the chunks)")
        return [_mcap_connection(f, cid, ch, walk.schemas.get(ch[2]), walk.index.counts.get(cid, 0))
                for cid, ch in walk.channels.items()]

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Time-ordered messages across the files."""
        wanted = None if topics is None else set(topics)
        streams = []
        for f in self._files:
            by_id = {c.key[1]: c for c in self.connections
                     if c.key[0] == str(f) and (wanted is None or c.topic in wanted)}
            if by_id:
                streams.append(self._file_messages(f, by_id))
        yield from heapq.merge(*streams, key=lambda m: m[1])

    def _file_messages(self, f: Path, by_id: dict[int, Connection]) -> Iterator[RawMessage]:
        walk = self._walks.get(str(f))
        if walk is not None:
            src = self._bytes(f)
            try:
                for log_time, cid, data in read_mcap_walked(f, src, walk, _limits(by_id)):
                    yield by_id[cid], log_time, data
            finally:
                if not isinstance(src, FileBytes):
                    src.close()
            return
        src = self._bytes(f)
        assert isinstance(src, FileBytes)
        damaged: list[Exception] = []
        try:
            yield from _checked(f, by_id, iter_chunk_messages(src, f, self._summaries[str(f)], set(by_id),
                                                              damaged.append))
        except _MCAP_ERRORS as err:  # a damaged chunk
            warn_skipped(f, f"stopped at a damaged chunk ({type(err).__name__}: {err})")
        if damaged:
            warn_skipped(f, f"skipped {len(damaged)} damaged chunk(s) ({damaged[0]})")

    def time_range_ns(self) -> tuple[int, int]:
        """From the summaries' chunk indexes and the walks' indexes."""
        ranges = []
        for f in self._files:
            walk = self._walks.get(str(f))
            ids = {c.key[1] for c in self.connections if c.key[0] == str(f)}
            if walk is not None:
                if walk.index.counts.keys() & ids:
                    ranges.append(walk.index.time_range(ids))
            else:
                chunks = [ci for ci in self._summaries[str(f)].chunk_indexes if ci.message_index_offsets.keys() & ids]
                if chunks:
                    ranges.append((min(ci.message_start_time for ci in chunks),
                                   max(ci.message_end_time for ci in chunks)))
        return (min(r[0] for r in ranges), max(r[1] for r in ranges)) if ranges else (0, 0)

    def close(self) -> None:
        """Closes the files and removes spilled indexes."""
        for walk in self._walks.values():
            walk.index.close()
        for src in self._plain.values():
            src.close()


def _mcap_connection(f: Path, cid: int, channel: tuple[str, str, int], schema: tuple[str, str, bytes] | None,
                     count: int) -> Connection:
    topic, enc, _sid = channel
    name, senc, sdata = schema if schema is not None else ("", "", b"")
    return Connection(
        (str(f), cid), topic, normalize_msgtype(name), "ros1" if enc == "ros1" else "cdr" if enc == "cdr" else enc,
        sdata.decode("utf-8", "replace"), "idl" if senc == "ros2idl" else "msg", count,
    )
