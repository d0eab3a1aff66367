"""REP 117: every reading outside the scanner's range, or not finite, is "no return"; no scan is dropped for it."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from mcnkit.io import LogContent, LogWarning, open_log, write_log
from mcnkit.io.info import describe, print_info
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan

SPECIALS = np.array([np.inf, -np.inf, np.nan, 12.5, 40.0, 1e30, 0.05, -1.0], np.float32)
"""+inf (nothing within range), -inf (too close), NaN (invalid), beyond range_max (12 m: just and far beyond),
below range_min (0.15 m), negative."""


def rplidar_frames(n: int = 40) -> list[Frame]:
    """A 720-beam 360° scanner (an RPLIDAR on a TurtleBot 4): every scan holds every kind of "no return"."""
    spec = LidarSpec(-np.pi, 2 * np.pi / 720, 720, 0.15, 12.0, Pose2D(0.05, 0.0, np.pi))
    rng = np.random.default_rng(3)
    frames = []
    for i in range(n):
        ranges = rng.uniform(0.3, 11.0, 720).astype(np.float32)
        ranges[rng.choice(720, len(SPECIALS), replace=False)] = SPECIALS
        frames.append(Frame(1_700_000_000_000_000_000 + i * 100_000_000, Scan(ranges, spec),
                            Pose2D(0.02 * i, 0.0, 0.01 * i)))
    return frames


@pytest.mark.parametrize(("fmt", "name"), [("ros2-mcap", "tb4"), ("ros2-sqlite3", "tb4_sqlite3"), ("mcap", "tb4.mcap")])
def test_a_360_degree_scanner_with_rep117_readings_reads_with_zero_scans_dropped(
    tmp_path: Path, fmt: str, name: str
) -> None:
    frames = rplidar_frames()
    path = write_log(tmp_path / name, LogContent(frames), fmt)
    with warnings.catch_warnings():
        warnings.simplefilter("error", LogWarning)  # nothing skipped, nothing to say
        with open_log(path) as log:
            got = list(log.frames())
            spec = log.lidar_spec
    assert len(got) == len(frames)
    assert spec.n_beams == 720 and np.isclose(spec.fov_rad, 2 * np.pi * 719 / 720)
    for a, b in zip(got, frames, strict=True):
        assert np.array_equal(a.scan.ranges_m, b.scan.ranges_m, equal_nan=True)  # kept as they were logged
        special = np.isin(b.scan.ranges_m, SPECIALS) | np.isnan(b.scan.ranges_m)
        assert not a.scan.valid[special].any() and a.scan.valid[~special].all()


def test_a_conversion_keeps_every_no_return_as_it_was(tmp_path: Path) -> None:
    from mcnkit.app.main import main

    frames = rplidar_frames(10)
    src = write_log(tmp_path / "tb4", LogContent(frames), "ros2-mcap")
    assert main(["convert", str(src), str(tmp_path / "back.bag"), "--quiet"]) == 0
    with open_log(tmp_path / "back.bag") as log:
        back = list(log.frames())
    assert all(np.array_equal(a.scan.ranges_m, b.scan.ranges_m, equal_nan=True) for a, b in zip(back, frames, strict=True))


def test_the_skipped_scan_warning_names_each_reason_with_its_count(tmp_path: Path) -> None:
    from mcnkit.io.plausible import plausible_frames

    frames = rplidar_frames(12)
    frames[3] = Frame(-1, frames[3].scan, frames[3].odom)
    frames[5] = Frame(frames[4].stamp_ns - 1, frames[5].scan, frames[5].odom)
    with pytest.warns(LogWarning, match=r"skipped scans: 1 \(stamp out of bounds\), 1 \(stamp went backwards\)$"):
        got = list(plausible_frames("tb4", frames))
    assert len(got) == 10


@pytest.mark.parametrize("stated", [np.inf, np.nan, 0.0, float(np.finfo(np.float32).max)])
def test_a_scanner_that_states_no_range_keeps_every_finite_reading(tmp_path: Path, stated: float,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """pointcloud_to_laserscan (a 3-D lidar's ring as a LaserScan) states range_max inf by default; other drivers
    leave it 0 or write FLT_MAX.  The first scans here reach 5 m, the later ones 60 m: all of them are returns, and
    ``mcnkit info`` says that no maximum was stated."""
    spec = LidarSpec(-np.pi, 2 * np.pi / 720, 720, 0.2, 100.0)
    object.__setattr__(spec, "range_max_m", stated)  # what the driver wrote, which a LidarSpec would refuse
    rng = np.random.default_rng(5)
    frames = []
    for i in range(20):
        ranges = rng.uniform(0.5, 5.0 if i < 8 else 60.0, 720).astype(np.float32)
        ranges[::40] = np.inf
        frames.append(Frame(1_700_000_000_000_000_000 + i * 100_000_000, Scan(ranges, spec), Pose2D(0.02 * i, 0.0, 0.0)))
    path = write_log(tmp_path / "ring", LogContent(frames), "ros2-mcap")
    with pytest.warns(LogWarning, match=r"/scan states no range \(range_max .*\): every finite reading from 0.2 m up "
                                        r"to 1000 m is a return"):
        with open_log(path) as log:
            got = list(log.frames())
            assert log.lidar_spec.range_max_m == 1000.0
            info = describe(log)
    assert len(got) == len(frames)
    assert info["scanner"]["range_max_stated"] is False  # type: ignore[index]
    print_info(info)
    assert "range from 0.2 m, no maximum stated (every finite reading up to 1000 m is a return)" in capsys.readouterr().out
    for a, b in zip(got, frames, strict=True):
        assert np.array_equal(a.scan.valid, np.isfinite(b.scan.ranges_m))
