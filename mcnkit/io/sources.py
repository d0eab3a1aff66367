"""Raw message sources: one per container format, each yielding ``(connection, record time ns, bytes)``.

* :class:`Ros1BagSource` — ROS1 ``.bag`` through its index (any chunk compression, unsorted chunks);
  an unindexed or truncated bag is read record by record instead (:mod:`mcnkit.io.ros1_records`).
* :class:`SqliteSource` — the ``.db3`` files of a ROS2 bag folder, through sqlite3 directly.
* :class:`McapSource` — MCAP files (plain, or the storage of a ROS2 bag folder), either profile, through
  ``mcap``'s reader; a file without a valid summary or footer is streamed as far as its data goes.
"""

from __future__ import annotations

import heapq
import io
import sqlite3
import struct
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

import zstandard
from mcap.exceptions import McapError
from mcap.reader import make_reader

from mcnkit.io.decode import normalize_msgtype
from mcnkit.io.errors import PARSE_ERRORS, LogError, warn_skipped
from mcnkit.io.mcap_chunks import McapRecords, iter_chunk_messages, read_mcap_records, summary_crc_ok
from mcnkit.io.ros1_records import ChunkInfo, iter_indexed_messages, read_ros1_index, read_ros1_records

__all__ = ["Connection", "McapSource", "RawMessage", "RawSource", "Ros1BagSource", "SqliteSource"]


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

# What reading a damaged MCAP chunk through the ``mcap`` package raises.
_MCAP_ERRORS: tuple[type[BaseException], ...] = (*PARSE_ERRORS, RuntimeError, McapError, zstandard.ZstdError)


class RawSource:
    """Base of the raw sources: ``connections`` and time-ordered ``messages(topics)``."""

    path: Path
    connections: list[Connection]

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Messages of the given topics (all when None), in record-time order."""
        raise NotImplementedError

    def time_range_ns(self) -> tuple[int, int]:
        """First and last record time; (0, 0) for an empty log."""
        stamps = [t for _, t, _ in self.messages()]
        return (min(stamps), max(stamps)) if stamps else (0, 0)

    def close(self) -> None:
        """Releases open files."""


class Ros1BagSource(RawSource):
    """A ROS1 bag: read through its index (any chunk compression, unsorted chunks); an unindexed or
    truncated bag is read record by record, as far as its data goes."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self._chunks: list[ChunkInfo] = []
        self._recovered: list[tuple[int, int, bytes]] | None = None
        try:
            conns, self._chunks = read_ros1_index(path)
        except (ValueError, KeyError, struct.error) as err:
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
        records = read_ros1_records(self.path)  # raises LogError when this is no bag at all
        self.connections = [
            Connection((str(self.path), c.conn_id), c.topic, normalize_msgtype(c.msgtype), "ros1", c.definition,
                       "msg", sum(1 for m in records.messages if m[1] == c.conn_id))
            for c in records.connections
        ]
        self._recovered = sorted(records.messages, key=lambda m: m[0])
        what = f"{why.rstrip('.')}; read {len(self._recovered)} message(s) record by record"
        if records.stopped_at is not None:
            what += f", the rest from byte {records.stopped_at} on is unreadable ({records.stop_reason})"
        warn_skipped(self.path, what)

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Time-ordered messages."""
        wanted = None if topics is None else set(topics)
        by_id = {c.key[1]: c for c in self.connections if wanted is None or c.topic in wanted}
        if self._recovered is not None:
            for stamp, conn_id, raw in self._recovered:
                if conn_id in by_id:
                    yield by_id[conn_id], stamp, raw
            return
        if not by_id:
            return
        damaged: list[str] = []
        try:
            for stamp, conn_id, raw in iter_indexed_messages(self.path, self._chunks, set(by_id), damaged.append):
                yield by_id[conn_id], stamp, raw
        except (ValueError, KeyError, OSError, RuntimeError, struct.error) as err:
            warn_skipped(self.path, f"stopped reading at a damaged chunk: {err}")
        if damaged:
            warn_skipped(self.path, f"{len(damaged)} damaged chunk(s): read the messages before the damage "
                                    f"({damaged[0]})")

    def time_range_ns(self) -> tuple[int, int]:
        """From the bag's index when it has one."""
        if self._recovered is not None or not self._chunks:
            return super().time_range_ns()
        return min(c.start_time for c in self._chunks), max(c.end_time for c in self._chunks)


class SqliteSource(RawSource):
    """The sqlite3 files of a ROS2 bag folder (split bags: several files, merged in time order)."""

    def __init__(self, path: Path, files: list[Path]) -> None:
        self.path = path
        self._dbs: list[tuple[Path, sqlite3.Connection]] = []
        self.connections = []
        merged: dict[tuple[str, str], Connection] = {}
        for f in files:
            try:
                db = sqlite3.connect(_readonly_uri(f), uri=True)
                topics = db.execute("SELECT id, name, type, serialization_format FROM topics").fetchall()
                counts = dict(db.execute("SELECT topic_id, count(*) FROM messages GROUP BY topic_id").fetchall())
                defs = _sqlite_definitions(db)
            except sqlite3.DatabaseError as err:
                raise LogError(f, f"not a readable rosbag2 sqlite3 file ({err})") from err
            _quick_check(f, db)
            self._dbs.append((f, db))
            for tid, name, msgtype, fmt in topics:
                if fmt != "cdr":
                    warn_skipped(f, f"topic {name} uses serialization {fmt!r}, not cdr; skipped")
                    continue
                d, dfmt = defs.get(msgtype, ("", "msg"))
                c = Connection((str(f), tid), name, normalize_msgtype(msgtype), "cdr", d, dfmt, counts.get(tid, 0))
                self.connections.append(c)
                key = (name, c.msgtype)
                prev = merged.get(key)
                merged[key] = c if prev is None else Connection(prev.key, name, c.msgtype, "cdr", d, dfmt,
                                                                prev.count + c.count)
        self._topic_conn = merged

    @property
    def topic_connections(self) -> list[Connection]:
        """One connection per (topic, type), counts summed over the files."""
        return list(self._topic_conn.values())

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Time-ordered messages, merged across the files of a split bag."""
        wanted = None if topics is None else set(topics)
        streams = []
        for f, db in self._dbs:
            by_id = {c.key[1]: c for c in self.connections if c.key[0] == str(f)
                     and (wanted is None or c.topic in wanted)}
            if by_id:
                marks = ",".join("?" * len(by_id))
                cur = db.execute(
                    f"SELECT timestamp, topic_id, data FROM messages WHERE topic_id IN ({marks}) ORDER BY timestamp",
                    list(by_id),
                )
                # a damaged row may hold values of other types: it sorts first here and is skipped below
                streams.append(((t, by_id[tid], data) if type(t) is int and isinstance(data, bytes) and tid in by_id
                                else (-(2**63), None, b"") for t, tid, data in cur))
        odd = 0
        try:
            for t, conn, data in heapq.merge(*streams, key=lambda m: m[0]):
                if conn is None:
                    odd += 1
                else:
                    yield conn, t, data
        except sqlite3.DatabaseError as err:
            warn_skipped(self.path, f"stopped at a damaged database page ({err})")
        if odd:
            warn_skipped(self.path, f"skipped {odd} message row(s) whose timestamp is not an integer or whose data is "
                                    "not a blob (damaged rows)")

    def time_range_ns(self) -> tuple[int, int]:
        """From the message tables."""
        ranges = [db.execute("SELECT min(timestamp), max(timestamp) FROM messages WHERE typeof(timestamp) = 'integer'")
                  .fetchone() for _, db in self._dbs]
        ranges = [r for r in ranges if r[0] is not None]
        return (min(r[0] for r in ranges), max(r[1] for r in ranges)) if ranges else (0, 0)

    def close(self) -> None:
        """Closes the databases."""
        for _, db in self._dbs:
            db.close()


def _quick_check(f: Path, db: sqlite3.Connection) -> None:
    """SQLite's own structural check of every page (``PRAGMA quick_check``: b-trees, record formats, NOT NULL
    columns; linear in the file's size): problems are counted in one warning, and what stays readable is read."""
    try:
        rows = [r[0] for r in db.execute("PRAGMA quick_check(100)")]
    except sqlite3.DatabaseError as err:
        rows = [str(err)]
    if rows != ["ok"]:
        more = "+" if len(rows) >= 100 else ""
        warn_skipped(f, f"sqlite integrity check found {len(rows)}{more} problem(s) (first: {rows[0]}); reading the "
                        "rows that remain readable")


def _readonly_uri(f: Path) -> str:
    """Read without writing anything beside the bag: ``immutable`` keeps SQLite from creating -wal/-shm files
    (a bag folder may be read-only or shared).  A non-empty -wal file (a recording cut short) must be read
    through SQLite's WAL machinery, so then the database is only opened read-only."""
    wal = f.with_name(f.name + "-wal")
    immutable = not (wal.exists() and wal.stat().st_size > 0)
    return f"{f.absolute().as_uri()}?mode=ro" + ("&immutable=1" if immutable else "")


def _sqlite_definitions(db: sqlite3.Connection) -> dict[str, tuple[str, str]]:
    try:
        rows = db.execute("SELECT topic_type, encoding, encoded_message_definition FROM message_definitions")
    except sqlite3.OperationalError:  # rosbag2 before version 9 stores no definitions
        return {}
    return {t: (d, "idl" if enc == "ros2idl" else "msg") for t, enc, d in rows if d}


class McapSource(RawSource):
    """One or more MCAP files (a split ROS2 bag folder has several), merged in time order."""

    def __init__(self, path: Path, files: list[Path], data: bytes | None = None) -> None:
        self.path = path
        self._files = files
        self._data = data  # a whole-file-compressed MCAP, already decompressed
        self.connections = []
        self._streamed: dict[str, bool] = {}
        self._recovered: dict[str, list[tuple[int, int, bytes]]] = {}
        for f in files:
            self.connections.extend(self._scan_connections(f))

    def _open(self, f: Path) -> BinaryIO:
        return io.BytesIO(self._data) if self._data is not None else open(f, "rb")

    def _scan_connections(self, f: Path) -> list[Connection]:
        with self._open(f) as stream:
            crc_ok = summary_crc_ok(stream)
            try:
                summary = make_reader(stream).get_summary() if crc_ok is not False else None
            except Exception:  # noqa: BLE001 - no footer/summary: fall back to streaming
                summary = None
            if crc_ok is False:
                warn_skipped(f, "the summary section does not match its CRC; read record by record instead")
            if summary is not None and summary.statistics is not None:
                if not summary.chunk_indexes:  # unchunked: the data section's CRC is the only check there is
                    stream.seek(0)
                    _refuse_unchunked_damage(f, read_mcap_records(stream.read()))
                counts = summary.statistics.channel_message_counts
                self._streamed[str(f)] = False
                return [_mcap_connection(f, ch, summary.schemas.get(ch.schema_id), counts.get(ch.id, 0))
                        for ch in summary.channels.values()]
        # No usable summary (truncated, unindexed): read it record by record, as far as its data goes.
        self._streamed[str(f)] = True
        with self._open(f) as stream:
            rec = read_mcap_records(stream.read())
        if rec.stopped_at is not None:
            warn_skipped(f, f"no usable summary; read {len(rec.messages)} message(s) record by record, the rest "
                         f"from byte {rec.stopped_at} on is unreadable ({rec.stop_reason})")
        if rec.damaged_chunks:
            warn_skipped(f, f"skipped {rec.damaged_chunks} damaged chunk(s) (CRC mismatch or undecodable)")
        _refuse_unchunked_damage(f, rec)
        if rec.data_crc_ok is False and not rec.damaged_chunks:
            warn_skipped(f, "the data section does not match its CRC (damage outside the chunks)")
        self._recovered[str(f)] = sorted(rec.messages, key=lambda m: m[0])
        n_msgs: dict[int, int] = {}
        for _, cid, _ in rec.messages:
            n_msgs[cid] = n_msgs.get(cid, 0) + 1
        return [
            Connection((str(f), cid), topic, normalize_msgtype(rec.schemas.get(sid, ("", "", b""))[0]),
                       "ros1" if enc == "ros1" else "cdr", rec.schemas.get(sid, ("", "", b""))[2].decode("utf-8", "replace"),
                       "idl" if rec.schemas.get(sid, ("", "", b""))[1] == "ros2idl" else "msg", n_msgs.get(cid, 0))
            for cid, (topic, enc, sid) in rec.channels.items()
        ]

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Time-ordered messages across the files."""
        wanted = None if topics is None else set(topics)
        by_key = {c.key: c for c in self.connections}
        streams = [self._file_messages(f, wanted, by_key) for f in self._files]
        yield from heapq.merge(*streams, key=lambda m: m[1])

    def _file_messages(
        self, f: Path, wanted: set[str] | None, by_key: dict[tuple[str, int], Connection]
    ) -> Iterator[RawMessage]:
        if self._streamed[str(f)]:
            for log_time, cid, data in self._recovered[str(f)]:
                conn = by_key.get((str(f), cid))
                if conn is not None and (wanted is None or conn.topic in wanted):
                    yield conn, log_time, data
            return
        with self._open(f) as stream:
            reader = make_reader(stream)
            summary = reader.get_summary()
            ids = {c.key[1] for c in by_key.values() if c.key[0] == str(f) and (wanted is None or c.topic in wanted)}
            damaged: list[Exception] = []
            try:
                if summary is not None and summary.chunk_indexes:
                    for log_time, cid, data in iter_chunk_messages(stream, summary, ids, damaged.append):
                        yield by_key[(str(f), cid)], log_time, data
                else:
                    checked = make_reader(stream, validate_crcs=True)
                    for _, ch, m in checked.iter_messages(topics=None if wanted is None else list(wanted)):
                        yield by_key[(str(f), ch.id)], m.log_time, m.data
            except _MCAP_ERRORS as err:  # a damaged chunk
                warn_skipped(f, f"stopped at a damaged chunk ({type(err).__name__}: {err})")
            if damaged:
                warn_skipped(f, f"skipped {len(damaged)} damaged chunk(s) ({damaged[0]})")


def _refuse_unchunked_damage(f: Path, rec: McapRecords) -> None:
    """An MCAP without chunks whose data section fails its CRC: the damage could be in any message and there is
    no smaller checksummed unit to drop, so the file is refused rather than read with changed values."""
    if rec.chunks == 0 and rec.data_crc_ok is False:
        raise LogError(f, "damaged: the data section does not match its CRC (an unchunked MCAP: no telling which "
                          "messages changed)")


def _mcap_connection(f: Path, channel: object, schema: object, count: int) -> Connection:
    enc = getattr(channel, "message_encoding", "")
    name = getattr(schema, "name", "") if schema is not None else ""
    sdata = getattr(schema, "data", b"") if schema is not None else b""
    senc = getattr(schema, "encoding", "") if schema is not None else ""
    definition = sdata.decode("utf-8", "replace") if isinstance(sdata, bytes | bytearray) else ""
    return Connection(
        (str(f), int(getattr(channel, "id", 0))), str(getattr(channel, "topic", "")), normalize_msgtype(name),
        "ros1" if enc == "ros1" else "cdr" if enc == "cdr" else enc, definition,
        "idl" if senc == "ros2idl" else "msg", count,
    )
