"""A spinning scanner on a turning robot: each beam is measured from another pose.  Deskewed, the returns lie where
the robot at the scan's stamp would have seen them, and the filter tracks a robot that spins in place as well as one
that turns slowly."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mcnkit.geometry import compose
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.slam.config import MatchingConfig
from mcnkit.slam.deskew import deskew_ranges
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan
from tests.slam.test_fastslam import WALLS

SWEEP_S = 0.125  # an RPLIDAR A1 at 8 Hz
N_BEAMS = 720
SPINNING = LidarSpec(-math.pi, 2 * math.pi / N_BEAMS, N_BEAMS, 0.15, 12.0, Pose2D(-0.05, 0.0, math.pi / 2),
                     time_increment_s=SWEEP_S / N_BEAMS)


def cast_each(origins: np.ndarray, angles: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The range from each origin (M, 2) along its own angle (M,) to the nearest wall of the test room, 1 cm noise."""
    d = np.stack([np.cos(angles), np.sin(angles)], axis=1)[:, None, :]
    p, q = WALLS[None, :, :2], WALLS[None, :, 2:]
    e = q - p
    ao = p - origins[:, None, :]
    den = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ao[..., 0] * e[..., 1] - ao[..., 1] * e[..., 0]) / den
        s = (ao[..., 0] * d[..., 1] - ao[..., 1] * d[..., 0]) / den
    t = np.where((t > 0) & (s >= 0) & (s <= 1) & np.isfinite(t), t, np.inf)
    return t.min(axis=1) + rng.normal(0, 0.01, len(angles))


def swept_scan(pose: np.ndarray, velocity: np.ndarray, rng: np.random.Generator, spec: LidarSpec = SPINNING) -> np.ndarray:
    """The ranges a spinning scanner logs on a robot at ``pose`` at the first beam, moving at ``velocity`` (robot
    frame): beam i from where the scanner is at its own time."""
    at = compose(pose, spec.beam_times_s[:, None] * velocity[None, :])  # the base at each beam's time
    scanner = compose(at, spec.base_to_laser.as_array())
    r = cast_each(scanner[:, :2], scanner[:, 2] + spec.angles_rad, rng)
    return np.where(r > spec.range_max_m, np.inf, r).astype(np.float32)


def wall_distance(points: np.ndarray) -> np.ndarray:
    """Each point's distance (M,) to the nearest wall segment of the test room."""
    p, q = WALLS[None, :, :2], WALLS[None, :, 2:]
    e = q - p
    u = np.clip(((points[:, None, :] - p) * e).sum(-1) / (e * e).sum(-1), 0.0, 1.0)
    return np.linalg.norm(p + u[..., None] * e - points[:, None, :], axis=-1).min(axis=1)


def world_points(pose: np.ndarray, ranges: np.ndarray, spec: LidarSpec = SPINNING) -> np.ndarray:
    ok = np.isfinite(ranges) & (ranges <= spec.range_max_m)
    a, r = spec.angles_rad[ok], ranges[ok].astype(np.float64)
    local = np.stack([r * np.cos(a), r * np.sin(a), np.zeros_like(r)], axis=1)
    return compose(compose(pose, spec.base_to_laser.as_array()), local)[:, :2]


@pytest.mark.parametrize("velocity", [(0.0, 0.0, 2.0), (0.5, 0.0, -1.2), (0.3, 0.1, 0.8)])
def test_each_return_lands_where_the_robot_at_the_stamp_would_have_seen_it(velocity: tuple[float, float, float]) -> None:
    """Spinning (a counter-clockwise sweep on a robot turning the same way sees 374°: 14° twice), turning while
    driving, and veering."""
    rng = np.random.default_rng(1)
    pose, v = np.array([3.0, 2.0, 0.4]), np.array(velocity)
    raw = swept_scan(pose, v, rng)
    fixed = deskew_ranges(raw, SPINNING, v)
    skewed, straight = wall_distance(world_points(pose, raw)), wall_distance(world_points(pose, fixed))
    # on the nearest beam: within half a step (0.25°) of the return's direction, 2.2 cm at 5 m, plus the noise
    assert np.quantile(straight, 0.95) < 0.04
    assert np.isfinite(fixed).sum() >= 0.95 * np.isfinite(raw).sum()  # two returns on one beam: the nearer kept
    assert np.quantile(skewed, 0.95) > 3 * np.quantile(straight, 0.95)


def test_a_scanner_that_does_not_say_when_it_measured_is_left_as_logged() -> None:
    spec = LidarSpec(-math.pi, 2 * math.pi / N_BEAMS, N_BEAMS, 0.15, 12.0)
    raw = swept_scan(np.array([3.0, 2.0, 0.0]), np.zeros(3), np.random.default_rng(2), spec)
    assert np.array_equal(deskew_ranges(raw, spec, np.array([0.0, 0.0, 2.0])), raw)


def test_beams_upside_down_were_measured_last_to_first() -> None:
    """A scanner read upside down has its beams reversed: its time increment is negative, and the first beam of
    the spec was measured last."""
    flipped = LidarSpec(-math.pi, 2 * math.pi / N_BEAMS, N_BEAMS, 0.15, 12.0, time_increment_s=-SWEEP_S / N_BEAMS)
    times = flipped.beam_times_s
    assert times[-1] == 0.0 and times[0] == pytest.approx(SWEEP_S * (N_BEAMS - 1) / N_BEAMS)


def test_the_filter_tracks_a_robot_spinning_in_place() -> None:
    """The robot drives 5 m, spins a full turn in place at up to 2 rad/s (14° within each sweep of 0.125 s; half a
    second to speed up and to slow down) and drives on.  Deskewed, its heading is where it was before the turn;
    as logged, each sweep's seam pulls the match, and the filter leaves the turn 12° off."""
    rng = np.random.default_rng(3)
    ramp = [np.array([0.0, 0.0, w]) for w in (0.5, 1.0, 1.5)]
    drive = np.array([0.4, 0.0, 0.0])
    plan = [drive] * 40 + ramp + [np.array([0.0, 0.0, 2.0])] * 22 + ramp[::-1] + [drive] * 30
    poses, pose = [], np.array([2.0, 1.5, 0.0])
    for v in plan:
        poses.append(pose.copy())
        pose = compose(pose, v * SWEEP_S)
    frames = [Frame(int(k * SWEEP_S * 1e9), Scan(swept_scan(p, v, rng), SPINNING), Pose2D.from_array(p))
              for k, (p, v) in enumerate(zip(poses, plan, strict=True))]
    after_turn = {}
    for deskew in (True, False):
        slam = FastSlam(SlamConfig(n_particles=10, matching=MatchingConfig(deskew=deskew)), np.random.default_rng(0))
        online = [slam.step(f).best_pose for f in frames]
        error_deg = [math.degrees(abs(math.remainder(e[2] - p[2], math.tau))) for e, p in zip(online, poses, strict=True)]
        after_turn[deskew] = max(error_deg[-20:])
    assert after_turn[True] < 1.5 and after_turn[False] > 5.0
