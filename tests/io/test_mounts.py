"""The scanner's mount from the log's transforms, in 3-D: a chain of frames, a scanner upside down, a mount that
an old log broadcasts on ``/tf`` instead of ``/tf_static``."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from mcnkit.io import LogContent, LogWarning, open_log, write_log
from mcnkit.io.info import describe
from mcnkit.types import Pose2D

TS = get_typestore(Stores.ROS2_HUMBLE)
T = TS.types
ROOM_M = (-2.0, 6.0, -1.5, 3.5)  # x0, x1, y0, y1: a rectangle the robot is not at the centre of (a mirror shows)
N_BEAMS = 360
BETWEEN_BEAMS_S = 0.1 / N_BEAMS  # a 10 Hz sweep
T0 = 1_700_000_000_000_000_000


def _quat(roll: float, yaw: float) -> tuple[float, float, float, float]:
    """x, y, z, w of a rotation by ``yaw`` about z after ``roll`` about x."""
    cr, sr, cy, sy = math.cos(roll / 2), math.sin(roll / 2), math.cos(yaw / 2), math.sin(yaw / 2)
    return sr * cy, -sr * sy, cr * sy, cr * cy


def _header(stamp: int, frame: str) -> object:
    return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=stamp // 10**9, nanosec=stamp % 10**9),
                                    frame_id=frame)


def _tf(stamp: int, parent: str, child: str, xyz: tuple[float, float, float], roll: float, yaw: float) -> object:
    x, y, z, w = _quat(roll, yaw)
    return T["geometry_msgs/msg/TransformStamped"](
        header=_header(stamp, parent), child_frame_id=child,
        transform=T["geometry_msgs/msg/Transform"](translation=T["geometry_msgs/msg/Vector3"](x=xyz[0], y=xyz[1], z=xyz[2]),
                                                   rotation=T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)))


def _range_to_room(origin: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Distance from ``origin`` (2,) to the room's walls along each angle (the room's inside)."""
    x0, x1, y0, y1 = ROOM_M
    dx, dy = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(dx > 0, (x1 - origin[0]) / dx, (x0 - origin[0]) / dx)
        ty = np.where(dy > 0, (y1 - origin[1]) / dy, (y0 - origin[1]) / dy)
    return np.minimum(np.where(dx == 0, np.inf, tx), np.where(dy == 0, np.inf, ty))


def write_mounted_bag(path: Path, mount_topic: str | None, upside_down: bool) -> tuple[np.ndarray, float]:
    """A ROS 2 bag of a robot at rest at the origin of a rectangular room, its scanner 0.3 m ahead and turned 90°
    (base_footprint -> base_link -> lidar_mount -> laser), upside down or not; the mount on ``mount_topic`` (None:
    nowhere, a bag recorded without ``/tf_static``).
    Returns the scanner's position in the base frame and its yaw."""
    mount_xy, mount_yaw = np.array([0.3, 0.1]), math.pi / 2
    roll = math.pi if upside_down else 0.0
    chain = [("base_footprint", "base_link", (0.0, 0.0, 0.1), 0.0, 0.0),
             ("base_link", "lidar_mount", (0.3, 0.1, 0.2), 0.0, mount_yaw),
             ("lidar_mount", "laser", (0.0, 0.0, 0.05), roll, 0.0)]
    amin, inc = -math.pi, 2 * math.pi / N_BEAMS
    raw_angles = amin + inc * np.arange(N_BEAMS)
    base_angles = mount_yaw - raw_angles if upside_down else mount_yaw + raw_angles  # where each beam points
    ranges = _range_to_room(mount_xy, base_angles).astype(np.float32)
    cov = np.zeros(36)
    zero = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0)
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as w:
        tf_type = "tf2_msgs/msg/TFMessage"
        c_tf = w.add_connection(mount_topic, tf_type, typestore=TS) if mount_topic else None
        c_scan = w.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=TS)
        c_odom = w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=TS)
        for i in range(5):
            t = T0 + i * 100_000_000
            if c_tf is not None and (i == 0 or mount_topic == "/tf"):  # static: once; broadcast: every step
                w.write(c_tf, t, TS.serialize_cdr(T[tf_type](transforms=[_tf(t, *c) for c in chain]), tf_type))
            odom = T["nav_msgs/msg/Odometry"](
                header=_header(t, "odom"), child_frame_id="base_footprint",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](pose=T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=0.0, y=0.0, z=0.0),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)), covariance=cov),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=T["geometry_msgs/msg/Twist"](linear=zero, angular=zero), covariance=cov))
            w.write(c_odom, t, TS.serialize_cdr(odom, "nav_msgs/msg/Odometry"))
            scan = T["sensor_msgs/msg/LaserScan"](
                header=_header(t, "laser"), angle_min=amin, angle_max=amin + (N_BEAMS - 1) * inc, angle_increment=inc,
                time_increment=BETWEEN_BEAMS_S * (1 + 0.01 * (i - 2)), scan_time=0.1, range_min=0.1, range_max=30.0,
                ranges=ranges,
                intensities=np.zeros(0, np.float32))
            w.write(c_scan, t, TS.serialize_cdr(scan, "sensor_msgs/msg/LaserScan"))
    return mount_xy, mount_yaw


def _on_the_walls(points: np.ndarray) -> np.ndarray:
    x0, x1, y0, y1 = ROOM_M
    d = np.minimum.reduce([abs(points[:, 0] - x0), abs(points[:, 0] - x1), abs(points[:, 1] - y0),
                           abs(points[:, 1] - y1)])
    return d < 1e-3


@pytest.mark.parametrize("upside_down", [False, True])
@pytest.mark.parametrize("mount_topic", ["/tf_static", "/tf"])
def test_every_beam_lands_on_the_wall_it_hit(tmp_path: Path, mount_topic: str, upside_down: bool) -> None:
    """Through a chain of three frames, from the odometry's base, the scan's points in the base frame lie on the
    room's walls: the mount is found (on /tf when a log has no /tf_static) and an upside-down scanner is mirrored."""
    mount_xy, mount_yaw = write_mounted_bag(tmp_path / "robot", mount_topic, upside_down)
    with open_log(tmp_path / "robot") as log:
        spec = log.lidar_spec
        frame = next(iter(log.frames()))
    assert np.allclose([spec.base_to_laser.x_m, spec.base_to_laser.y_m], mount_xy, atol=1e-9)
    assert spec.base_to_laser.yaw_rad == pytest.approx(mount_yaw)
    assert frame.scan.spec.base_to_laser.yaw_rad == pytest.approx(mount_yaw)
    m, r, a = spec.base_to_laser, frame.scan.ranges_m.astype(np.float64), spec.angles_rad + spec.base_to_laser.yaw_rad
    points = np.stack([m.x_m + r * np.cos(a), m.y_m + r * np.sin(a)], axis=1)  # the base frame: the robot is at 0
    assert len(points) == N_BEAMS and _on_the_walls(points).all()
    # the driver measures each sweep anew: the spec takes the median; read upside down, the first beam came last
    assert spec.time_increment_s == pytest.approx(-BETWEEN_BEAMS_S if upside_down else BETWEEN_BEAMS_S, rel=1e-6)
    assert spec.beam_times_s[-1 if upside_down else 0] == 0.0


def test_the_time_between_beams_survives_a_conversion(tmp_path: Path) -> None:
    write_mounted_bag(tmp_path / "robot", "/tf_static", upside_down=True)
    with open_log(tmp_path / "robot") as log:
        spec = log.lidar_spec
        assert describe(log)["scanner"]["sweep_s"] == pytest.approx(BETWEEN_BEAMS_S * (N_BEAMS - 1), abs=1e-6)
        out = write_log(tmp_path / "again.mcap", LogContent(log.frames()))
    with open_log(out) as again:
        assert again.lidar_spec.time_increment_s == pytest.approx(spec.time_increment_s, rel=1e-6)


def test_a_bag_without_the_mount_says_so(tmp_path: Path) -> None:
    write_mounted_bag(tmp_path / "robot", None, upside_down=False)
    with pytest.warns(LogWarning, match="no transform from the base frame 'base_footprint' to the scanner's frame "
                                        "'laser': the scanner is taken to sit at the base, facing forward"):
        with open_log(tmp_path / "robot") as log:
            assert log.lidar_spec.base_to_laser == Pose2D()
