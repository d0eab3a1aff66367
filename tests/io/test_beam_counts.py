"""Scanners whose driver does not keep the beams constant (LD06/LD19, YDLIDAR, RPLIDAR S1 without angle
compensation: 450 to 460 readings a turn, a new count every scan) are read with no scan dropped."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mcnkit.io import LogContent, LogWarning, open_log, write_log
from mcnkit.io.bag import resample_beams
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan
from tests.io.test_mounts import _range_to_room

COUNTS = [456, 456, 458, 456, 455, 460, 453, 456, 459, 456, 454, 457] * 3
"""Readings per turn, scan by scan: 456 is the commonest among the first scans."""


def _spec(n: int) -> LidarSpec:
    return LidarSpec(0.0, 2 * math.pi / n, n, 0.02, 12.0)


def test_every_scan_of_a_wandering_beam_count_is_read_onto_the_scanners_beams(tmp_path: Path) -> None:
    frames = []
    for k, n in enumerate(COUNTS):
        spec = _spec(n)
        frames.append(Frame(1_700_000_000_000_000_000 + k * 100_000_000,
                            Scan(_range_to_room(np.zeros(2), spec.angles_rad).astype(np.float32), spec), Pose2D()))
    path = write_log(tmp_path / "ld19", LogContent(frames), "ros2-mcap")
    others = sum(n != 456 for n in COUNTS)
    with pytest.warns(LogWarning, match=rf"{others} scans of another beam count or angles than the scanner's 456 beams"):
        with open_log(path) as log:
            got = list(log.frames())
            spec = log.lidar_spec
    assert spec.n_beams == 456 and len(got) == len(COUNTS)
    for f, n in zip(got, COUNTS, strict=True):
        step = 2 * math.pi / n  # that scan's own beams: the nearest to each of the scanner's, round the circle
        nearest = np.mod(np.rint(spec.angles_rad / step), n) * step
        logged = _range_to_room(np.zeros(2), nearest).astype(np.float32)
        assert np.array_equal(f.scan.ranges_m, logged)  # copied from the nearest beam, never interpolated


def test_a_reading_goes_to_the_beam_nearest_in_angle_round_the_circle() -> None:
    ranges = np.arange(8, dtype=np.float32)  # 8 beams at 0°, 45°, ..., 315°
    target = np.radians([0.0, 44.0, 359.0, 200.0, 337.0])
    out = resample_beams(ranges, 0.0, math.pi / 4, target)
    assert list(out[:4]) == [0.0, 1.0, 0.0, 4.0]  # 359° is nearest to 0° round the circle
    assert list(resample_beams(ranges[::-1], 7 * math.pi / 4, -math.pi / 4, target)[:4]) == [0.0, 1.0, 0.0, 4.0]
    half = resample_beams(ranges[:4], 0.0, math.pi / 4, np.radians([90.0, 180.0, 300.0]))  # a 135° scanner
    assert half[0] == 2.0 and np.isnan(half[1:]).all()  # nothing within half a step: no return
