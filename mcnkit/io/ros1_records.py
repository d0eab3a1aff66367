"""Reads a ROS1 bag (format 2.0) record by record, without its index: the way to recover an unindexed or
truncated bag.  Reading stops at the first record that is cut off or damaged; everything before it is kept.

Record layout: ``header_len u32, header (fields: len u32 + "name=value"), data_len u32, data``.  The header's
``op`` byte says what it is: 0x02 message data, 0x03 bag header, 0x04 index, 0x05 chunk (bz2/lz4/none
compressed records inside), 0x06 chunk info, 0x07 connection.
"""

from __future__ import annotations

import bz2
import heapq
import struct
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, BinaryIO

import lz4.frame

from mcnkit.io.errors import LogError

__all__ = [
    "ChunkInfo",
    "RecoveredBag",
    "RecoveredConnection",
    "iter_indexed_messages",
    "read_ros1_index",
    "read_ros1_records",
]

_MAGIC = b"#ROSBAG V2.0\n"
_U32 = struct.Struct("<I")
_TIME = struct.Struct("<II")
_OP_MSG, _OP_BAG, _OP_CHUNK, _OP_CHUNK_INFO, _OP_CONN = 0x02, 0x03, 0x05, 0x06, 0x07


@dataclass(frozen=True)
class RecoveredConnection:
    """A connection record: id, topic, type and the full message definition text."""

    conn_id: int
    topic: str
    msgtype: str
    definition: str


@dataclass
class RecoveredBag:
    """What could be read: connections, messages ``(time ns, conn id, raw)``, and where reading stopped."""

    connections: list[RecoveredConnection] = field(default_factory=list)
    messages: list[tuple[int, int, bytes]] = field(default_factory=list)
    stopped_at: int | None = None
    stop_reason: str = ""


def _fields(header: bytes) -> dict[str, bytes]:
    out, off = {}, 0
    while off + 4 <= len(header):
        (n,) = _U32.unpack_from(header, off)
        off += 4
        if n > len(header) - off:
            raise ValueError("header field runs past the header")
        name, _, value = header[off : off + n].partition(b"=")
        out[name.decode("ascii", "replace")] = value
        off += n
    return out


def _records(buf: bytes, start: int) -> tuple[list[tuple[dict[str, bytes], bytes]], int | None, str]:
    """Splits ``buf`` into (header fields, data) records; returns where and why it stopped early, if it did.

    A last record whose header is whole but whose data is cut off is returned with the data that is there
    (an uncompressed chunk cut off mid-way still holds whole messages).
    """
    out: list[tuple[dict[str, bytes], bytes]] = []
    off = start
    while off < len(buf):
        try:
            (hlen,) = _U32.unpack_from(buf, off)
            if off + 4 + hlen + 4 > len(buf):
                raise ValueError("record header is cut off")
            fields = _fields(buf[off + 4 : off + 4 + hlen])
            (dlen,) = _U32.unpack_from(buf, off + 4 + hlen)
            dstart = off + 8 + hlen
            if "op" not in fields:
                raise ValueError("record has no op field")
            if dstart + dlen > len(buf):
                if fields["op"][:1] == bytes([_OP_CHUNK]):
                    out.append(({**fields, "cut": b"1"}, buf[dstart:]))
                raise ValueError("record data is cut off")
        except (struct.error, ValueError) as err:
            return out, off, str(err)
        out.append((fields, buf[dstart : dstart + dlen]))
        off = dstart + dlen
    return out, None, ""


def _decompress(kind: bytes, data: bytes, partial: bool = False) -> bytes:
    """Decompresses a chunk; ``partial``: the data is cut off, return what decompresses."""
    if kind == b"none":
        return data
    if kind == b"bz2":
        return bz2.BZ2Decompressor().decompress(data) if partial else bz2.decompress(data)
    if kind == b"lz4":
        return bytes(lz4.frame.LZ4FrameDecompressor().decompress(data) if partial else lz4.frame.decompress(data))
    raise ValueError(f"unknown chunk compression {kind.decode('ascii', 'replace')!r}")


def _take(bag: RecoveredBag, fields: dict[str, bytes], data: bytes, seen: set[int]) -> None:
    op = fields["op"][0]
    if op == _OP_CONN:
        conn_id = _U32.unpack(fields["conn"])[0]
        if conn_id not in seen:
            seen.add(conn_id)
            info = _fields(data)
            bag.connections.append(RecoveredConnection(
                conn_id, fields["topic"].decode(), info.get("type", b"").decode(),
                info.get("message_definition", b"").decode("utf-8", "replace"),
            ))
    elif op == _OP_MSG:
        sec, nsec = struct.unpack("<II", fields["time"])
        bag.messages.append((sec * 1_000_000_000 + nsec, _U32.unpack(fields["conn"])[0], data))


def read_ros1_records(path: Path) -> RecoveredBag:
    """Reads every record up to the first damaged one.  Raises :class:`LogError` if this is no ROS1 bag."""
    buf = path.read_bytes()
    if not buf.startswith(_MAGIC):
        raise LogError(path, "not a ROS1 bag (no '#ROSBAG V2.0' magic)")
    bag, seen = RecoveredBag(), set[int]()
    records, stop, why = _records(buf, len(_MAGIC))
    for fields, data in records:
        if not fields.get("op"):
            continue
        try:
            if fields["op"][0] == _OP_CHUNK:
                inner = _decompress(fields.get("compression", b"none"), data, partial="cut" in fields)
                chunk_records, cstop, cwhy = _records(inner, 0)
                for f2, d2 in chunk_records:
                    _take(bag, f2, d2, seen)
                if cstop is not None:
                    raise ValueError(f"chunk damaged: {cwhy}")
            else:
                _take(bag, fields, data, seen)
        except (ValueError, KeyError, OSError, RuntimeError, struct.error, UnicodeDecodeError) as err:
            bag.stopped_at, bag.stop_reason = len(buf) - len(data), str(err) or type(err).__name__
            return bag
    if stop is not None:
        bag.stopped_at, bag.stop_reason = stop, why
    return bag


def _salvage(kind: bytes, data: bytes) -> bytes:
    """What decompresses of a damaged chunk before the damage (fed in pieces: output before the error is kept)."""
    if kind == b"none":
        return data
    d: Any = bz2.BZ2Decompressor() if kind == b"bz2" else lz4.frame.LZ4FrameDecompressor()
    out = bytearray()
    for i in range(0, len(data), 4096):
        try:
            out += d.decompress(data[i : i + 4096])
        except (OSError, RuntimeError, ValueError, EOFError):
            break
    return bytes(out)


def _chunk_messages(
    f: BinaryIO, pos: int, conn_ids: set[int], on_damaged: Callable[[str], None] | None = None
) -> list[tuple[int, int, bytes]]:
    f.seek(pos)
    (hlen,) = _U32.unpack(f.read(4))
    fields = _fields(f.read(hlen))
    (dlen,) = _U32.unpack(f.read(4))
    raw = f.read(dlen)
    kind = fields.get("compression", b"none")
    damaged = None
    try:
        inner = _decompress(kind, raw)
    except (OSError, RuntimeError, ValueError, EOFError) as err:
        if on_damaged is None:
            raise
        inner, damaged = _salvage(kind, raw), str(err) or type(err).__name__
    out, off, end = [], 0, len(inner)
    unpack, unpack_time = _U32.unpack_from, _TIME.unpack_from
    try:
        while off + 4 <= end:
            (hlen,) = unpack(inner, off)
            header = inner[off + 4 : off + 4 + hlen]
            (dlen,) = unpack(inner, off + 4 + hlen)
            dstart = off + 8 + hlen
            if dstart + dlen > end:
                raise ValueError("a record runs past the end of its chunk")
            # Message-data headers hold op, conn and time: find them by name instead of parsing every field.
            if b"op=\x02" in header:
                conn = unpack(header, header.find(b"conn=") + 5)[0]
                if conn in conn_ids:
                    sec, nsec = unpack_time(header, header.find(b"time=") + 5)
                    out.append((sec * 1_000_000_000 + nsec, conn, inner[dstart : dstart + dlen]))
            off = dstart + dlen
    except (struct.error, ValueError) as err:
        if on_damaged is None:
            raise
        damaged = damaged or str(err)
    if damaged is not None and on_damaged is not None:
        on_damaged(damaged)
    out.sort(key=lambda m: m[0])
    return out


def iter_indexed_messages(
    path: Path, chunk_infos: list[Any], conn_ids: set[int], on_damaged: Callable[[str], None] | None = None
) -> Iterator[tuple[int, int, bytes]]:
    """``(time ns, conn id, raw)`` in time order from an indexed bag's chunks (``rosbags`` ChunkInfo list).

    Each chunk is read and decompressed once; chunks whose time ranges overlap are merged.  With
    ``on_damaged``, a chunk that does not decompress or split into records gives the messages before the damage
    and is reported to it; without, the error is raised.
    """
    infos = sorted((c for c in chunk_infos if any(k in conn_ids for k in c.connection_counts)),
                   key=lambda c: (c.start_time, c.pos))
    with open(path, "rb") as f:
        group: list[list[tuple[int, int, bytes]]] = []
        group_end = -1
        for c in infos:
            if group and c.start_time >= group_end:
                yield from (heapq.merge(*group, key=lambda m: m[0]) if len(group) > 1 else group[0])
                group = []
            try:
                group.append(_chunk_messages(f, c.pos, conn_ids, on_damaged))
            except (struct.error, ValueError, KeyError, OSError) as err:
                if on_damaged is None:
                    raise
                on_damaged(f"chunk header: {err}")
                continue
            group_end = max(group_end, c.end_time)
        if group:
            yield from (heapq.merge(*group, key=lambda m: m[0]) if len(group) > 1 else group[0])


@dataclass(frozen=True)
class ChunkInfo:
    """Where a chunk is and which connections it holds: from the bag's index."""

    pos: int
    start_time: int
    end_time: int
    connection_counts: dict[int, int]


def read_ros1_index(path: Path) -> tuple[list[RecoveredConnection], list[ChunkInfo]]:
    """Connections and chunk infos from the index at the end of an indexed bag.

    Raises:
        ValueError: the bag has no index (``index_pos`` 0, cut off, or damaged).
    """
    with open(path, "rb") as f:
        buf = f.read(len(_MAGIC) + 8192)  # the bag header record is padded to 4096 bytes
        if not buf.startswith(_MAGIC):
            raise LogError(path, "not a ROS1 bag (no '#ROSBAG V2.0' magic)")
        records, _, _ = _records(buf, len(_MAGIC))
        if not records or records[0][0].get("op", b"\x00")[0] != _OP_BAG:
            raise ValueError("no bag header record")
        fields = records[0][0]
        index_pos = struct.unpack("<Q", fields["index_pos"])[0]
        n_conns = _U32.unpack(fields["conn_count"])[0]
        n_chunks = _U32.unpack(fields["chunk_count"])[0]
        if index_pos == 0:
            raise ValueError("Bag is not indexed")
        f.seek(index_pos)
        tail = f.read()
    index, stop, why = _records(tail, 0)
    if stop is not None:
        raise ValueError(f"the index is damaged ({why})")
    conns, seen = [], set[int]()
    chunks = []
    for fields, data in index:
        op = fields["op"][0]
        if op == _OP_CONN:
            bag = RecoveredBag()
            _take(bag, fields, data, seen)
            conns.extend(bag.connections)
        elif op == _OP_CHUNK_INFO:
            start = struct.unpack("<II", fields["start_time"])
            end = struct.unpack("<II", fields["end_time"])
            counts = dict(struct.iter_unpack("<II", data))
            chunks.append(ChunkInfo(struct.unpack("<Q", fields["chunk_pos"])[0],
                                    start[0] * 1_000_000_000 + start[1], end[0] * 1_000_000_000 + end[1], counts))
    if len(conns) != n_conns or len(chunks) != n_chunks:
        raise ValueError(f"the index lists {len(conns)}/{n_conns} connections and {len(chunks)}/{n_chunks} chunks")
    return conns, chunks
