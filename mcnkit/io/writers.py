"""``write_log``: frames (plus optional ground truth) to a ROS1 bag, a ROS2 bag folder or an MCAP file.

Messages: ``sensor_msgs/LaserScan`` (frame ``laser``, ranges as read: a "no return" of any kind stays one),
``nav_msgs/Odometry`` (``odom`` → ``base_link``) and the same odometry as ``/tf`` (neither in a log without
odometry), the scanner mount as ``/tf_static``, ground-truth ``nav_msgs/Odometry`` in ``map``, and a
``nav_msgs/OccupancyGrid`` ground-truth map.  Record time = header stamp, so a log read back yields the same
frames: float32 ranges bit-identical, stamps identical to the nanosecond.  Frames are written as they come, so a
reader's ``frames()`` converts a log of any length in the memory of one chunk.

Writing goes to ``<path>.partial`` and is renamed at the end, so an interrupted write never leaves a file that
looks complete.
"""

from __future__ import annotations

import itertools
import shutil
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import zstandard
from mcap.reader import make_reader as make_mcap_reader
from mcap.writer import CompressionType
from mcap.writer import Writer as McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.rosbag2.enums import CompressionFormat, CompressionMode
from rosbags.typesys.store import Typestore
from ruamel.yaml import YAML

from mcnkit.geometry import yaw_to_quaternion
from mcnkit.io.content import BAG_COMPRESSIONS, FORMATS, LogContent
from mcnkit.io.decode import MessageDecoder
from mcnkit.io.errors import LogError
from mcnkit.types import Frame, Pose2D

__all__ = ["infer_format", "write_log"]

_TYPES = {
    "scan": "sensor_msgs/msg/LaserScan",
    "odom": "nav_msgs/msg/Odometry",
    "tf": "tf2_msgs/msg/TFMessage",
    "map": "nav_msgs/msg/OccupancyGrid",
}
ODOM_FRAME, BASE_FRAME, LASER_FRAME, MAP_FRAME = "odom", "base_link", "laser", "map"


def infer_format(path: Path) -> str:
    """``.bag`` → ros1, ``.mcap`` → mcap, anything else (a folder) → ros2-mcap."""
    return {".bag": "ros1", ".mcap": "mcap"}.get(path.suffix, "ros2-mcap")


class _Msgs:
    """Builds rosbags message objects for one typestore (ROS1 headers carry ``seq``)."""

    def __init__(self, ts: Typestore, ros1: bool) -> None:
        self.ts, self.ros1 = ts, ros1
        self.T = ts.types

    def header(self, stamp_ns: int, frame: str) -> Any:
        stamp = self.T["builtin_interfaces/msg/Time"](sec=stamp_ns // 1_000_000_000, nanosec=stamp_ns % 1_000_000_000)
        if self.ros1:
            return self.T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)
        return self.T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def pose(self, p: Pose2D) -> Any:
        q = yaw_to_quaternion(p.yaw_rad)
        return self.T["geometry_msgs/msg/Pose"](
            position=self.T["geometry_msgs/msg/Point"](x=p.x_m, y=p.y_m, z=0.0),
            orientation=self.T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]),
        )

    def scan(self, f: Frame) -> Any:
        s = f.scan.spec
        return self.T[_TYPES["scan"]](
            header=self.header(f.stamp_ns, LASER_FRAME), angle_min=s.angle_min_rad, angle_max=s.angle_max_rad,
            angle_increment=s.angle_increment_rad, time_increment=s.time_increment_s,
            scan_time=0.0, range_min=s.range_min_m,
            range_max=s.range_max_m, ranges=np.asarray(f.scan.ranges_m, dtype=np.float32),
            intensities=np.zeros(0, dtype=np.float32),
        )

    def odometry(self, stamp_ns: int, p: Pose2D, frame: str) -> Any:
        T = self.T
        cov = np.zeros(36, dtype=np.float64)
        zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
        return T[_TYPES["odom"]](
            header=self.header(stamp_ns, frame), child_frame_id=BASE_FRAME,
            pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=self.pose(p), covariance=cov),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=cov.copy()),
        )

    def tf(self, stamp_ns: int, parent: str, child: str, p: Pose2D) -> Any:
        T = self.T
        q = yaw_to_quaternion(p.yaw_rad)
        tr = T["geometry_msgs/msg/TransformStamped"](
            header=self.header(stamp_ns, parent), child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=p.x_m, y=p.y_m, z=0.0),
                rotation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3])),
        )
        return T[_TYPES["tf"]](transforms=[tr])

    def occupancy_grid(self, content: LogContent) -> Any:
        m = content.ground_truth_map
        assert m is not None
        T = self.T
        h, w = m.data.shape
        info = T["nav_msgs/msg/MapMetaData"](
            map_load_time=T["builtin_interfaces/msg/Time"](sec=0, nanosec=0), resolution=m.resolution_m,
            width=w, height=h, origin=self.pose(Pose2D(m.origin_x_m, m.origin_y_m, 0.0)))
        return T[_TYPES["map"]](header=self.header(m.stamp_ns, MAP_FRAME), info=info,
                                data=np.ascontiguousarray(m.data, dtype=np.int8).ravel())


def _messages(content: LogContent, b: _Msgs) -> Iterator[tuple[str, str, int, Any]]:
    """(topic, kind, record time, message) in time order (``content.frames`` starts with a frame: see
    :func:`write_log`)."""
    frames = iter(content.frames)
    head = next(frames)
    first = head.stamp_ns
    if content.mount_transform:
        yield "/tf_static", "tf", first, b.tf(first, BASE_FRAME, LASER_FRAME, head.scan.spec.base_to_laser)
    if content.ground_truth_map is not None:
        yield content.map_topic, "map", content.ground_truth_map.stamp_ns, b.occupancy_grid(content)
    gt = content.ground_truth
    gi = 0
    for f in itertools.chain([head], frames):
        while gt is not None and gi < len(gt) and gt.stamps_ns[gi] <= f.stamp_ns:
            t = int(gt.stamps_ns[gi])
            yield content.ground_truth_topic, "odom", t, b.odometry(t, Pose2D.from_array(gt.poses[gi]), MAP_FRAME)
            gi += 1
        yield content.scan_topic, "scan", f.stamp_ns, b.scan(f)
        if not content.odometry:
            continue
        if content.odom_topic:
            yield content.odom_topic, "odom", f.stamp_ns, b.odometry(f.stamp_ns, f.odom, ODOM_FRAME)
        yield "/tf", "tf", f.stamp_ns, b.tf(f.stamp_ns, ODOM_FRAME, BASE_FRAME, f.odom)
    while gt is not None and gi < len(gt):
        t = int(gt.stamps_ns[gi])
        yield content.ground_truth_topic, "odom", t, b.odometry(t, Pose2D.from_array(gt.poses[gi]), MAP_FRAME)
        gi += 1


def _topics(content: LogContent) -> dict[str, str]:
    topics = {"/tf_static": "tf"} if content.mount_transform else {}
    topics[content.scan_topic] = "scan"
    if content.odometry:
        topics["/tf"] = "tf"
        if content.odom_topic:
            topics[content.odom_topic] = "odom"
    if content.ground_truth is not None:
        topics[content.ground_truth_topic] = "odom"
    if content.ground_truth_map is not None:
        topics[content.map_topic] = "map"
    return topics


def _write_ros1(path: Path, content: LogContent, ts: Typestore) -> None:
    b = _Msgs(ts, ros1=True)
    writer = Ros1Writer(path)
    writer.set_compression(Ros1Writer.CompressionFormat.LZ4)
    with writer:
        conns = {t: writer.add_connection(t, _TYPES[k], typestore=ts) for t, k in _topics(content).items()}
        for topic, kind, stamp, msg in _messages(content, b):
            writer.write(conns[topic], stamp, ts.serialize_ros1(msg, _TYPES[kind]))


def _write_ros2(path: Path, content: LogContent, ts: Typestore, storage: StoragePlugin, per_message: bool) -> None:
    b = _Msgs(ts, ros1=False)
    writer = Ros2Writer(path, version=9, storage_plugin=storage)
    if per_message:
        writer.set_compression(CompressionMode.MESSAGE, CompressionFormat.ZSTD)
    with writer:
        conns = {t: writer.add_connection(t, _TYPES[k], typestore=ts) for t, k in _topics(content).items()}
        for topic, kind, stamp, msg in _messages(content, b):
            writer.write(conns[topic], stamp, ts.serialize_cdr(msg, _TYPES[kind]))


def _add_mcap_crcs(path: Path, chunk_bytes: int) -> None:
    """Rewrites a rosbag2 folder's MCAP file (rosbags stores CRC 0) with chunk and data-section CRCs, as
    ``ros2 bag record`` does, so that a reader can tell a damaged chunk: records copied unchanged, in order."""
    tmp = path.with_name(path.name + ".crc")
    with open(path, "rb") as src, open(tmp, "wb") as dst:
        reader = make_mcap_reader(src)
        header, summary = reader.get_header(), reader.get_summary()
        assert summary is not None  # rosbags writes a summary
        w = McapWriter(dst, chunk_size=chunk_bytes, compression=CompressionType.ZSTD, enable_crcs=True,
                       enable_data_crcs=True)
        w.start(profile=header.profile, library=header.library)
        schemas = {sid: w.register_schema(s.name, s.encoding, s.data) for sid, s in summary.schemas.items()}
        channels = {cid: w.register_channel(c.topic, c.message_encoding, schemas.get(c.schema_id, 0), c.metadata)
                    for cid, c in summary.channels.items()}
        for _schema, channel, message in reader.iter_messages(log_time_order=False):
            w.add_message(channels[channel.id], log_time=message.log_time, publish_time=message.publish_time,
                          data=message.data, sequence=message.sequence)
        for record in reader.iter_metadata():
            w.add_metadata(record.name, record.metadata)
        w.finish()
    tmp.replace(path)


def _write_mcap(path: Path, content: LogContent, ts: Typestore, ros1: bool, chunk_bytes: int) -> None:
    b = _Msgs(ts, ros1=ros1)
    serialize: Callable[[Any, str], Any] = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    with open(path, "wb") as f:
        w = McapWriter(f, chunk_size=chunk_bytes, compression=CompressionType.ZSTD)
        w.start(profile="ros1" if ros1 else "ros2", library="mcnkit")
        channels = {}
        for topic, kind in _topics(content).items():
            name = _TYPES[kind].replace("/msg/", "/") if ros1 else _TYPES[kind]
            msgdef = ts.generate_msgdef(_TYPES[kind], ros_version=1 if ros1 else 2)[0]
            sid = w.register_schema(name, "ros1msg" if ros1 else "ros2msg", msgdef.encode())
            channels[topic] = w.register_channel(topic, "ros1" if ros1 else "cdr", sid)
        for seq, (topic, kind, stamp, msg) in enumerate(_messages(content, b)):
            w.add_message(channels[topic], log_time=stamp, publish_time=stamp,
                          data=bytes(serialize(msg, _TYPES[kind])), sequence=seq)
        w.finish()


def _compress_bag_files(folder: Path) -> None:
    """Compresses every file of a rosbag2 folder as a whole (``x_0.db3`` -> ``x_0.db3.zstd``) and says so in its
    metadata, as ``ros2 bag record --compression-mode file --compression-format zstd`` does."""
    meta = folder / "metadata.yaml"
    cctx = zstandard.ZstdCompressor(level=3)
    for f in sorted(folder.iterdir()):
        if f != meta:
            with open(f, "rb") as src, open(f.with_name(f.name + ".zstd"), "wb") as dst:
                cctx.copy_stream(src, dst)
            f.unlink()
    _set_compression(meta, "FILE", rename=lambda name: name + ".zstd")


def _set_compression(meta: Path, mode: str, rename: Callable[[str], str] = lambda name: name) -> None:
    """Writes ``mode`` (``FILE``/``MESSAGE``, upper case as rosbag2 writes it) and zstd into a rosbag2
    ``metadata.yaml``, renaming its files' paths by ``rename``."""
    yaml = YAML()
    doc = yaml.load(meta.read_text())
    info = doc["rosbag2_bagfile_information"]
    info["relative_file_paths"] = [rename(p) for p in info["relative_file_paths"]]
    for entry in info.get("files", []):
        entry["path"] = rename(entry["path"])
    info["compression_format"], info["compression_mode"] = "zstd", mode
    with open(meta, "w") as f:
        yaml.dump(doc, f)


def write_log(path: str | Path, content: LogContent, fmt: str | None = None, *, overwrite: bool = False,
              mcap_chunk_bytes: int = 1 << 20, compression: str | None = None) -> Path:
    """Writes ``content`` to ``path`` in ``fmt`` (one of :data:`FORMATS` or ``mcap-ros1``; default by suffix).

    ``mcap_chunk_bytes``: the (uncompressed) chunk size of a plain MCAP file (1 MiB, like ``ros2 bag record``);
    each chunk carries its own CRC, so a damaged file loses only the chunks that were hit.  ``compression``: a
    rosbag2 folder's own zstd compression, ``"file"`` (each bag file as a whole) or ``"message"`` (each message),
    as ``ros2 bag record --compression-mode`` writes them; None: none.

    Raises:
        LogError: unknown format or compression, nothing to write, or ``path`` exists and ``overwrite`` is False.
    """
    path = Path(path)
    fmt = fmt or infer_format(path)
    if fmt not in (*FORMATS, "mcap-ros1"):
        raise LogError(path, f"unknown output format {fmt!r} (choose from {', '.join(FORMATS)})")
    if compression not in (None, *BAG_COMPRESSIONS) or (compression and fmt not in ("ros2-sqlite3", "ros2-mcap")):
        raise LogError(path, f"compression {compression!r}: rosbag2 folders (ros2-sqlite3, ros2-mcap) take "
                             f"{' or '.join(BAG_COMPRESSIONS)}")
    if path.exists() and not overwrite:
        raise LogError(path, "exists already (pass overwrite=True or --overwrite)")
    frames = iter(content.frames)
    head = next(frames, None)
    if head is None:
        raise LogError(path, "nothing to write: no frames")
    content = replace(content, frames=itertools.chain([head], frames))
    partial = path.with_name(path.name + ".partial")
    if partial.exists():
        shutil.rmtree(partial) if partial.is_dir() else partial.unlink()
    decoder = MessageDecoder()
    try:
        if fmt == "ros1":
            _write_ros1(partial, content, decoder.typestore("ros1"))
        elif fmt in ("ros2-sqlite3", "ros2-mcap"):
            plugin = StoragePlugin.SQLITE3 if fmt == "ros2-sqlite3" else StoragePlugin.MCAP
            _write_ros2(partial, content, decoder.typestore("cdr"), plugin, per_message=compression == "message")
            if plugin == StoragePlugin.MCAP:
                for f in partial.glob("*.mcap"):
                    _add_mcap_crcs(f, mcap_chunk_bytes)
            _rename_bag_files(partial, path.name)
            if compression == "file":
                _compress_bag_files(partial)
            elif compression == "message":
                _set_compression(partial / "metadata.yaml", "MESSAGE")
        else:
            _write_mcap(partial, content, decoder.typestore("ros1" if fmt == "mcap-ros1" else "cdr"),
                        ros1=fmt == "mcap-ros1", chunk_bytes=mcap_chunk_bytes)
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True) if partial.is_dir() else partial.unlink(missing_ok=True)
        raise
    if path.exists() and (path.is_dir() or partial.is_dir()):  # a folder cannot be replaced by a rename
        shutil.rmtree(path) if path.is_dir() else path.unlink()
    partial.replace(path)  # a file: replaced atomically, only now that the new one is complete
    return path


def _rename_bag_files(folder: Path, name: str) -> None:
    """rosbag2 names its files after the folder; drop the ``.partial`` from them before the final rename."""
    meta = folder / "metadata.yaml"
    text = meta.read_text()
    for f in folder.iterdir():
        if f.name.startswith(folder.name) and f != meta:
            new = name + f.name[len(folder.name):]
            f.rename(folder / new)
            text = text.replace(f.name, new)
    meta.write_text(text)
