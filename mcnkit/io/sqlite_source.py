"""The sqlite3 storage of a ROS2 bag folder, read through sqlite3 directly (split bags: several files, merged in
time order).  SQLite pages through the file itself; a message row is fetched only for the topics asked for, and a
row larger than its topic's limit (:mod:`mcnkit.io.limits`) is refused before its blob is loaded."""

from __future__ import annotations

import heapq
import sqlite3
from collections.abc import Iterable, Iterator
from pathlib import Path

from mcnkit.io.decode import normalize_msgtype
from mcnkit.io.errors import LogError, warn_skipped
from mcnkit.io.limits import check_size, message_limit
from mcnkit.io.sources import Connection, RawMessage, RawSource

__all__ = ["SqliteSource"]


class SqliteSource(RawSource):
    """The sqlite3 files of a ROS2 bag folder (split bags: several files, merged in time order).  ``shown``: the
    names errors and warnings give the files (the compressed originals of decompressed copies); default ``files``."""

    def __init__(self, path: Path, files: list[Path], shown: list[Path] | None = None) -> None:
        self.path = path
        self._dbs: list[tuple[Path, sqlite3.Connection]] = []
        self.connections = []
        for f, shown_as in zip(files, shown or files, strict=True):
            try:
                db = sqlite3.connect(_readonly_uri(f), uri=True)
                topics = db.execute("SELECT id, name, type, serialization_format FROM topics").fetchall()
                counts = dict(db.execute("SELECT topic_id, count(*) FROM messages GROUP BY topic_id").fetchall())
                defs = _sqlite_definitions(db)
            except sqlite3.DatabaseError as err:
                raise LogError(shown_as, f"not a readable rosbag2 sqlite3 file ({err})") from err
            _quick_check(shown_as, db)
            self._dbs.append((f, db))
            for tid, name, msgtype, fmt in topics:
                if fmt != "cdr":
                    warn_skipped(shown_as, f"topic {name} uses serialization {fmt!r}, not cdr; skipped")
                    continue
                d, dfmt = defs.get(msgtype, ("", "msg"))
                c = Connection((str(f), tid), name, normalize_msgtype(msgtype), "cdr", d, dfmt, counts.get(tid, 0))
                self.connections.append(c)

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """Time-ordered messages, merged across the files of a split bag."""
        wanted = None if topics is None else set(topics)
        streams = []
        for f, db in self._dbs:
            by_id = {c.key[1]: c for c in self.connections if c.key[0] == str(f)
                     and (wanted is None or c.topic in wanted)}
            if by_id:
                streams.append(self._rows(f, db, by_id))
        odd = 0
        try:
            for t, conn, data in heapq.merge(*streams, key=lambda m: m[0]):
                if conn is None:
                    odd += 1
                    continue
                if isinstance(data, int):  # the blob's length instead of the blob: over the limit
                    check_size(self.path, f"a message on {conn.topic} at {t} ns", data, message_limit(conn.msgtype))
                    continue
                yield conn, t, data
        except sqlite3.DatabaseError as err:
            warn_skipped(self.path, f"stopped at a damaged database page ({err})")
        if odd:
            warn_skipped(self.path, f"skipped {odd} message row(s) whose timestamp is not an integer or whose data is "
                                    "not a blob (damaged rows)")

    @staticmethod
    def _rows(f: Path, db: sqlite3.Connection, by_id: dict[int, Connection]
              ) -> Iterator[tuple[int, Connection | None, bytes | int]]:
        """Rows of one file in time order; a blob over its topic's limit comes as its length, a damaged row (values
        of other types) sorts first with no connection."""
        limits = {tid: message_limit(c.msgtype) for tid, c in by_id.items()}
        marks = ",".join("?" * len(by_id))
        cur = db.execute(
            "SELECT timestamp, topic_id, CASE WHEN typeof(data) != 'blob' THEN NULL WHEN length(data) <= ? THEN data "
            f"ELSE length(data) END FROM messages WHERE topic_id IN ({marks}) ORDER BY timestamp",
            [max(limits.values()), *by_id],
        )
        for t, tid, data in cur:
            if type(t) is not int or tid not in by_id or data is None:
                yield -(2**63), None, b""
            elif isinstance(data, int) or len(data) > limits[tid]:
                yield t, by_id[tid], data if isinstance(data, int) else len(data)
            else:
                yield t, by_id[tid], data

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
