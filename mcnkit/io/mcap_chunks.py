"""Indexed MCAP files: the summary section (schemas, channels, chunk indexes, statistics), read with ``struct``
within the limits of :mod:`mcnkit.io.limits`, and the chunks it lists, each read and decompressed once and split
with ``struct`` — about 3× faster than the ``mcap`` package's ordered iterator, whose per-message heap dominates on
logs of small messages.

Record framing (MCAP spec): ``opcode u8, length u64, body``.  A Chunk body is ``start u64, end u64,
uncompressed_size u64, crc u32, compression (u32 len + str), records (u64 len + bytes)``; a Message body is
``channel u16, sequence u32, log_time u64, publish_time u64, data``.

Checksums: a chunk's ``uncompressed_crc`` (CRC32 of its decompressed records, 0 = not written) is checked on
every chunk read; a chunk that fails it (or fails to decompress) is skipped and counted, the others are read.
The footer's ``summary_crc`` covers the summary section (:func:`read_summary`), and a record-by-record read
(:mod:`mcnkit.io.mcap_records`) checks the ``DataEnd`` record's CRC of the whole data section.
"""

from __future__ import annotations

import heapq
import struct
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

import lz4.frame
import zstandard

from mcnkit.io.limits import MAX_CHUNK_BYTES, check_size
from mcnkit.io.streams import FileBytes

__all__ = ["MAGIC", "ChunkCrcError", "ChunkIndex", "Summary", "decompress_chunk", "iter_chunk_messages",
           "read_summary", "take_definition", "take_string"]

MAGIC = b"\x89MCAP0\r\n"
_OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK = 0x02, 0x03, 0x04, 0x05, 0x06
_OP_CHUNK_INDEX, _OP_STATISTICS = 0x08, 0x0B
_RECORD = struct.Struct("<BQ")
_MSG_HEAD = struct.Struct("<HIQQ")
_FOOTER = 9 + 20  # opcode, length, summary_start u64, summary_offset_start u64, crc u32
_CRC_PIECE = 1 << 20


class ChunkCrcError(ValueError):
    """A chunk whose records do not match its CRC."""


@dataclass(frozen=True)
class ChunkIndex:
    """Where a chunk is, the log times it spans and the channels it holds (channel -> its message index offset)."""

    message_start_time: int
    message_end_time: int
    chunk_start_offset: int
    chunk_length: int
    message_index_offsets: dict[int, int]


@dataclass
class Summary:
    """What an MCAP summary section lists."""

    schemas: dict[int, tuple[str, str, bytes]] = field(default_factory=dict)  # id -> (name, encoding, data)
    channels: dict[int, tuple[str, str, int]] = field(default_factory=dict)  # id -> (topic, message encoding, schema)
    chunk_indexes: list[ChunkIndex] = field(default_factory=list)
    channel_message_counts: dict[int, int] | None = None  # from the Statistics record (None: there is none)


def take_string(buf: bytes | memoryview, off: int) -> tuple[str, int]:
    """A ``u32 length + UTF-8`` string at ``off`` and the offset after it."""
    (n,) = struct.unpack_from("<I", buf, off)
    if off + 4 + n > len(buf):
        raise ValueError("string runs past the record")
    return bytes(buf[off + 4 : off + 4 + n]).decode("utf-8", "replace"), off + 4 + n


def _take_map(buf: bytes, off: int, fmt: str) -> tuple[dict[int, int], int]:
    (n,) = struct.unpack_from("<I", buf, off)
    item = struct.calcsize(fmt)
    if off + 4 + n > len(buf) or n % item:
        raise ValueError("map runs past the record")
    return dict(struct.iter_unpack(fmt, buf[off + 4 : off + 4 + n])), off + 4 + n


def take_definition(schemas: dict[int, tuple[str, str, bytes]], channels: dict[int, tuple[str, str, int]], op: int,
                    body: bytes) -> None:
    """Files a Schema (``op`` 0x03: id -> name, encoding, data) or Channel record (0x04: id -> topic, message
    encoding, schema id); struct.error/ValueError when it is damaged."""
    if op == _OP_SCHEMA:
        (sid,) = struct.unpack_from("<H", body, 0)
        name, o = take_string(body, 2)
        enc, o = take_string(body, o)
        (n,) = struct.unpack_from("<I", body, o)
        schemas[sid] = (name, enc, bytes(body[o + 4 : o + 4 + n]))
    elif op == _OP_CHANNEL:
        cid, sid = struct.unpack_from("<HH", body, 0)
        topic, o = take_string(body, 4)
        enc, o = take_string(body, o)
        channels[cid] = (topic, enc, sid)


def _summary_record(out: Summary, op: int, body: bytes) -> None:
    if op in (_OP_SCHEMA, _OP_CHANNEL):
        take_definition(out.schemas, out.channels, op, body)
    elif op == _OP_CHUNK_INDEX:
        start, end, offset, length = struct.unpack_from("<QQQQ", body, 0)
        offsets, _ = _take_map(body, 32, "<HQ")
        out.chunk_indexes.append(ChunkIndex(start, end, offset, length, offsets))
    elif op == _OP_STATISTICS:
        counts, _ = _take_map(body, 8 + 2 + 4 * 4 + 16, "<HQ")
        out.channel_message_counts = counts


def read_summary(src: FileBytes) -> tuple[Summary | None, bool | None]:
    """The summary section (None: the file has none, or it is damaged or larger than ``MAX_CHUNK_BYTES``) and
    whether it matches the footer's CRC (None: no CRC, or no footer)."""
    footer = src.size - len(MAGIC) - _FOOTER
    if footer < len(MAGIC):
        return None, None
    tail = src.read_at(footer, _FOOTER + len(MAGIC))
    if tail[_FOOTER:] != MAGIC or tail[0] != _OP_FOOTER:
        return None, None
    summary_start, _offsets, crc = struct.unpack_from("<QQI", tail, 9)
    if summary_start == 0:
        return None, None
    if not len(MAGIC) <= summary_start <= footer or footer - summary_start > MAX_CHUNK_BYTES:
        return None, False if crc else None
    crc_ok = None
    if crc:
        running = 0
        for off in range(summary_start, footer, _CRC_PIECE):
            running = zlib.crc32(src.read_at(off, min(_CRC_PIECE, footer - off)), running)
        crc_ok = zlib.crc32(tail[:25], running) == crc
        if not crc_ok:
            return None, False
    buf = src.read_at(summary_start, footer - summary_start)
    out, pos = Summary(), 0
    try:
        while pos < len(buf):
            op, length = _RECORD.unpack_from(buf, pos)
            if pos + 9 + length > len(buf):
                raise ValueError("summary record runs past the summary")
            _summary_record(out, op, buf[pos + 9 : pos + 9 + length])
            pos += 9 + length
    except (ValueError, struct.error):
        return None, crc_ok
    return out, crc_ok


def decompress_chunk(kind: str, data: bytes | memoryview, size: int, partial: bool = False) -> bytes:
    """A chunk's records, at most its declared ``size``; ``partial``: the data is cut off, give what decompresses."""
    if kind == "":
        return bytes(data)
    if kind == "zstd":
        if partial:
            return _partial_zstd(data, size)
        declared = zstandard.frame_content_size(data)
        if declared > size:
            raise ValueError(f"chunk claims {declared} bytes uncompressed, more than its {size}")
        out = zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    elif kind == "lz4":
        d = lz4.frame.LZ4FrameDecompressor()
        out = bytes(d.decompress(data, max_length=size + 1))
        if not partial and not d.eof:
            raise ValueError("chunk data ends before its compressed stream does")
    else:
        raise ValueError(f"unknown MCAP chunk compression {kind!r}")
    if len(out) > size:
        raise ValueError(f"chunk decompresses to more than the {size} bytes it declares")
    return out


def _partial_zstd(data: bytes | memoryview, size: int) -> bytes:
    """What decompresses of a cut-off zstd chunk, at most ``size`` bytes (fed in small pieces: one piece of a
    hostile stream cannot expand beyond a few tens of MB)."""
    d = zstandard.ZstdDecompressor().decompressobj()
    out = bytearray()
    for i in range(0, len(data), 1024):
        out += d.decompress(bytes(data[i : i + 1024]))
        if len(out) > size:
            break
    return bytes(out[:size])


def _chunk_messages(src: FileBytes, path: Path, index: ChunkIndex, channels: set[int]) -> list[tuple[int, int, bytes]]:
    if index.chunk_start_offset + index.chunk_length > src.size:
        raise ValueError(f"the chunk index points past the end of the file ({index.chunk_start_offset})")
    check_size(path, f"a chunk at byte {index.chunk_start_offset}", index.chunk_length, MAX_CHUNK_BYTES)
    buf = src.read_at(index.chunk_start_offset, index.chunk_length)
    op, _length = _RECORD.unpack_from(buf, 0)
    if op != _OP_CHUNK:
        raise ValueError(f"no chunk record at offset {index.chunk_start_offset}")
    _start, _end, size, crc = struct.unpack_from("<QQQI", buf, 9)
    if size > MAX_CHUNK_BYTES:  # the file does not hold it: a damaged size field
        raise ValueError(f"chunk at byte {index.chunk_start_offset} claims {size} bytes uncompressed")
    kind, off = take_string(buf, 37)
    (rlen,) = struct.unpack_from("<Q", buf, off)
    records = decompress_chunk(kind, memoryview(buf)[off + 8 : off + 8 + rlen], size)
    if crc != 0 and zlib.crc32(records) != crc:
        raise ChunkCrcError("chunk CRC mismatch")
    out = []
    pos, end = 0, len(records)
    unpack_record, unpack_msg = _RECORD.unpack_from, _MSG_HEAD.unpack_from
    while pos + 9 <= end:
        op, length = unpack_record(records, pos)
        body = pos + 9
        if op == _OP_MESSAGE:
            channel, _seq, log_time, _pub = unpack_msg(records, body)
            if channel in channels:
                out.append((log_time, channel, records[body + 22 : body + length]))
        pos = body + length
    out.sort(key=lambda m: m[0])
    return out


def iter_chunk_messages(
    src: FileBytes, path: Path, summary: Summary, channels: set[int],
    on_damaged: Callable[[Exception], None] | None = None,
) -> Iterator[tuple[int, int, bytes]]:
    """``(log_time, channel id, data)`` in log-time order for the chunks that hold any of ``channels``.

    Chunks whose time ranges overlap are merged; others are yielded one after the other.  A chunk that is
    damaged (CRC mismatch, cannot be decompressed or split) is skipped and passed to ``on_damaged``; without
    ``on_damaged`` the error is raised.  A chunk larger than ``MAX_CHUNK_BYTES`` is a :class:`LogError`.
    """
    indexes = sorted(
        (ci for ci in summary.chunk_indexes if any(c in ci.message_index_offsets for c in channels)),
        key=lambda ci: (ci.message_start_time, ci.chunk_start_offset),
    )
    group: list[list[tuple[int, int, bytes]]] = []
    group_end = -1
    for ci in indexes:
        if group and ci.message_start_time >= group_end:
            yield from (heapq.merge(*group, key=lambda m: m[0]) if len(group) > 1 else group[0])
            group = []
        try:
            group.append(_chunk_messages(src, path, ci, channels))
        except (ValueError, struct.error, zstandard.ZstdError, RuntimeError, OverflowError, MemoryError) as err:
            if on_damaged is None:
                raise
            on_damaged(err)
            continue
        group_end = max(group_end, ci.message_end_time)
    if group:
        yield from (heapq.merge(*group, key=lambda m: m[0]) if len(group) > 1 else group[0])
