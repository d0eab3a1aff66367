"""Message decoding: fast numpy paths for LaserScan and Odometry, rosbags' typestores for everything else.

The hot path of reading a robot log is one LaserScan and one Odometry per scan.  Their byte layouts are fixed
(ROS1 serialization and little-endian CDR), so :func:`decode_scan` and :func:`decode_odometry` read them with
``struct``/``numpy.frombuffer`` directly — several times faster than generic deserialisers.  Any other
layout (big-endian CDR, unexpected sizes) falls back to the generic path, which handles every message type
through a rosbags typestore filled with the definitions stored in the log itself.

A ``sensor_msgs/MultiEchoLaserScan`` (the 2-D scanners of Cartographer's backpack logs, and drivers that report
several echoes per beam) is read as the LaserScan of its first echoes, as Cartographer reads it: the nearest surface
a beam met.  A beam with no echo is no return (NaN).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Any

import numpy as np
from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from mcnkit.geometry import quaternion_to_yaw

__all__ = ["MULTI_ECHO_TYPE", "SCAN_TYPE", "DecodedOdometry", "DecodedScan", "MessageDecoder", "normalize_msgtype"]

SCAN_TYPE = "sensor_msgs/msg/LaserScan"
MULTI_ECHO_TYPE = "sensor_msgs/msg/MultiEchoLaserScan"

_U32 = struct.Struct("<I")
_STAMP1 = struct.Struct("<III")  # ROS1 header: seq, secs, nsecs
_STAMP2 = struct.Struct("<iI")  # CDR: sec, nanosec
_SCAN_FIELDS = struct.Struct("<7f")
_POSE = struct.Struct("<7d")

_TFMESSAGE_DEF = "geometry_msgs/TransformStamped[] transforms"


def normalize_msgtype(name: str) -> str:
    """``pkg/Type`` → ``pkg/msg/Type`` (ROS1 and some MCAP schemas omit the ``msg`` part)."""
    parts = name.split("/")
    return f"{parts[0]}/msg/{parts[1]}" if len(parts) == 2 else name


@dataclass(frozen=True)
class DecodedScan:
    """The fields of a LaserScan that SLAM needs."""

    stamp_ns: int
    frame_id: str
    angle_min_rad: float
    angle_increment_rad: float
    range_min_m: float
    range_max_m: float
    ranges_m: np.ndarray  # float32 (n,)
    time_increment_s: float = 0.0


@dataclass(frozen=True)
class DecodedOdometry:
    """The planar part of a nav_msgs/Odometry."""

    stamp_ns: int
    frame_id: str
    child_frame_id: str
    x_m: float
    y_m: float
    yaw_rad: float


def _string(buf: memoryview, off: int, cdr: bool) -> tuple[str, int]:
    (n,) = _U32.unpack_from(buf, off)
    off += 4
    text = bytes(buf[off : off + n - (1 if cdr and n else 0)]).decode("utf-8", "replace")
    return text, off + n


def _align(off: int, n: int, base: int) -> int:
    return off + (-(off - base) % n)


def _is_le_cdr(buf: memoryview) -> bool:
    return len(buf) >= 4 and buf[1] in (1, 3)  # CDR_LE / PL_CDR_LE


def _header(buf: memoryview, cdr: bool) -> tuple[int, str, int]:
    if cdr:
        sec, nsec = _STAMP2.unpack_from(buf, 4)
        frame, off = _string(buf, 12, cdr=True)
    else:
        _, sec, nsec = _STAMP1.unpack_from(buf, 0)
        frame, off = _string(buf, 12, cdr=False)
    return sec * 1_000_000_000 + nsec, frame, off


def _fast_scan(raw: bytes | memoryview, cdr: bool) -> DecodedScan:
    buf = memoryview(raw)
    stamp, frame, off = _header(buf, cdr)
    if cdr:
        off = _align(off, 4, 4)
    amin, _amax, inc, tinc, _st, rmin, rmax = _SCAN_FIELDS.unpack_from(buf, off)
    off += 28
    (n,) = _U32.unpack_from(buf, off)
    off += 4
    if off + 4 * n > len(buf):
        raise ValueError("ranges run past the end of the message")
    ranges = np.frombuffer(buf, dtype="<f4", count=n, offset=off).astype(np.float32)
    return DecodedScan(stamp, frame, amin, inc, rmin, rmax, ranges, tinc)


def _fast_odometry(raw: bytes | memoryview, cdr: bool) -> DecodedOdometry:
    buf = memoryview(raw)
    stamp, frame, off = _header(buf, cdr)
    if cdr:
        off = _align(off, 4, 4)
    child, off = _string(buf, off, cdr)
    if cdr:
        off = _align(off, 8, 4)
    px, py, _pz, qx, qy, qz, qw = _POSE.unpack_from(buf, off)
    yaw = math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))  # scalar quaternion_to_yaw
    return DecodedOdometry(stamp, frame, child, px, py, yaw)


class MessageDecoder:
    """Decodes raw messages of one log: ``encoding`` is ``"ros1"`` or ``"cdr"``."""

    def __init__(self) -> None:
        self._stores: dict[str, Typestore] = {}

    def typestore(self, encoding: str) -> Typestore:
        """The typestore for ``encoding`` (created on first use)."""
        if encoding not in self._stores:
            if encoding == "ros1":
                ts = get_typestore(Stores.ROS1_NOETIC)
                ts.register(get_types_from_msg(_TFMESSAGE_DEF, "tf2_msgs/msg/TFMessage"))
                ts.register(get_types_from_msg(_TFMESSAGE_DEF, "tf/msg/tfMessage"))
            else:
                ts = get_typestore(Stores.ROS2_HUMBLE)
            self._stores[encoding] = ts
        return self._stores[encoding]

    def register(self, encoding: str, msgtype: str, definition: str, definition_format: str = "msg") -> None:
        """Adds the types of a stored message definition (``msg`` text or ``idl``); bad definitions are ignored."""
        if not definition.strip():
            return
        ts = self.typestore(encoding)
        try:
            if definition_format == "idl":
                types = get_types_from_idl(definition)
            else:
                types = get_types_from_msg(definition, normalize_msgtype(msgtype))
            ts.register({k: v for k, v in types.items() if k not in ts.fielddefs})
        except Exception:  # noqa: BLE001 - a definition we cannot parse falls back to the built-in types
            return

    def decode(self, raw: bytes | memoryview, msgtype: str, encoding: str) -> Any:
        """Any message, as rosbags' dataclass objects (arrays as numpy)."""
        ts = self.typestore(encoding)
        name = normalize_msgtype(msgtype)
        if encoding == "ros1":
            return ts.deserialize_ros1(raw, name)
        return ts.deserialize_cdr(raw, name)

    def scan(self, raw: bytes | memoryview, encoding: str, msgtype: str = SCAN_TYPE) -> DecodedScan:
        """A sensor_msgs/LaserScan, or the first echoes of a MultiEchoLaserScan (``msgtype``)."""
        if normalize_msgtype(msgtype) == MULTI_ECHO_TYPE:
            return self._multi_echo_scan(raw, encoding)
        cdr = encoding == "cdr"
        if not cdr or _is_le_cdr(memoryview(raw)):
            try:
                return _fast_scan(raw, cdr)
            except (struct.error, ValueError):
                pass
        m = self.decode(raw, "sensor_msgs/msg/LaserScan", encoding)
        return DecodedScan(
            _stamp_of(m.header), m.header.frame_id, float(m.angle_min), float(m.angle_increment),
            float(m.range_min), float(m.range_max), np.asarray(m.ranges, dtype=np.float32),
            float(m.time_increment),
        )

    def _multi_echo_scan(self, raw: bytes | memoryview, encoding: str) -> DecodedScan:
        m = self.decode(raw, MULTI_ECHO_TYPE, encoding)
        first = np.array([e.echoes[0] if len(e.echoes) else np.nan for e in m.ranges], dtype=np.float32)
        return DecodedScan(
            _stamp_of(m.header), m.header.frame_id, float(m.angle_min), float(m.angle_increment),
            float(m.range_min), float(m.range_max), first, float(m.time_increment),
        )

    def odometry(self, raw: bytes | memoryview, encoding: str) -> DecodedOdometry:
        """A nav_msgs/Odometry, reduced to the plane."""
        cdr = encoding == "cdr"
        if not cdr or _is_le_cdr(memoryview(raw)):
            try:
                return _fast_odometry(raw, cdr)
            except (struct.error, ValueError):
                pass
        m = self.decode(raw, "nav_msgs/msg/Odometry", encoding)
        p, q = m.pose.pose.position, m.pose.pose.orientation
        yaw = float(quaternion_to_yaw(np.array([q.x, q.y, q.z, q.w])))
        return DecodedOdometry(_stamp_of(m.header), m.header.frame_id, m.child_frame_id, p.x, p.y, yaw)


def _stamp_of(header: Any) -> int:
    return int(header.stamp.sec) * 1_000_000_000 + int(header.stamp.nanosec)
