"""A bag recorded without ``/tf_static`` does not say where its scanner points: the reader finds it from the robot's
motion (the direction, sense of sweep and offset that make the sharpest map), so a scanner mounted turned, upside
down or off the base's centre still gives the map the robot saw."""

from __future__ import annotations

import itertools
import math
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mcnkit.io import LogContent, LogWarning, open_log, write_log
from mcnkit.io.mountfit import as_mounted
from mcnkit.types import Frame, LidarSpec, Pose2D


@pytest.fixture(scope="module")
def mit_first_metres(shared_data: Path) -> list[Frame]:
    """MIT CSAIL's scans over its robot's first ten metres, with their odometry (its scanner at the base)."""
    frames, path_m = [], 0.0
    with open_log(shared_data / "reallab/mit-csail/mit-csail.clf") as log:
        for f in log.frames():
            if frames:
                path_m += math.hypot(f.odom.x_m - frames[-1].odom.x_m, f.odom.y_m - frames[-1].odom.y_m)
            frames.append(f)
            if path_m > 10.0:
                break
    assert frames[0].scan.spec.base_to_laser == Pose2D()
    return frames


def world_points(f: Frame) -> np.ndarray:
    """The frame's returns in the odometry's frame, through the mount its spec names."""
    spec: LidarSpec = f.scan.spec
    m, o = spec.base_to_laser, f.odom
    ok = f.scan.valid
    r, a = f.scan.ranges_m[ok].astype(np.float64), spec.angles_rad[ok] + m.yaw_rad + o.yaw_rad
    c, s = math.cos(o.yaw_rad), math.sin(o.yaw_rad)
    x0, y0 = o.x_m + c * m.x_m - s * m.y_m, o.y_m + s * m.x_m + c * m.y_m
    return np.stack([x0 + r * np.cos(a), y0 + r * np.sin(a)], axis=1)


@pytest.mark.parametrize(("mount", "upside_down"), [
    (Pose2D(0.0, 0.0, math.pi / 2), False),           # a quarter turn
    (Pose2D(-0.25, 0.12, math.radians(165.5)), False),  # nearly backwards, off the centre
    (Pose2D(0.3, -0.1, math.pi), True),                 # backwards and upside down
])
def test_a_turned_scanner_is_found_from_the_motion(tmp_path: Path, mit_first_metres: list[Frame], mount: Pose2D,
                                                   upside_down: bool) -> None:
    bag = write_log(tmp_path / "no_tf_static.mcap",
                    LogContent(list(as_mounted(mit_first_metres, mount, upside_down)), mount_transform=False))
    with pytest.warns(LogWarning, match=r"no transform from the base frame 'base_link' to the scanner's frame "
                                        r"'laser': from the robot's first \d+ m, the scanner points"):
        with open_log(bag) as log:
            found = log.lidar_spec.base_to_laser
            got = list(log.frames())
    assert math.degrees(abs(math.remainder(found.yaw_rad - mount.yaw_rad, math.tau))) < 2.0
    assert math.hypot(found.x_m - mount.x_m, found.y_m - mount.y_m) < 0.08
    # every return lands where the robot saw it, within the fit's 8 cm and 2° (0.35 m more at 10 m)
    for a, b in zip(got[::25], mit_first_metres[::25], strict=False):
        ok = b.scan.valid
        reach_m = b.scan.ranges_m[ok].astype(np.float64)
        assert (np.linalg.norm(world_points(a) - world_points(b), axis=1) < 0.08 + reach_m * math.sin(math.radians(2))).all()


def test_the_odometry_on_tf_alone_tells_it_too(tmp_path: Path, mit_first_metres: list[Frame]) -> None:
    """A bag whose odometry is only the ``odom -> base_link`` transform on ``/tf`` (no Odometry topic)."""
    mount = Pose2D(0.0, 0.0, -math.pi / 2)
    bag = write_log(tmp_path / "tf_only.mcap", LogContent(list(as_mounted(mit_first_metres, mount)), odom_topic=None,
                                                          mount_transform=False))
    with pytest.warns(LogWarning, match="from the robot.s first 8 m, the scanner points -"):
        with open_log(bag) as log:
            assert log.odom_source == "tf:odom->base_link"
            assert math.degrees(abs(math.remainder(log.lidar_spec.base_to_laser.yaw_rad + math.pi / 2, math.tau))) < 2.0


def test_a_scanner_facing_forward_stays_so(tmp_path: Path, mit_first_metres: list[Frame]) -> None:
    bag = write_log(tmp_path / "no_tf_static.mcap", LogContent(mit_first_metres, mount_transform=False))
    with pytest.warns(LogWarning, match=r"the scanner is taken to sit at the base, facing forward \(the robot's first "
                                        r"\d+ m agree with it"):
        with open_log(bag) as log:
            assert log.lidar_spec.base_to_laser == Pose2D()
            assert len(list(log.frames())) == len(mit_first_metres)


@pytest.mark.parametrize("log", ["intel/intel-corrected.log.gz", "radish/aces-corrected.log.gz",
                                 "radish/freiburg-079-corrected.log.gz", "radish/freiburg-101-corrected.log.gz",
                                 "radish/fhw-corrected.log.gz", "radish/acapulco-corrected.log.gz",
                                 "radish/freiburg-campus-corrected.log.gz"])
def test_no_building_s_scanner_is_taken_for_a_turned_one(tmp_path: Path, shared_data: Path, log: str) -> None:
    """Every building of the shared logs (their scanners face forward at the base) written without /tf_static: the
    fit agrees with facing forward, however sparse the log (Intel: a scan per metre) or wide the space (campus)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        with open_log(shared_data / "reallab" / log) as original:
            frames = list(itertools.islice(original.frames(), 3000))
    bag = write_log(tmp_path / "no_tf_static.mcap", LogContent(frames, mount_transform=False))
    with pytest.warns(LogWarning, match=r"facing forward \(the robot's first \d+ m agree with it"):
        with open_log(bag) as read:
            assert read.lidar_spec.base_to_laser == Pose2D()


def test_a_robot_that_only_turns_cannot_tell(tmp_path: Path, mit_first_metres: list[Frame]) -> None:
    """Turning in place shows the same map whichever way the scanner points: it is taken to face forward."""
    spinning = [replace(f, odom=Pose2D(0.0, 0.0, f.odom.yaw_rad)) for f in mit_first_metres]
    bag = write_log(tmp_path / "spinning.mcap", LogContent(list(as_mounted(spinning, Pose2D(0, 0, 1.0))),
                                                           mount_transform=False))
    with pytest.warns(LogWarning, match=r"facing forward \(the robot drives 0.0 m in the stretch looked at: too little"):
        with open_log(bag) as log:
            assert log.lidar_spec.base_to_laser == Pose2D()
