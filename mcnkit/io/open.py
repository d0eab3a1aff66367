"""``open_log(path)``: recognise a robot log by its content and open it.

| what                                        | recognised by                                   | ``format``        |
|---------------------------------------------|-------------------------------------------------|-------------------|
| ROS1 bag                                    | ``#ROSBAG V2.0`` magic                          | ``ros1``          |
| ROS2 bag folder, sqlite3 / mcap storage     | ``metadata.yaml`` (or ``.db3``/``.mcap`` files) | ``ros2-sqlite3``, ``ros2-mcap`` |
| the same, rosbag2-compressed (file/message) | ``compression_mode`` in ``metadata.yaml``       | as above          |
| MCAP file, ROS2 (cdr) or ROS1 profile       | MCAP magic                                      | ``mcap-ros2``, ``mcap-ros1`` |
| zstd-, bz2- or gzip-compressed file of these | the compressor's magic, then the above         | as above          |
| CARMEN ``.clf``/``.log`` (gzip'd or not)    | a CARMEN keyword on the first line              | ``carmen``, ``carmen-corrected`` |
| DP-SLAM log                                 | ``Odometry``/``Laser`` lines                    | ``dpslam``        |
"""

from __future__ import annotations

import shutil
from pathlib import Path

from ruamel.yaml import YAML

from mcnkit.io.bag import BagLog
from mcnkit.io.bagcompression import DecompressedSource, decompressed_copies, file_compression, mode_and_format
from mcnkit.io.base import LogReader
from mcnkit.io.carmen import CarmenLog, is_carmen
from mcnkit.io.errors import LogError, as_log_error
from mcnkit.io.limits import MAX_DEFINITION_BYTES, check_regular, check_size
from mcnkit.io.sources import McapSource, RawSource, Ros1BagSource
from mcnkit.io.sqlite_source import SqliteSource
from mcnkit.io.streams import compression_of, open_decompressed

__all__ = ["ODOMETRY_CHOICES", "open_log"]

_ROS1_MAGIC = b"#ROSBAG V2.0"
_MCAP_MAGIC = b"\x89MCAP0\r\n"


ODOMETRY_CHOICES = ("use", "ignore")


def open_log(path: str | Path, *, scan_topic: str | None = None, odom: str | None = None,
             odometry: str = "use") -> LogReader:
    """Opens any supported robot log.

    Args:
        path: a file or a ROS2 bag folder.
        scan_topic: the LaserScan topic to build frames from (default: detected).
        odom: an Odometry topic, or ``tf:<odom frame>-><base frame>`` (default: detected).
        odometry: ``"use"`` the log's odometry, or ``"ignore"`` it: read the log as a lidar-only one (every
            frame's motion unknown), as a log without odometry is read.

    Raises:
        LogError: one line naming the file and the problem (missing, empty, not a regular file, not a log, damaged
            beyond use, or holding more in one piece than a reader holds: see :mod:`mcnkit.io.limits`).
    """
    if odometry not in ODOMETRY_CHOICES:
        raise ValueError(f"odometry must be one of {ODOMETRY_CHOICES}, not {odometry!r}")
    path = Path(path)
    if not path.exists():
        raise LogError(path, "no such file or folder")
    log: LogReader
    with as_log_error(path, "cannot read"):
        if path.is_dir():
            fmt, source = _open_ros2_folder(path)
            log = BagLog(path, fmt, source, scan_topic=scan_topic, odom=odom)
        else:
            check_regular(path)
            fmt, maybe_source = _open_file(path)
            log = CarmenLog(path) if maybe_source is None else BagLog(path, fmt, maybe_source, scan_topic=scan_topic,
                                                                      odom=odom)
    log.odometry = odometry
    return log


def looks_like_log(path: str | Path) -> bool:
    """Whether ``path`` carries the signature of a log :func:`open_log` reads (the table above), without reading
    further: for the hint a command gives when a log stands where it wants another kind of file."""
    path = Path(path)
    try:
        if path.is_dir():
            return (path / "metadata.yaml").is_file() or bool(_bag_files_by_name(path))
        if not path.is_file():
            return False
        _signature(path)  # raises LogError for no log
        return True
    except (OSError, ValueError, LogError):
        return False


def _signature(path: Path) -> tuple[str, str | None]:
    """What the first bytes of the file ``path`` make it: ``("ros1" | "mcap" | "carmen", its compression or None)``;
    :class:`LogError` when they make it no log."""
    with open(path, "rb") as f:
        head = f.read(16)
    if not head:
        raise LogError(path, "empty file")
    if head.startswith(_ROS1_MAGIC):
        return "ros1", None
    if head.startswith(_MCAP_MAGIC):
        return "mcap", None
    kind = compression_of(head)
    if kind is not None and (kind != "gzip" or not is_carmen(path)):
        with open_decompressed(path, kind) as stream:
            inner = stream.read(len(_MCAP_MAGIC))
        if inner.startswith(_MCAP_MAGIC):
            return "mcap", kind
        raise LogError(path, "a compressed file that holds no MCAP (compressed ROS1 bags: use bag chunk compression)")
    if is_carmen(path):
        return "carmen", None
    raise LogError(path, "not a robot log: no ROS1 bag, MCAP, CARMEN or DP-SLAM signature")


def _open_file(path: Path) -> tuple[str, RawSource | None]:
    kind, compression = _signature(path)
    if kind == "ros1":
        return "ros1", Ros1BagSource(path)
    if kind == "mcap":
        return _mcap_format(McapSource(path, [path], compression=compression))
    return "carmen", None


def _bag_files_by_name(folder: Path) -> list[Path]:
    """A rosbag2 folder's bag files by their names alone (no ``metadata.yaml``: a recording cut short): its ``.db3``
    files, else its ``.mcap`` files, whole-file compressed ones (``.zstd``) too."""
    for suffix in (".db3", ".mcap"):
        files = sorted([*folder.glob(f"*{suffix}"), *folder.glob(f"*{suffix}.zstd")])
        if files:
            return files
    return []


def _mcap_format(source: McapSource) -> tuple[str, RawSource]:
    encodings = {c.encoding for c in source.connections}
    return ("mcap-ros1" if "ros1" in encodings else "mcap-ros2"), source


def _open_ros2_folder(path: Path) -> tuple[str, RawSource]:
    meta = path / "metadata.yaml"
    mode = None
    if meta.exists():
        check_regular(meta)
        check_size(meta, "a metadata file", meta.stat().st_size, MAX_DEFINITION_BYTES)
        try:
            info = YAML(typ="safe").load(meta.read_text())["rosbag2_bagfile_information"]
            storage = str(info.get("storage_identifier", ""))
            files = [path / Path(p).name for p in info.get("relative_file_paths", [])]
        except Exception as err:
            raise LogError(meta, f"not a rosbag2 metadata file ({type(err).__name__})") from err
        if missing := [f.name for f in files if not f.exists()]:
            raise LogError(path, f"bag files listed in metadata.yaml are missing: {missing}")
        mode, _ = mode_and_format(info, path)
    else:  # no metadata (a recording cut short): the files by their names
        files = _bag_files_by_name(path)
        storage = "sqlite3" if files and ".db3" in files[0].name else "mcap"
    if not files:
        raise LogError(path, "a folder that is not a ROS2 bag (no metadata.yaml, no .db3 or .mcap files)")
    if storage not in ("sqlite3", "mcap"):
        raise LogError(path, f"unsupported rosbag2 storage {storage!r}")
    for f in files:
        check_regular(f)
    kinds = file_compression(files)
    owned = None
    if storage == "sqlite3":
        owned, plain = decompressed_copies(files, kinds)
        try:
            source: RawSource = SqliteSource(path, plain, shown=files)
        except BaseException:
            if owned is not None:
                shutil.rmtree(owned, ignore_errors=True)
            raise
    else:
        source = McapSource(path, files, compression={str(f): k for f, k in kinds.items()})
    if mode == "message" or owned is not None:
        source = DecompressedSource(source, per_message=mode == "message", owned=owned)
    return f"ros2-{storage}", source
