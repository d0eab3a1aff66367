"""rosbag2's own compression: whole bag files (``compression_mode: FILE``) or each message (``MESSAGE``), zstd.

``ros2 bag record --compression-mode file --compression-format zstd`` compresses every file of the bag once it is
closed (``x_0.db3.zstd``, ``x_0.mcap.zstd``); ``--compression-mode message`` compresses each message's serialized
bytes on its own, inside an ordinary ``.db3``/``.mcap`` file.  Both write the mode and format into
``metadata.yaml``.

* A compressed MCAP file is read as a stream, like any whole-file-compressed MCAP
  (:class:`mcnkit.io.sources.McapSource`).
* SQLite pages through a real file, so a compressed ``.db3`` is decompressed once into a temporary folder
  (:func:`decompressed_copies`), ratio-guarded like every stream (:func:`mcnkit.io.streams.open_decompressed`), and
  removed when the log is closed.
* :class:`DecompressedSource` wraps either source: it decompresses each message of a ``MESSAGE`` bag, refusing one
  that would grow past its type's limit (:func:`mcnkit.io.limits.message_limit`) before it is held whole and
  counting undecodable ones in one warning, and removes the temporary folder when closed.

Example:
    >>> mode_and_format({"compression_mode": "FILE", "compression_format": "zstd"}, Path("bag"))
    ('file', 'zstd')
    >>> mode_and_format({"compression_mode": "", "compression_format": ""}, Path("bag"))
    (None, None)
"""

from __future__ import annotations

import io
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import Any

import zstandard

from mcnkit.io.content import BAG_COMPRESSIONS
from mcnkit.io.errors import LogError, warn_skipped
from mcnkit.io.limits import check_size, message_limit
from mcnkit.io.sources import RawMessage, RawSource
from mcnkit.io.streams import compression_of, open_decompressed

__all__ = ["DecompressedSource", "decompressed_copies", "file_compression", "mode_and_format"]

_NONE = ("", "none", "storage")  # "storage": the storage plugin compresses internally (MCAP chunks), read as usual


def mode_and_format(info: Mapping[str, Any], path: Path) -> tuple[str | None, str | None]:
    """The bag's compression mode (``"file"``/``"message"``, None when uncompressed) and format, from its
    ``rosbag2_bagfile_information``.

    Raises:
        LogError: a mode or format this reader does not know (rosbag2 writes zstd only).
    """
    mode = str(info.get("compression_mode") or "").strip().lower()
    fmt = str(info.get("compression_format") or "").strip().lower()
    if mode in _NONE:
        return None, None
    if mode not in BAG_COMPRESSIONS:
        raise LogError(path, f"unknown rosbag2 compression_mode {info.get('compression_mode')!r} in metadata.yaml "
                             f"(read: {', '.join(m.upper() for m in BAG_COMPRESSIONS)})")
    if fmt != "zstd":
        raise LogError(path, f"rosbag2 {fmt or 'unnamed'!r} compression is not supported (zstd is)")
    return mode, fmt


def file_compression(files: Iterable[Path]) -> dict[Path, str | None]:
    """Each file's whole-file compression by its magic (``"zstd"``, ``"gzip"``, ``"bz2"`` or None): a bag cut short
    leaves its last file uncompressed, whatever its metadata says."""
    kinds: dict[Path, str | None] = {}
    for f in files:
        with open(f, "rb") as stream:
            kinds[f] = compression_of(stream.read(4))
    return kinds


def decompressed_copies(files: Iterable[Path], kinds: Mapping[Path, str | None]) -> tuple[Path | None, list[Path]]:
    """The files with every compressed one decompressed into a new temporary folder (None when none was), named by
    its place in the list and its own name without the compression suffix; the caller removes the folder.  A file
    that decompresses past the ratio limit, or is damaged, raises :class:`LogError` naming it and leaves no folder
    behind."""
    folder: Path | None = None
    out: list[Path] = []
    try:
        for f in files:
            kind = kinds.get(f)
            if kind is None:
                out.append(f)
                continue
            if folder is None:
                folder = Path(tempfile.mkdtemp(prefix="mcnkit-bag-"))
            stem = f.name.rsplit(".", 1)[0] if f.name.endswith((".zstd", ".zst", ".gz", ".bz2")) else f.name
            target = folder / f"{len(out)}_{stem}"
            try:
                with open_decompressed(f, kind) as src, open(target, "wb") as dst:
                    shutil.copyfileobj(src, dst, 1 << 20)
            except zstandard.ZstdError as err:
                raise LogError(f, f"damaged {kind} data ({err})") from err
            except (EOFError, OSError) as err:
                raise LogError(f, f"damaged {kind} data ({type(err).__name__}: {err})") from err
            out.append(target)
    except BaseException:
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)
        raise
    return folder, out


class DecompressedSource(RawSource):
    """A compressed rosbag2 source as an uncompressed one: with ``per_message`` (``compression_mode: MESSAGE``) each
    message is decompressed as it is read; ``owned``, a temporary folder of decompressed files
    (:func:`decompressed_copies`), is removed on :meth:`close`."""

    def __init__(self, inner: RawSource, *, per_message: bool, owned: Path | None = None) -> None:
        self.inner = inner
        self.path = inner.path
        self.connections = inner.connections
        self.per_message = per_message
        self._owned = owned
        self.compression = ("zstd, each message (rosbag2)" if per_message
                            else "zstd, whole file (rosbag2; read from a decompressed copy)" if owned is not None
                            else inner.compression)

    def messages(self, topics: Iterable[str] | None = None) -> Iterator[RawMessage]:
        """The inner source's messages, each decompressed when ``per_message``; an undecodable one is skipped and
        counted in one warning, one that would grow past its type's limit is refused before it is held whole."""
        if not self.per_message:
            yield from self.inner.messages(topics)
            return
        dctx = zstandard.ZstdDecompressor()
        damaged = 0
        for conn, stamp, data in self.inner.messages(topics):
            limit = message_limit(conn.msgtype)
            parts: list[bytes] = []
            held = 0
            try:
                with dctx.stream_reader(io.BytesIO(data), read_across_frames=True) as reader:
                    while held <= limit and (part := reader.read(min(1 << 20, limit + 1 - held))):
                        parts.append(part)
                        held += len(part)
            except zstandard.ZstdError:
                damaged += 1
                continue
            raw = b"".join(parts)
            check_size(self.path, f"a message on {conn.topic} at {stamp} ns, decompressed,", len(raw), limit)
            yield conn, stamp, raw
        if damaged:
            warn_skipped(self.path, f"skipped {damaged} message(s) whose zstd data does not decompress (damaged)")

    def time_range_ns(self) -> tuple[int, int]:
        """The inner source's (compression does not touch the record times)."""
        return self.inner.time_range_ns()

    def close(self) -> None:
        """Closes the inner source and removes the temporary folder."""
        self.inner.close()
        if self._owned is not None:
            shutil.rmtree(self._owned, ignore_errors=True)
            self._owned = None
