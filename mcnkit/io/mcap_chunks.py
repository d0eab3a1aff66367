"""A fast path through indexed MCAP files: read the chunks the summary lists, decompress each once, and
split its records with ``struct`` — about 3× faster than the ``mcap`` package's ordered iterator, whose
per-message heap dominates on logs of small messages.

Record framing (MCAP spec): ``opcode u8, length u64, body``.  A Chunk body is ``start u64, end u64,
uncompressed_size u64, crc u32, compression (u32 len + str), records (u64 len + bytes)``; a Message body is
``channel u16, sequence u32, log_time u64, publish_time u64, data``.

Checksums: a chunk's ``uncompressed_crc`` (CRC32 of its decompressed records, 0 = not written) is checked on
every chunk read; a chunk that fails it (or fails to decompress) is skipped and counted, the others are read.
The footer's ``summary_crc`` covers the summary section (:func:`summary_crc_ok`), and a record-by-record read
checks the ``DataEnd`` record's CRC of the whole data section when the writer computed one.
"""

from __future__ import annotations

import heapq
import struct
import zlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from typing import Any, BinaryIO

import lz4.frame
import zstandard

__all__ = ["ChunkCrcError", "McapRecords", "iter_chunk_messages", "read_mcap_records", "summary_crc_ok"]

_OP_MESSAGE, _OP_CHUNK, _OP_FOOTER, _OP_DATA_END = 0x05, 0x06, 0x02, 0x0F
_MAGIC = b"\x89MCAP0\r\n"
_MAX_CHUNK_BYTES = 1 << 31  # a chunk claiming more is damaged (writers chunk at about 1 MB)
_RECORD = struct.Struct("<BQ")
_MSG_HEAD = struct.Struct("<HIQQ")


class ChunkCrcError(ValueError):
    """A chunk whose records do not match its CRC."""


def _check_crc(records: bytes, crc: int) -> None:
    if crc != 0 and zlib.crc32(records) != crc:
        raise ChunkCrcError("chunk CRC mismatch")


def summary_crc_ok(stream: BinaryIO) -> bool | None:
    """Whether the summary section of an MCAP file matches the footer's CRC (None: no CRC, or no footer).

    Reads only the footer and the summary section; leaves the stream at its start."""
    stream.seek(0, 2)
    size = stream.tell()
    footer = size - len(_MAGIC) - 29  # opcode u8, length u64, summary_start u64, summary_offset_start u64, crc u32
    if footer < len(_MAGIC):
        stream.seek(0)
        return None
    stream.seek(footer)
    tail = stream.read()
    stream.seek(0)
    if tail[29:] != _MAGIC or tail[0] != _OP_FOOTER:
        return None
    summary_start, _offsets, crc = struct.unpack_from("<QQI", tail, 9)
    if crc == 0 or summary_start == 0:
        return None
    if not len(_MAGIC) <= summary_start <= footer:
        return False
    stream.seek(summary_start)
    summary = stream.read(footer - summary_start)
    stream.seek(0)
    return zlib.crc32(tail[:25], zlib.crc32(summary)) == crc


def _decompress(kind: str, data: bytes, size: int) -> bytes:
    if kind == "":
        return data
    if kind == "zstd":
        declared = zstandard.frame_content_size(data)
        if declared > min(size, _MAX_CHUNK_BYTES) or (declared < 0 and size > _MAX_CHUNK_BYTES):
            raise ValueError(f"chunk claims {max(declared, size)} bytes uncompressed")
        return zstandard.ZstdDecompressor().decompress(data, max_output_size=size)
    if kind == "lz4":
        return bytes(lz4.frame.decompress(data))
    raise ValueError(f"unknown MCAP chunk compression {kind!r}")


def _chunk_messages(stream: BinaryIO, index: Any, channels: set[int]) -> list[tuple[int, int, bytes]]:
    stream.seek(index.chunk_start_offset)
    buf = stream.read(index.chunk_length)
    op, _length = _RECORD.unpack_from(buf, 0)
    if op != _OP_CHUNK:
        raise ValueError(f"no chunk record at offset {index.chunk_start_offset}")
    off = 9
    _start, _end, size, crc = struct.unpack_from("<QQQI", buf, off)
    off += 28
    (clen,) = struct.unpack_from("<I", buf, off)
    kind = bytes(buf[off + 4 : off + 4 + clen]).decode()
    off += 4 + clen
    (rlen,) = struct.unpack_from("<Q", buf, off)
    off += 8
    records = _decompress(kind, buf[off : off + rlen], size)
    _check_crc(records, crc)
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
    stream: BinaryIO, summary: Any, channels: set[int], on_damaged: Callable[[Exception], None] | None = None
) -> Iterator[tuple[int, int, bytes]]:
    """``(log_time, channel id, data)`` in log-time order for the chunks that hold any of ``channels``.

    Chunks whose time ranges overlap are merged; others are yielded one after the other.  A chunk that is
    damaged (CRC mismatch, cannot be decompressed or split) is skipped and passed to ``on_damaged``; without
    ``on_damaged`` the error is raised.
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
            group.append(_chunk_messages(stream, ci, channels))
        except (ValueError, struct.error, zstandard.ZstdError, RuntimeError, OverflowError, MemoryError) as err:
            if on_damaged is None:
                raise
            on_damaged(err)
            continue
        group_end = max(group_end, ci.message_end_time)
    if group:
        yield from (heapq.merge(*group, key=lambda m: m[0]) if len(group) > 1 else group[0])


@dataclass
class McapRecords:
    """What a record-by-record pass over an MCAP file found, and where (and why) it stopped early."""

    schemas: dict[int, tuple[str, str, bytes]] = field(default_factory=dict)  # id -> (name, encoding, data)
    channels: dict[int, tuple[str, str, int]] = field(default_factory=dict)  # id -> (topic, msg encoding, schema)
    messages: list[tuple[int, int, bytes]] = field(default_factory=list)  # (log_time, channel, data)
    stopped_at: int | None = None
    stop_reason: str = ""
    chunks: int = 0  # chunk records met (0: an unchunked file, whose only checksum is the data section's)
    damaged_chunks: int = 0  # whole chunks skipped: CRC mismatch or undecodable
    data_crc_ok: bool | None = None  # the DataEnd record's CRC of the data section (None: absent or not reached)


def _str(buf: bytes, off: int) -> tuple[str, int]:
    (n,) = struct.unpack_from("<I", buf, off)
    if off + 4 + n > len(buf):
        raise ValueError("string runs past the record")
    return bytes(buf[off + 4 : off + 4 + n]).decode("utf-8", "replace"), off + 4 + n


def _partial_decompress(kind: str, data: bytes) -> bytes:
    """As much of a (possibly cut-off) compressed chunk as decompresses."""
    if kind == "zstd":
        return zstandard.ZstdDecompressor().decompressobj().decompress(data)
    if kind == "lz4":
        out = lz4.frame.LZ4FrameDecompressor()
        return bytes(out.decompress(data))
    return data


def _take_records(buf: bytes, out: McapRecords, inside_chunk: bool) -> tuple[int | None, str]:
    pos = 0 if inside_chunk else 8
    while pos < len(buf):
        try:
            op, length = _RECORD.unpack_from(buf, pos)
            body, end = pos + 9, pos + 9 + length
            cut = end > len(buf)
            if cut and not (op == _OP_CHUNK and not inside_chunk):
                raise ValueError(f"record (opcode {op:#x}) is cut off")
            if op == 0x03:
                (sid,) = struct.unpack_from("<H", buf, body)
                name, o = _str(buf, body + 2)
                enc, o = _str(buf, o)
                (n,) = struct.unpack_from("<I", buf, o)
                out.schemas[sid] = (name, enc, bytes(buf[o + 4 : o + 4 + n]))
            elif op == 0x04:
                cid, sid = struct.unpack_from("<HH", buf, body)
                topic, o = _str(buf, body + 4)
                enc, o = _str(buf, o)
                out.channels[cid] = (topic, enc, sid)
            elif op == _OP_MESSAGE:
                channel, _seq, log_time, _pub = _MSG_HEAD.unpack_from(buf, body)
                out.messages.append((log_time, channel, bytes(buf[body + 22 : end])))
            elif op == _OP_CHUNK:
                out.chunks += 1
                size, crc = struct.unpack_from("<QI", buf, body + 16)
                kind, o = _str(buf, body + 28)
                (rlen,) = struct.unpack_from("<Q", buf, o)
                data = buf[o + 8 : min(o + 8 + rlen, len(buf))]
                if cut:
                    inner = _partial_decompress(kind, data)
                else:
                    try:
                        inner = _decompress(kind, data, size)
                        _check_crc(inner, crc)
                    except (ValueError, zstandard.ZstdError, RuntimeError) as err:
                        if o + 8 + rlen > end:
                            raise
                        out.damaged_chunks += 1  # its framing holds: skip just this chunk
                        del err
                        pos = end
                        continue
                stop, why = _take_records(inner, out, inside_chunk=True)
                if cut or stop is not None:
                    raise ValueError(why or "chunk is cut off")
            elif op == _OP_DATA_END and not inside_chunk:
                (crc,) = struct.unpack_from("<I", buf, body)
                out.data_crc_ok = None if crc == 0 else zlib.crc32(buf[:pos]) == crc
            elif op == _OP_FOOTER and not inside_chunk:  # footer: the data section is over
                return None, ""
        except (struct.error, ValueError, zstandard.ZstdError, RuntimeError) as err:
            return pos, str(err)
        pos = end
    return None, ""


def read_mcap_records(data: bytes) -> McapRecords:
    """Reads an MCAP file record by record, keeping every whole message before a cut-off or damage."""
    out = McapRecords()
    if not data.startswith(b"\x89MCAP0\r\n"):
        out.stopped_at, out.stop_reason = 0, "no MCAP magic"
        return out
    out.stopped_at, out.stop_reason = _take_records(data, out, inside_chunk=False)
    return out
