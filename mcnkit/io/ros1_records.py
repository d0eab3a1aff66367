"""ROS1 bags (format 2.0) at the record level: the index at the end of a bag, its chunks, and the record-by-record
walk that recovers a bag without a usable index (never indexed, or truncated), stopping at the first record that is
cut off or damaged and keeping everything before it.

Record layout: ``header_len u32, header (fields: len u32 + "name=value"), data_len u32, data``.  The header's
``op`` byte says what it is: 0x02 message data, 0x03 bag header, 0x04 index data, 0x05 chunk (bz2/lz4/none
compressed records inside), 0x06 chunk info, 0x07 connection.

Memory: one chunk at a time (``MAX_CHUNK_BYTES``), messages outside compressed chunks read one by one.  The walk
indexes every message (:class:`~mcnkit.io.msgindex.MessageIndex`) and reads none of them; reading them in time
order afterwards decompresses each chunk about once.
"""

from __future__ import annotations

import bz2
import heapq
import struct
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import lz4.frame

from mcnkit.io.errors import LogError
from mcnkit.io.limits import MAX_CHUNK_BYTES, MAX_DEFINITION_BYTES, check_size
from mcnkit.io.msgindex import Block, MessageIndex, read_indexed
from mcnkit.io.streams import FileBytes

__all__ = [
    "ChunkInfo",
    "RecoveredConnection",
    "Ros1Walk",
    "iter_indexed_messages",
    "read_ros1_index",
    "read_walked",
    "walk_ros1_records",
]

MAGIC = b"#ROSBAG V2.0\n"
_U32 = struct.Struct("<I")
_TIME = struct.Struct("<II")
_OP_MSG, _OP_BAG, _OP_CHUNK, _OP_CHUNK_INFO, _OP_CONN = 0x02, 0x03, 0x05, 0x06, 0x07
_WINDOW = 1 << 14


@dataclass(frozen=True)
class RecoveredConnection:
    """A connection record: id, topic, type and the full message definition text."""

    conn_id: int
    topic: str
    msgtype: str
    definition: str


@dataclass(frozen=True)
class ChunkInfo:
    """Where a chunk is and which connections it holds: from the bag's index."""

    pos: int
    start_time: int
    end_time: int
    connection_counts: dict[int, int]


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


def _decompress(kind: bytes, data: bytes, size: int, partial: bool = False) -> bytes:
    """A chunk's records, at most its declared ``size``; ``partial``: the data is cut off, give what decompresses."""
    if kind == b"none":
        return data
    if kind not in (b"bz2", b"lz4"):
        raise ValueError(f"unknown chunk compression {kind.decode('ascii', 'replace')!r}")
    d: Any = bz2.BZ2Decompressor() if kind == b"bz2" else lz4.frame.LZ4FrameDecompressor()
    out = bytes(d.decompress(data, max_length=size + 1))
    if len(out) > size:
        raise ValueError(f"chunk decompresses to more than the {size} bytes it declares")
    if not partial and not d.eof:
        raise ValueError("chunk data ends before its compressed stream does")
    return out


def _salvage(kind: bytes, data: bytes, size: int) -> bytes:
    """What decompresses of a damaged chunk before the damage (fed in pieces: output before the error is kept)."""
    if kind == b"none":
        return data
    d: Any = bz2.BZ2Decompressor() if kind == b"bz2" else lz4.frame.LZ4FrameDecompressor()
    out = bytearray()
    for i in range(0, len(data), 4096):
        try:
            out += d.decompress(data[i : i + 4096], max_length=max(0, size - len(out)))
        except (OSError, RuntimeError, ValueError, EOFError):
            break
        if len(out) >= size:
            break
    return bytes(out)


def _record_head(src: FileBytes, path: Path, off: int) -> tuple[dict[str, bytes], int, int]:
    """(header fields, data start, data length) of the record at ``off``; ValueError when it is cut off or damaged,
    LogError when it holds a header no bag has."""
    head = src.read_at(off, 4)
    if len(head) < 4:
        raise ValueError("record header is cut off")
    (hlen,) = _U32.unpack(head)
    if off + 8 + hlen > src.size:
        raise ValueError("record header is cut off")
    check_size(path, f"a record header at byte {off}", hlen, MAX_DEFINITION_BYTES)
    raw = src.read_at(off + 4, hlen + 4)
    fields = _fields(raw[:hlen])
    if "op" not in fields:
        raise ValueError("record has no op field")
    (dlen,) = _U32.unpack_from(raw, hlen)
    return fields, off + 8 + hlen, dlen


def _chunk_bytes(src: FileBytes, path: Path, fields: dict[str, bytes], dstart: int, dlen: int,
                 partial: bool = False) -> bytes:
    """A chunk record's decompressed records (ValueError/struct.error when damaged)."""
    (size,) = _U32.unpack(fields["size"])
    if not partial and dstart + dlen > src.size:
        raise ValueError(f"the chunk at byte {dstart} runs {dstart + dlen - src.size} bytes past the end of the file")
    check_size(path, f"a chunk at byte {dstart}", dlen, MAX_CHUNK_BYTES)
    if size > MAX_CHUNK_BYTES:  # the file does not hold it: a damaged size field
        raise ValueError(f"chunk at byte {dstart} claims {size} bytes uncompressed")
    return _decompress(fields.get("compression", b"none"), src.read_at(dstart, dlen), size, partial)


# -- the index -----------------------------------------------------------------------------------------------------
def _connection(fields: dict[str, bytes], data: bytes) -> RecoveredConnection:
    info = _fields(data)
    return RecoveredConnection(_U32.unpack(fields["conn"])[0], fields["topic"].decode(), info.get("type", b"").decode(),
                               info.get("message_definition", b"").decode("utf-8", "replace"))


def read_ros1_index(path: Path, src: FileBytes) -> tuple[list[RecoveredConnection], list[ChunkInfo]]:
    """Connections and chunk infos from the index at the end of an indexed bag.

    Raises:
        LogError: not a ROS1 bag.
        ValueError: the bag has no index (``index_pos`` 0, cut off, or damaged).
    """
    if src.read_at(0, len(MAGIC)) != MAGIC:
        raise LogError(path, "not a ROS1 bag (no '#ROSBAG V2.0' magic)")
    fields, _, _ = _record_head(src, path, len(MAGIC))
    if fields["op"][:1] != bytes([_OP_BAG]):
        raise ValueError("no bag header record")
    index_pos = struct.unpack("<Q", fields["index_pos"])[0]
    n_conns = _U32.unpack(fields["conn_count"])[0]
    n_chunks = _U32.unpack(fields["chunk_count"])[0]
    if index_pos == 0:
        raise ValueError("Bag is not indexed")
    if not len(MAGIC) < index_pos <= src.size:
        raise ValueError(f"the index position {index_pos} is outside the file")
    conns, seen, chunks = [], set[int](), []
    off = index_pos
    while off < src.size:
        try:
            fields, dstart, dlen = _record_head(src, path, off)
        except ValueError as err:
            raise ValueError(f"the index is damaged ({err})") from err
        if dstart + dlen > src.size:
            raise ValueError("the index is damaged (record data is cut off)")
        op = fields["op"][0]
        if op == _OP_CONN:
            check_size(path, f"a connection record at byte {off}", dlen, MAX_DEFINITION_BYTES)
            conn = _connection(fields, src.read_at(dstart, dlen))
            if conn.conn_id not in seen:
                seen.add(conn.conn_id)
                conns.append(conn)
        elif op == _OP_CHUNK_INFO:
            check_size(path, f"a chunk info record at byte {off}", dlen, MAX_DEFINITION_BYTES)
            start = _TIME.unpack(fields["start_time"])
            end = _TIME.unpack(fields["end_time"])
            counts = dict(struct.iter_unpack("<II", src.read_at(dstart, dlen)))
            chunks.append(ChunkInfo(struct.unpack("<Q", fields["chunk_pos"])[0],
                                    start[0] * 1_000_000_000 + start[1], end[0] * 1_000_000_000 + end[1], counts))
        off = dstart + dlen
    if len(conns) != n_conns or len(chunks) != n_chunks:
        raise ValueError(f"the index lists {len(conns)}/{n_conns} connections and {len(chunks)}/{n_chunks} chunks")
    return conns, chunks


def _plain_chunk_messages(src: FileBytes, start: int, end: int, conn_ids: set[int],
                          out: list[tuple[int, int, bytes]]) -> None:
    """The wanted messages of an uncompressed chunk (``start``..``end`` in the file) into ``out``, read through a
    window that skips what is not wanted (a camera image beside the scans is never read).  ValueError/struct.error
    when a record does not fit in the chunk (``out`` keeps the messages before it)."""
    window, at = b"", start
    off = start
    while off + 4 <= end:
        if off + 8 > at + len(window):
            window, at = src.read_at(off, min(_WINDOW, end - off)), off
        (hlen,) = _U32.unpack_from(window, off - at)
        if off + 8 + hlen > end:
            raise ValueError("a record runs past the end of its chunk")
        if off + 8 + hlen > at + len(window):
            window, at = src.read_at(off, min(max(_WINDOW, 8 + hlen), end - off)), off
        rel = off - at
        header = window[rel + 4 : rel + 4 + hlen]
        (dlen,) = _U32.unpack_from(window, rel + 4 + hlen)
        dstart = off + 8 + hlen
        if dstart + dlen > end:
            raise ValueError("a record runs past the end of its chunk")
        if b"op=\x02" in header:
            conn = _U32.unpack_from(header, header.find(b"conn=") + 5)[0]
            if conn in conn_ids:
                sec, nsec = _TIME.unpack_from(header, header.find(b"time=") + 5)
                data = (window[dstart - at : dstart - at + dlen] if dstart + dlen <= at + len(window)
                        else src.read_at(dstart, dlen))
                out.append((sec * 1_000_000_000 + nsec, conn, data))
        off = dstart + dlen


def _chunk_messages(src: FileBytes, path: Path, pos: int, conn_ids: set[int],
                    on_damaged: Callable[[str], None] | None = None) -> list[tuple[int, int, bytes]]:
    fields, dstart, dlen = _record_head(src, path, pos)
    kind = fields.get("compression", b"none")
    if kind == b"none":
        found: list[tuple[int, int, bytes]] = []
        try:
            _plain_chunk_messages(src, dstart, min(dstart + dlen, src.size), conn_ids, found)
            if dstart + dlen > src.size:
                raise ValueError("the chunk is cut off")
        except (struct.error, ValueError) as err:
            if on_damaged is None:
                raise
            on_damaged(str(err))
        found.sort(key=lambda m: m[0])
        return found
    damaged = None
    try:
        inner = _chunk_bytes(src, path, fields, dstart, dlen)
    except (OSError, RuntimeError, ValueError, EOFError) as err:
        if on_damaged is None:
            raise
        inner = _salvage(kind, src.read_at(dstart, dlen), _U32.unpack(fields["size"])[0])
        damaged = str(err) or type(err).__name__
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


def iter_indexed_messages(path: Path, src: FileBytes, chunk_infos: list[ChunkInfo], conn_ids: set[int],
                          on_damaged: Callable[[str], None] | None = None) -> Iterator[tuple[int, int, bytes]]:
    """``(time ns, conn id, raw)`` in time order from an indexed bag's chunks.

    Each chunk is read and decompressed once; chunks whose time ranges overlap are merged.  With ``on_damaged``,
    a chunk that does not decompress or split into records gives the messages before the damage and is reported
    to it; without, the error is raised.
    """
    infos = sorted((c for c in chunk_infos if any(k in conn_ids for k in c.connection_counts)),
                   key=lambda c: (c.start_time, c.pos))
    group: list[list[tuple[int, int, bytes]]] = []
    group_end = -1
    for c in infos:
        if group and c.start_time >= group_end:
            yield from (heapq.merge(*group, key=lambda m: m[0]) if len(group) > 1 else group[0])
            group = []
        try:
            group.append(_chunk_messages(src, path, c.pos, conn_ids, on_damaged))
        except (struct.error, ValueError, KeyError, OSError) as err:
            if on_damaged is None:
                raise
            on_damaged(f"chunk header: {err}")
            continue
        group_end = max(group_end, c.end_time)
    if group:
        yield from (heapq.merge(*group, key=lambda m: m[0]) if len(group) > 1 else group[0])


# -- the record walk -----------------------------------------------------------------------------------------------
@dataclass
class Ros1Walk:
    """What a record-by-record pass found: connections, an index of the messages, and where (and why) it stopped."""

    connections: list[RecoveredConnection] = field(default_factory=list)
    index: MessageIndex = field(default_factory=MessageIndex)
    blocks: list[Block] = field(default_factory=list)
    stopped_at: int | None = None
    stop_reason: str = ""


def _walk_chunk(walk: Ros1Walk, inner: bytes, base: int, block: int, seen: set[int]) -> str | None:
    """Indexes the records of one decompressed chunk; returns why it stopped early (None: it did not).  ``base``:
    where ``inner`` starts in the file (an uncompressed chunk), ``block``: its block number (a compressed one)."""
    times, conns, offsets, lengths = [], [], [], []
    off, end = 0, len(inner)
    why = None
    try:
        while off < end:
            if off + 4 > end:
                raise ValueError("record header is cut off")
            (hlen,) = _U32.unpack_from(inner, off)
            if off + 8 + hlen > end:
                raise ValueError("record header is cut off")
            fields = _fields(inner[off + 4 : off + 4 + hlen])
            (dlen,) = _U32.unpack_from(inner, off + 4 + hlen)
            dstart = off + 8 + hlen
            if "op" not in fields:
                raise ValueError("record has no op field")
            if dstart + dlen > end:
                raise ValueError("record data is cut off")
            op = fields["op"][0]
            if op == _OP_MSG:
                sec, nsec = _TIME.unpack(fields["time"])
                times.append(sec * 1_000_000_000 + nsec)
                conns.append(_U32.unpack(fields["conn"])[0])
                offsets.append(base + dstart)
                lengths.append(dlen)
            elif op == _OP_CONN:
                _take_connection(walk, fields, inner[dstart : dstart + dlen], seen)
            off = dstart + dlen
    except (ValueError, KeyError, IndexError, struct.error, UnicodeDecodeError) as err:
        why = str(err) or type(err).__name__
    walk.index.add(times, conns, block, offsets, lengths)
    return why


def _take_connection(walk: Ros1Walk, fields: dict[str, bytes], data: bytes, seen: set[int]) -> None:
    conn = _connection(fields, data)
    if conn.conn_id not in seen:
        seen.add(conn.conn_id)
        walk.connections.append(conn)


def walk_ros1_records(path: Path, src: FileBytes) -> Ros1Walk:
    """Indexes every record up to the first damaged one.  Raises :class:`LogError` if this is no ROS1 bag, or when
    the bag holds a record larger than a reader holds (``mcnkit.io.limits``)."""
    if src.read_at(0, len(MAGIC)) != MAGIC:
        raise LogError(path, "not a ROS1 bag (no '#ROSBAG V2.0' magic)")
    walk, seen = Ros1Walk(), set[int]()
    off = len(MAGIC)
    while off < src.size:
        try:
            fields, dstart, dlen = _record_head(src, path, off)
            op = fields["op"][0]
            cut = dstart + dlen > src.size
            if cut and op != _OP_CHUNK:
                raise ValueError("record data is cut off")
            if op == _OP_CHUNK:
                kind = fields.get("compression", b"none")
                stored = min(dlen, src.size - dstart)
                inner = _chunk_bytes(src, path, fields, dstart, stored, partial=cut)
                if kind == b"none":
                    why = _walk_chunk(walk, inner, dstart, -1, seen)
                else:
                    walk.blocks.append(Block(dstart, stored, kind.decode(), _U32.unpack(fields["size"])[0], cut))
                    why = _walk_chunk(walk, inner, 0, len(walk.blocks) - 1, seen)
                if why is not None:
                    raise ValueError(f"chunk damaged: {why}")
                if cut:
                    raise ValueError("record data is cut off")
            elif op == _OP_CONN:
                check_size(path, f"a connection record at byte {off}", dlen, MAX_DEFINITION_BYTES)
                _take_connection(walk, fields, src.read_at(dstart, dlen), seen)
            elif op == _OP_MSG:
                sec, nsec = _TIME.unpack(fields["time"])
                walk.index.add([sec * 1_000_000_000 + nsec], [_U32.unpack(fields["conn"])[0]], -1, [dstart], [dlen])
        except (ValueError, KeyError, IndexError, OSError, RuntimeError, EOFError, struct.error,
                UnicodeDecodeError) as err:
            walk.stopped_at, walk.stop_reason = off, str(err) or type(err).__name__
            return walk
        off = dstart + dlen
    return walk


def read_walked(path: Path, src: FileBytes, walk: Ros1Walk, limits: dict[int, tuple[str, int]]
                ) -> Iterator[tuple[int, int, bytes]]:
    """``(time ns, conn id, raw)`` in time order for the connections in ``limits`` (see
    :func:`~mcnkit.io.msgindex.read_indexed`)."""

    def load(block: int) -> bytes:
        b = walk.blocks[block]
        return _decompress(b.compression.encode(), src.read_at(b.offset, b.length), b.size, partial=b.partial)

    return read_indexed(path, src, walk.index, load, limits)
