"""An MCAP file without a usable summary (truncated, unindexed, unchunked, or compressed as a whole) read record by
record, keeping every whole message before a cut-off or damage.

The walk (:func:`walk_mcap_records`) holds one record, or one chunk, at a time: it collects the schemas and
channels, indexes every message (:class:`~mcnkit.io.msgindex.MessageIndex`) without keeping it, skips a chunk whose
records fail their CRC (counted), and checks the ``DataEnd`` record's CRC of the whole data section as it goes.
:func:`read_walked` then gives the messages of some channels in log-time order.
"""

from __future__ import annotations

import struct
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import zstandard

from mcnkit.io.limits import MAX_CHUNK_BYTES, MAX_DEFINITION_BYTES, check_size
from mcnkit.io.mcap_chunks import MAGIC, ChunkCrcError, decompress_chunk, take_definition, take_string
from mcnkit.io.msgindex import Block, MessageIndex, read_indexed
from mcnkit.io.streams import ByteSource

__all__ = ["McapWalk", "read_walked", "walk_mcap_records"]

_OP_FOOTER, _OP_SCHEMA, _OP_CHANNEL, _OP_MESSAGE, _OP_CHUNK, _OP_DATA_END = 0x02, 0x03, 0x04, 0x05, 0x06, 0x0F
_RECORD = struct.Struct("<BQ")
_MSG_HEAD = struct.Struct("<HIQQ")
_PIECE = 1 << 20
_ERRORS = (struct.error, ValueError, zstandard.ZstdError, RuntimeError, OverflowError)


@dataclass
class McapWalk:
    """What a record-by-record pass over an MCAP file found, and where (and why) it stopped early."""

    schemas: dict[int, tuple[str, str, bytes]] = field(default_factory=dict)  # id -> (name, encoding, data)
    channels: dict[int, tuple[str, str, int]] = field(default_factory=dict)  # id -> (topic, msg encoding, schema)
    index: MessageIndex = field(default_factory=MessageIndex)
    blocks: list[Block] = field(default_factory=list)
    stopped_at: int | None = None
    stop_reason: str = ""
    chunks: int = 0  # chunk records met (0: an unchunked file, whose only checksum is the data section's)
    damaged_chunks: int = 0  # whole chunks skipped: CRC mismatch or undecodable
    data_crc_ok: bool | None = None  # the DataEnd record's CRC of the data section (None: absent or not reached)


class _Crc:
    """CRC32 of the file's bytes in order, fed as the walk passes them."""

    def __init__(self) -> None:
        self.value = 0

    def feed(self, data: bytes | memoryview) -> None:
        self.value = zlib.crc32(data, self.value)


def _walk_records(buf: bytes, out: McapWalk, base: int, block: int) -> str | None:
    """Takes the records inside one decompressed chunk; returns why it stopped early (None: it did not).
    ``base``: where ``buf`` lies in the file (an uncompressed chunk), ``block``: its block number (a compressed one)."""
    times, chans, offsets, lengths = [], [], [], []
    pos, why = 0, None
    try:
        while pos < len(buf):
            op, length = _RECORD.unpack_from(buf, pos)
            body, end = pos + 9, pos + 9 + length
            if end > len(buf):
                raise ValueError(f"record (opcode {op:#x}) is cut off")
            if op == _OP_MESSAGE:
                channel, _seq, log_time, _pub = _MSG_HEAD.unpack_from(buf, body)
                times.append(log_time)
                chans.append(channel)
                offsets.append(base + body + 22)
                lengths.append(max(0, length - 22))
            elif op in (_OP_SCHEMA, _OP_CHANNEL):
                take_definition(out.schemas, out.channels, op, buf[body:end])
            elif op == _OP_CHUNK:
                raise ValueError("a chunk inside a chunk")
            pos = end
    except _ERRORS as err:
        why = str(err)
    out.index.add(times, chans, block, offsets, lengths)
    return why


def _chunk(src: ByteSource, path: Path, out: McapWalk, pos: int, body: bytes, cut: bool, crc: _Crc) -> None:
    """Takes one chunk record (``body`` as far as the file holds it); raises ValueError when the walk must stop."""
    out.chunks += 1
    size, chunk_crc = struct.unpack_from("<QI", body, 16)
    if size > MAX_CHUNK_BYTES:  # more than the file holds: a damaged size field
        if cut:
            raise ValueError(f"chunk claims {size} bytes uncompressed")
        out.damaged_chunks += 1  # its framing holds: skip just this chunk
        return
    kind, o = take_string(body, 28)
    (rlen,) = struct.unpack_from("<Q", body, o)
    start = o + 8
    stored = min(rlen, len(body) - start)
    if not cut and start + rlen > len(body):
        raise ValueError("chunk records run past the chunk record")
    data = memoryview(body)[start : start + stored]
    try:
        records = decompress_chunk(kind, data, size, partial=cut)
        if not cut and chunk_crc != 0 and zlib.crc32(records) != chunk_crc:
            raise ChunkCrcError("chunk CRC mismatch")
    except _ERRORS:
        if cut:
            raise
        out.damaged_chunks += 1  # its framing holds: skip just this chunk
        return
    if kind == "":
        why = _walk_records(records, out, pos + 9 + start, -1)
    else:
        out.blocks.append(Block(pos + 9 + start, stored, kind, size, partial=cut))
        why = _walk_records(records, out, 0, len(out.blocks) - 1)
    if cut or why is not None:
        raise ValueError(why or "chunk is cut off")


def _skip(src: ByteSource, pos: int, n: int, crc: _Crc) -> bool:
    """Reads past ``n`` bytes from ``pos`` (feeding the CRC); False when the data ends first."""
    end = pos + n
    while pos < end:
        piece = src.read_at(pos, min(_PIECE, end - pos))
        if not piece:
            return False
        crc.feed(piece)
        pos += len(piece)
    return True


def walk_mcap_records(path: Path, src: ByteSource) -> McapWalk:
    """Reads an MCAP file record by record (see the module docstring).  Raises :class:`LogError` for a record
    larger than a reader holds (``mcnkit.io.limits``)."""
    out, crc = McapWalk(), _Crc()
    head = src.read_at(0, len(MAGIC))
    if head != MAGIC:
        out.stopped_at, out.stop_reason = 0, "no MCAP magic"
        return out
    crc.feed(head)
    pos = len(MAGIC)
    while True:
        frame = src.read_at(pos, 9)
        if not frame:
            return out
        try:
            if len(frame) < 9:
                raise ValueError("record header is cut off")
            op, length = _RECORD.unpack(frame)
            if op == 0:
                raise ValueError("opcode 0x00 (not a record: damaged or zeroed data)")
            if op == _OP_FOOTER:  # the data and summary sections are over
                return out
            if op == _OP_MESSAGE:
                head = src.read_at(pos + 9, 22)
                channel, _seq, log_time, _pub = _MSG_HEAD.unpack(head) if len(head) == 22 else (0, 0, 0, 0)
                crc.feed(frame)
                if len(head) < 22 or not _skip(src, pos + 9, length, crc):
                    raise ValueError(f"record (opcode {op:#x}) is cut off")
                out.index.add([log_time], [channel], -1, [pos + 9 + 22], [max(0, length - 22)])
            elif op in (_OP_SCHEMA, _OP_CHANNEL, _OP_CHUNK, _OP_DATA_END):
                limit = MAX_CHUNK_BYTES if op == _OP_CHUNK else MAX_DEFINITION_BYTES
                body = src.read_at(pos + 9, min(length, limit + 1))
                cut = len(body) < length
                check_size(path, f"a record (opcode {op:#x}) at byte {pos}", len(body), limit)
                if op == _OP_DATA_END:
                    (data_crc,) = struct.unpack_from("<I", body, 0)
                    out.data_crc_ok = None if data_crc == 0 else crc.value == data_crc
                crc.feed(frame)
                crc.feed(body)
                if op == _OP_CHUNK:
                    _chunk(src, path, out, pos, body, cut, crc)
                elif cut:
                    raise ValueError(f"record (opcode {op:#x}) is cut off")
                elif op != _OP_DATA_END:
                    take_definition(out.schemas, out.channels, op, body)
            else:
                crc.feed(frame)
                if not _skip(src, pos + 9, length, crc):
                    raise ValueError(f"record (opcode {op:#x}) is cut off")
        except _ERRORS as err:
            out.stopped_at, out.stop_reason = pos, str(err)
            return out
        pos += 9 + length


def read_walked(path: Path, src: ByteSource, walk: McapWalk, limits: dict[int, tuple[str, int]]
                ) -> Iterator[tuple[int, int, bytes]]:
    """``(log_time, channel id, data)`` in log-time order for the channels in ``limits`` (see
    :func:`~mcnkit.io.msgindex.read_indexed`)."""

    def load(block: int) -> bytes:
        b = walk.blocks[block]
        return decompress_chunk(b.compression, src.read_at(b.offset, b.length), b.size, partial=b.partial)

    return read_indexed(path, src, walk.index, load, limits)
