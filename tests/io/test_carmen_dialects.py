"""CARMEN logs as gmapping's and CARMEN's own tools write them: every dialect is read completely, in log order.

Each test writes a small log of one kind into ``tmp_path``: a robot driving 0.5 m per scan along x in a 10 m
square room, so the scans and the odometry are consistent and the stamps are the only thing that varies.
"""

from __future__ import annotations

import itertools
import math
import warnings
from pathlib import Path

import numpy as np
import pytest

from mcnkit.io import LogWarning, open_log
from mcnkit.io.carmen import repair_stamps
from mcnkit.io.info import describe
from mcnkit.slam import FastSlam, SlamConfig

N_SCANS = 12


def _ranges(x: float, n: int = 181) -> list[str]:
    """Ranges from (x, 5) facing +x to the walls of the square [0, 10]²."""
    out = []
    for a in np.radians(np.linspace(-90, 90, n)):
        c, s = math.cos(a), math.sin(a)
        t = min((10 - x) / c if c > 1e-9 else 1e9, 5 / abs(s) if abs(s) > 1e-9 else 1e9)
        out.append(f"{t:.3f}")
    return out


def _flaser(k: int, stamp: str | None, n: int = 181) -> str:
    x = 1.0 + 0.5 * k
    tail = f" {stamp} host {stamp}" if stamp is not None else ""
    return f"FLASER {n} {' '.join(_ranges(x, n))} {x} 5 0 {x} 5 0{tail}"


def _write(tmp_path: Path, lines: list[str], name: str = "run.log") -> Path:
    path = tmp_path / name
    path.write_text("\n".join(lines) + "\n")
    return path


def _read(path: Path) -> tuple[list[int], list[float], list[str], dict[str, object]]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LogWarning)
        with open_log(path) as log:
            frames = list(log.frames())
            info = describe(log)
    messages = [str(w.message) for w in caught if issubclass(w.category, LogWarning)]
    return [f.stamp_ns for f in frames], [f.odom.x_m for f in frames], messages, info


def _assert_complete_and_in_log_order(stamps: list[int], xs: list[float]) -> None:
    assert len(stamps) == N_SCANS
    assert xs == [1.0 + 0.5 * k for k in range(N_SCANS)]  # log order: the robot's x rises scan by scan
    assert all(b > a for a, b in itertools.pairwise(stamps))  # strictly rising


def test_a_clean_log_keeps_its_exact_stamps_and_warns_nothing(tmp_path: Path) -> None:
    path = _write(tmp_path, [_flaser(k, f"1134864629.{k:06d}") for k in range(N_SCANS)])
    stamps, xs, messages, info = _read(path)
    _assert_complete_and_in_log_order(stamps, xs)
    assert stamps[3] == 1134864629_000003000 and messages == []
    assert info["scans"] == N_SCANS and info["laser_lines"] == N_SCANS


def test_gmapping_style_header_param_lines_and_six_digit_stamps(tmp_path: Path) -> None:
    header = ["# CARMEN Logfile", "# file format is one message per line", "PARAM robot_length 0.47 1.13486e+09 host 0"]
    # printed with %g: six significant digits, i.e. 10,000 s ticks; this log crosses one tick
    lines = header + [_flaser(k, f"{1134864980.0 + 3.0 * k:g}") for k in range(N_SCANS)]
    stamps, xs, messages, _ = _read(_write(tmp_path, lines))
    _assert_complete_and_in_log_order(stamps, xs)
    assert len(messages) == 1 and "only 2 distinct values for 12 scans" in messages[0]
    assert "stamped in log order every 0.2 s" in messages[0]
    assert stamps[0] == 1_134_860_000_000_000_000  # the log's first (coarse) stamp, then the nominal rate


@pytest.mark.parametrize(
    ("stamp", "problem"),
    [("1134864629.5", "all equal"), ("0", "all zero"), ("-12.25", "negative"), ("4.29497e+09", "32-bit sentinel")],
)
def test_stamps_that_carry_no_time_are_replaced_in_log_order(tmp_path: Path, stamp: str, problem: str) -> None:
    stamps, xs, messages, _ = _read(_write(tmp_path, [_flaser(k, stamp) for k in range(N_SCANS)]))
    _assert_complete_and_in_log_order(stamps, xs)
    assert len(messages) == 1 and problem in messages[0] and "stamped in log order every 0.2 s" in messages[0]


def test_stamps_running_backwards_are_replaced_from_the_odom_stream(tmp_path: Path) -> None:
    lines = []
    for k in range(N_SCANS):
        x = 1.0 + 0.5 * k
        lines.append(f"ODOM {x} 5 0 0.5 0 0 {100.0 + k:.3f} host {100.0 + k:.3f}")
        lines.append(_flaser(k, f"{500.0 - 7 * k:.3f}"))  # a clock that runs backwards
    stamps, xs, messages, _ = _read(_write(tmp_path, lines))
    _assert_complete_and_in_log_order(stamps, xs)
    assert len(messages) == 1 and "going backwards" in messages[0] and "ODOM lines they follow" in messages[0]
    assert abs(stamps[0] / 1e9 - 100.0) < 1e-3  # the ODOM line before the first scan


def test_lines_without_stamp_fields_and_dpslam_style_short_lines(tmp_path: Path) -> None:
    stamps, xs, messages, _ = _read(_write(tmp_path, [_flaser(k, None) for k in range(N_SCANS)]))
    _assert_complete_and_in_log_order(stamps, xs)
    assert len(messages) == 1 and "no stamp" in messages[0]


def test_a_malformed_line_is_skipped_counted_and_named(tmp_path: Path) -> None:
    lines = [_flaser(k, f"{10.0 + k:.3f}") for k in range(N_SCANS)]
    lines.insert(4, "FLASER 181 1.0 2.0 oops")
    stamps, xs, messages, info = _read(_write(tmp_path, lines))
    _assert_complete_and_in_log_order(stamps, xs)
    assert messages == [f"{tmp_path / 'run.log'}: malformed line(s) skipped: 1 FLASER (first at line 5)"]
    assert info["scans"] == N_SCANS and info["laser_lines"] == N_SCANS + 1


def test_rawlaser_lines_take_their_odometry_from_the_odom_stream(tmp_path: Path) -> None:
    lines = []
    for k in range(N_SCANS):
        x = 1.0 + 0.5 * k
        lines.append(f"ODOM {x - 0.25} 5 0 0.5 0 0 {10.0 + k - 0.5:.3f} host 0")
        lines.append(f"ODOM {x} 5 0 0.5 0 0 {10.0 + k:.3f} host 0")
        r = _ranges(x)
        lines.append(f"RAWLASER1 0 {-math.pi / 2} {math.pi} {math.pi / 180} 81.9 0.01 0 181 {' '.join(r)} 0 "
                     f"{10.0 + k:.3f} host 0")
    stamps, xs, messages, info = _read(_write(tmp_path, lines))
    _assert_complete_and_in_log_order(stamps, xs)
    assert messages == [] and info["odom_source"] == "ODOM lines at the scan stamps"


def test_robotlaser_lines(tmp_path: Path) -> None:
    lines = []
    for k in range(N_SCANS):
        x = 1.0 + 0.5 * k
        r = _ranges(x)
        lines.append(f"ROBOTLASER1 0 {-math.pi / 2} {math.pi} {math.pi / 180} 81.9 0.01 0 181 {' '.join(r)} 0 "
                     f"{x} 5 0 {x} 5 0 0.5 0 1 1 1 {20.0 + k:.3f} host {20.0 + k:.3f}")
    stamps, xs, messages, _ = _read(_write(tmp_path, lines))
    _assert_complete_and_in_log_order(stamps, xs)
    assert messages == []


def test_slam_on_a_log_with_equal_stamps_keeps_one_pose_per_scan_in_log_order(tmp_path: Path) -> None:
    path = _write(tmp_path, [_flaser(k, "0.0") for k in range(N_SCANS)])
    with pytest.warns(LogWarning, match="all zero"), open_log(path) as log:
        frames = list(log.frames())
    slam = FastSlam(SlamConfig(n_particles=5), np.random.default_rng(0))
    for f in frames:
        slam.step(f)
    traj = slam.trajectory()
    assert len(traj) == N_SCANS and (np.diff(traj.stamps_ns) > 0).all()
    assert np.allclose(traj.poses[:, 0], [1.0 + 0.5 * k for k in range(N_SCANS)], atol=0.1)


def test_repair_stamps_is_a_no_op_on_rising_stamps_and_spreads_ties() -> None:
    good = [1, 2, 3]
    assert repair_stamps(good, None, 0.2) == (pytest.approx(np.array(good)), None)  # type: ignore[comparison-overlap]
    out, problem = repair_stamps([10, 10, 10, 40, 40], None, 0.2)
    assert out.tolist() == [10, 20, 30, 40, 70] and problem is not None and "2 equal" not in problem


def test_several_no_return_sentinels_at_the_top_of_the_range_are_all_no_return(tmp_path: Path) -> None:
    # Acapulco marks "no return" with 51.14, 51.15 and 50.00 m in one log, and holds a few real 51.25 m returns;
    # taking the largest reading as the limit would keep ~13,000 sentinel readings as 51 m walls.
    rng = np.random.default_rng(0)
    lines = []
    for k in range(N_SCANS):
        r = np.array(_ranges(1.0 + 0.5 * k), dtype=float)
        r[rng.choice(181, 40, replace=False)] = rng.choice([51.14, 51.15, 50.0], 40)
        if k == 3:
            r[10] = 51.25
        lines.append(f"FLASER 181 {' '.join(f'{v:.2f}' for v in r)} 0 0 0 0 0 0 {k + 1.0:.3f} host 0")
    with open_log(_write(tmp_path, lines)) as log:
        assert log.lidar_spec.range_max_m == pytest.approx(49.98)
        first = next(iter(log.frames()))
    assert not first.scan.valid[first.scan.ranges_m >= 50.0].any()


@pytest.mark.parametrize(("bad", "problem"), [("-3.5", "1 zero or negative"), ("4.29497e+09", "1 at the 32-bit sentinel")])
def test_one_bad_stamp_among_good_ones_is_a_tie_not_a_restamped_log(tmp_path: Path, bad: str, problem: str) -> None:
    """The log's own time is kept: the damaged stamp takes its predecessor's time and is spread like a tie."""
    lines = [_flaser(k, f"{100.0 + 0.25 * k:.3f}" if k != 5 else bad) for k in range(N_SCANS)]
    stamps, xs, messages, _ = _read(_write(tmp_path, lines))
    _assert_complete_and_in_log_order(stamps, xs)
    assert len(messages) == 1 and problem in messages[0] and "the time of the scan before" in messages[0]
    assert stamps[0] == 100_000_000_000 and stamps[-1] == int((100.0 + 0.25 * (N_SCANS - 1)) * 1e9)
    assert 101_000_000_000 < stamps[5] < 101_500_000_000  # between its neighbours' own times


def test_a_corrected_log_that_dropped_the_odometry_between_some_scans_says_the_motion_is_unknown(tmp_path: Path) -> None:
    # Radish "corrected" layout: FLASER pose fields = corrected pose, then ODOM re-anchored at it, then the raw
    # odometry until the next scan.  Örebro's log holds only the re-anchoring line in most gaps: the robot moved,
    # but the log does not say how, and reading that as "no motion" sends SLAM the wrong way (Seattle: 13 m).
    gaps = {4, 8}
    lines = []
    for k in range(N_SCANS):
        x = 1.0 + 0.5 * k
        if k and k not in gaps:
            lines.append(f"ODOM {x - 0.02:.3f} 5.01 0.003 0 0 0 {k - 0.5:.3f} host {k - 0.5:.3f}")  # raw, a bit off
        lines.append(f"FLASER 181 {' '.join(_ranges(x))} {x} 5 0 {x} 5 0 {k + 0.0:.3f} host {k + 0.0:.3f}")
        lines.append(f"ODOM {x} 5 0 0 0 0 {k + 0.1:.3f} host {k + 0.1:.3f}")  # re-anchored at the corrected pose
        lines.append("NEFF 30")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LogWarning)
        with open_log(_write(tmp_path, lines)) as log:
            frames = list(log.frames())
            assert log.ground_truth() is not None
    messages = [str(w.message) for w in caught if issubclass(w.category, LogWarning)]
    assert [k for k, f in enumerate(frames) if not f.odom_known] == sorted(gaps)
    assert any("no odometry between 2 of 11 pairs of consecutive scans" in m for m in messages)
    odom = np.array([f.odom.as_array() for f in frames])
    assert np.allclose(odom[4], odom[3]) and np.allclose(odom[8], odom[7])  # the pose repeats: motion unknown
    assert 0.45 < odom[5, 0] - odom[4, 0] < 0.55  # elsewhere the raw increments are kept


def test_a_20_m_step_into_a_scan_whose_stamp_was_rebuilt_is_unknown_motion(tmp_path: Path) -> None:
    # a damaged line: its stamp reads 0 (rebuilt from its neighbours, so it carries no time to judge a speed by) and
    # its pose fields are shifted 20 m: the steps into and out of it are read as unknown motion, not passed on
    lines = [_flaser(k, f"{100.0 + 0.25 * k:.3f}") for k in range(N_SCANS)]
    x = 1.0 + 0.5 * 5
    lines[5] = f"FLASER 181 {' '.join(_ranges(x))} {x + 20} 5 0 {x + 20} 5 0 0 host 0"
    stamps, xs, messages, _ = _read(_write(tmp_path, lines))
    assert len(stamps) == N_SCANS  # the scan is kept
    assert any("2 odometry step(s) a robot cannot make between scans whose stamps were rebuilt" in m for m in messages)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        with open_log(tmp_path / "run.log") as log:
            known = [f.odom_known for f in log.frames()]
    assert [k for k, ok in enumerate(known) if not ok] == [5, 6]
    steps = np.diff(xs)
    assert steps[4] == steps[5] == 0.0  # unknown motion carries no step
    assert np.allclose(steps[6:], 0.5) and np.allclose(steps[:4], 0.5)  # the odometry's own steps elsewhere


def test_a_misparsed_corrected_line_does_not_carry_the_robot_away(tmp_path: Path) -> None:
    # Radish corrected layout; scan 6's line lost a field, so its pose fields shifted and its stamp reads 0.003
    lines = []
    for k in range(N_SCANS):
        x = 1.0 + 0.5 * k
        if k:
            lines.append(f"ODOM {x - 0.02:.3f} 5.01 0.003 0 0 0 {k - 0.5:.3f} host {k - 0.5:.3f}")
        pose = f"5 0 {x} 5 0.003 {x} 5 0" if k == 6 else f"{x} 5 0 {x} 5 0"
        lines.append(f"FLASER 181 {' '.join(_ranges(x))} {pose} {k + 0.0:.3f} host {k + 0.0:.3f}")
        lines.append(f"ODOM {x} 5 0 0 0 0 {k + 0.1:.3f} host {k + 0.1:.3f}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", LogWarning)
        with open_log(_write(tmp_path, lines)) as log:
            frames = list(log.frames())
    odom = np.array([f.odom.as_array() for f in frames])
    assert np.abs(np.diff(odom[:, :2], axis=0)).max() < 1.0  # no step beyond the robot's own half metre


def test_a_turn_in_place_between_scans_whose_stamps_carry_no_time_is_kept_as_odometry(tmp_path: Path) -> None:
    # Radish corrected layout with every stamp equal (rebuilt in log order): such logs keep one scan per metre or
    # per turn, so the robot may turn 80 degrees in place between two scans; only a step's length is judged there
    headings = [0.0] * 6 + [1.4] * (N_SCANS - 6)
    xy = [np.array([1.0, 5.0])]
    for k in range(1, N_SCANS):
        xy.append(xy[-1] + (0.0 if k == 6 else 0.5) * np.array([math.cos(headings[k]), math.sin(headings[k])]))
    lines = []
    for k in range(N_SCANS):
        (x, y), th = xy[k], headings[k]
        if k:
            lines.append(f"ODOM {x - 0.02:.3f} {y + 0.01:.3f} {th + 0.003:.3f} 0 0 0 7.0 host 7.0")  # raw, a bit off
        lines.append(f"FLASER 181 {' '.join(_ranges(1.0))} {x:.3f} {y:.3f} {th} {x:.3f} {y:.3f} {th} 7.0 host 7.0")
        lines.append(f"ODOM {x:.3f} {y:.3f} {th} 0 0 0 7.0 host 7.0")  # re-anchored at the corrected pose
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LogWarning)
        with open_log(_write(tmp_path, lines)) as log:
            frames = list(log.frames())
    messages = [str(w.message) for w in caught if issubclass(w.category, LogWarning)]
    assert not any("cannot make" in m for m in messages)
    assert all(f.odom_known for f in frames)
    odom = np.array([f.odom.as_array() for f in frames])
    assert abs(odom[6, 2] - odom[5, 2] - 1.4) < 0.01  # the turn is the odometry's own
    assert np.hypot(*(odom[6, :2] - odom[5, :2])) < 0.05


def test_a_log_that_keeps_one_scan_every_3_m_is_read_with_its_odometry_but_a_damaged_line_is_not(tmp_path: Path) -> None:
    # Radish corrected layout, every stamp equal: the robot drives 3 m between scans (as Örebro's log keeps them);
    # the step's length is judged against the log's own steps, so only scan 6's line, shifted 40 m, is refused
    lines = []
    for k in range(N_SCANS):
        x = 1.0 + 3.0 * k + (40.0 if k == 6 else 0.0)
        if k:
            lines.append(f"ODOM {x - 0.02:.3f} 5.01 0.003 0 0 0 7.0 host 7.0")
        lines.append(f"FLASER 181 {' '.join(_ranges(1.0))} {x} 5 0 {x} 5 0 7.0 host 7.0")
        lines.append(f"ODOM {x} 5 0 0 0 0 7.0 host 7.0")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", LogWarning)
        with open_log(_write(tmp_path, lines)) as log:
            known = [f.odom_known for f in log.frames()]
    messages = [str(w.message) for w in caught if issubclass(w.category, LogWarning)]
    assert [k for k, ok in enumerate(known) if not ok] == [6, 7]
    assert any("2 odometry increment(s) a robot cannot make" in m for m in messages)
