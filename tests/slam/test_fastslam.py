"""The filter on a generated world: a room with a box, pillars and a wall stub, a lidar ray-cast against
its wall segments, and odometry whose heading drifts 0.03 rad per metre.  The filter must stay near the
true path where odometry alone ends metres away."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from mcnkit.geometry import compose, relative
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.slam.config import LoopsConfig, MotionConfig, OfflineConfig, WideConfig
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan

LIDAR = LidarSpec(-np.pi / 2, np.pi / 180, 181, 0.05, 10.0)


def _box(x0: float, y0: float, x1: float, y1: float) -> list[tuple[float, float, float, float]]:
    return [(x0, y0, x1, y0), (x1, y0, x1, y1), (x1, y1, x0, y1), (x0, y1, x0, y0)]


WALLS = np.array(
    _box(0, 0, 12, 8)
    + _box(5, 3, 7, 5)
    + _box(9, 3.5, 9.3, 3.8)
    + _box(3, 5, 3.3, 5.3)
    + [(6, 8, 6, 7), (0, 4, 0.8, 4)]
)


def cast(pose: np.ndarray, rng: np.random.Generator, spec: LidarSpec = LIDAR, walls: np.ndarray = WALLS) -> np.ndarray:
    """Ranges (B,) of ``spec`` from ``pose`` to the nearest of the wall segments ``walls`` (W, 4), with 1 cm noise;
    beyond its range is no return."""
    a = pose[2] + spec.angles_rad
    d = np.stack([np.cos(a), np.sin(a)], axis=1)[:, None, :]  # (M, 1, 2)
    p, q = walls[None, :, :2], walls[None, :, 2:]
    e = q - p
    ao = p - pose[None, None, :2]
    den = d[..., 0] * e[..., 1] - d[..., 1] * e[..., 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (ao[..., 0] * e[..., 1] - ao[..., 1] * e[..., 0]) / den
        s = (ao[..., 0] * d[..., 1] - ao[..., 1] * d[..., 0]) / den
    t = np.where((t > 0) & (s >= 0) & (s <= 1) & np.isfinite(t), t, np.inf)
    r = t.min(axis=1) + rng.normal(0, 0.01, len(a))
    return np.where(r > spec.range_max_m, np.inf, r).astype(np.float32)


def true_path() -> np.ndarray:
    """A loop around the box: 0.1 m steps along the sides, 0.15 rad turns in place at the corners."""
    corners = [(1.5, 1.5), (10.5, 1.5), (10.5, 6.5), (1.5, 6.5), (1.5, 1.6)]
    poses = [np.array([1.5, 1.5, 0.0])]
    for (x0, y0), (x1, y1) in itertools.pairwise(corners):
        heading = np.arctan2(y1 - y0, x1 - x0)
        while abs(np.angle(np.exp(1j * (heading - poses[-1][2])))) > 1e-9:
            turn = np.clip(np.angle(np.exp(1j * (heading - poses[-1][2]))), -0.15, 0.15)
            poses.append(poses[-1] + [0, 0, turn])
        n = int(round(np.hypot(x1 - x0, y1 - y0) / 0.1))
        for k in range(1, n + 1):
            poses.append(np.array([x0 + (x1 - x0) * k / n, y0 + (y1 - y0) * k / n, heading]))
    return np.array(poses)


def drifting_odometry(truth: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """True increments with a heading bias of 0.03 rad/m and small Gaussian noise, chained from the start."""
    odom = [truth[0].copy()]
    for a, b in itertools.pairwise(truth):
        inc = relative(a, b)
        dist = np.hypot(inc[0], inc[1])
        inc = inc + np.array(
            [rng.normal(0, 0.01 * dist), rng.normal(0, 0.005 * dist), 0.03 * dist + rng.normal(0, 0.005)]
        )
        odom.append(compose(odom[-1], inc))
    return np.array(odom)


@pytest.fixture(scope="module")
def world_run() -> tuple[np.ndarray, np.ndarray, FastSlam, list]:
    rng = np.random.default_rng(7)
    truth = true_path()
    odom = drifting_odometry(truth, rng)
    frames = [
        Frame(int(k * 1e8), Scan(cast(p, rng), LIDAR), Pose2D.from_array(o))
        for k, (p, o) in enumerate(zip(truth, odom, strict=True))
    ]
    slam = FastSlam(SlamConfig(n_particles=10, resolution_m=0.05), np.random.default_rng(0))
    steps = [slam.step(f) for f in frames]
    return truth, odom, slam, steps


def test_filter_stays_on_the_true_path_where_odometry_drifts(world_run: tuple) -> None:
    truth, odom, slam, _ = world_run
    est = slam.trajectory().poses
    odom_err = np.hypot(*(odom[:, :2] - truth[:, :2]).T)
    slam_err = np.hypot(*(est[:, :2] - truth[:, :2]).T)
    yaw_err = np.abs(np.angle(np.exp(1j * (est[:, 2] - truth[:, 2]))))
    assert odom_err[-1] > 1.0  # odometry alone ends more than a metre away
    assert slam_err.max() < 0.25
    assert slam_err[-1] < 0.15
    assert np.degrees(yaw_err).max() < 4.0


def test_online_tracking_follows_heading_better_than_odometry_propagation(world_run: tuple) -> None:
    # This world's odometry drifts mostly in heading (0.03 rad/m); tracking each scan removes that, while the
    # position error stays the corrected poses' (a few centimetres) either way.
    truth, _, slam, _ = world_run
    online, gmapping = slam.trajectory(mode="tracked").poses, slam.trajectory(mode="gmapping").poses
    err_online = np.hypot(*(online[:, :2] - truth[:, :2]).T)
    err_gmapping = np.hypot(*(gmapping[:, :2] - truth[:, :2]).T)
    yaw_online = np.abs(np.angle(np.exp(1j * (online[:, 2] - truth[:, 2]))))
    yaw_gmapping = np.abs(np.angle(np.exp(1j * (gmapping[:, 2] - truth[:, 2]))))
    assert err_online.mean() <= 1.15 * err_gmapping.mean()
    assert yaw_online.mean() < 0.8 * yaw_gmapping.mean()


def test_updates_only_after_enough_motion(world_run: tuple) -> None:
    _, odom, slam, steps = world_run
    updated = [s.index for s in steps if s.updated]
    assert updated[0] == 0 and slam.n_updates == len(updated)
    for a, b in itertools.pairwise(updated):  # summed odometry motion between updates
        inc = relative(odom[a:b], odom[a + 1 : b + 1])
        lin, ang = np.hypot(inc[:, 0], inc[:, 1]).sum(), np.abs(inc[:, 2]).sum()
        assert lin >= 1.0 - 1e-9 or ang >= 0.5 - 1e-9
        lin_before, ang_before = lin - np.hypot(*inc[-1, :2]), ang - abs(inc[-1, 2])
        assert lin_before < 1.0 and ang_before < 0.5  # ... and not one scan earlier


def test_step_reports_a_consistent_particle_set(world_run: tuple) -> None:
    _, _, slam, steps = world_run
    last = steps[-1]
    assert last.poses.shape == (10, 3) and last.weights.shape == (10,)
    assert last.weights.sum() == pytest.approx(1.0)
    assert 1.0 <= last.neff <= 10.0
    assert np.array_equal(last.best_pose, last.poses[last.best_index])
    grid = slam.best_map()
    ternary = slam.best_ternary()
    assert ternary.image.shape == grid.spec.shape
    # the room's south wall (y = 0) is mapped as occupied near x = 6
    row, col = grid.spec.world_to_cell(np.array([6.0, 0.01]))
    assert (grid.log_odds[row - 1 : row + 2, col] > 0).any()


def test_trajectory_modes_agree_at_updates_and_matched_fixes_the_heading(world_run: tuple) -> None:
    truth, _, slam, steps = world_run
    gm, sm, mt = (slam.trajectory(mode=m).poses for m in ("gmapping", "smoothed", "matched"))
    at_updates = [s.index for s in steps if s.updated]
    np.testing.assert_allclose(gm[at_updates], sm[at_updates], atol=1e-9)  # smoothing moves in-between poses only
    yaw_err = np.degrees(np.abs(np.angle(np.exp(1j * (mt[:, 2] - truth[:, 2])))))
    assert yaw_err.max() < 1.5  # every scan matched to the map: no odometry drift between updates
    with pytest.raises(ValueError, match="mode must be"):
        slam.trajectory(mode="best")


def test_scans_without_returns_and_a_mounted_laser_do_not_break_the_filter() -> None:
    spec = LidarSpec(-np.pi / 2, np.pi / 180, 181, 0.05, 10.0, Pose2D(0.2, 0.0, 0.0))
    rng = np.random.default_rng(1)
    slam = FastSlam(SlamConfig(n_particles=5), np.random.default_rng(0))
    for k in range(30):
        truth = np.array([1.5 + 0.1 * k, 1.5, 0.0])
        laser = compose(truth, np.array([0.2, 0.0, 0.0]))
        empty = k % 3 == 1  # every third scan, the first one excepted, has no return at all
        ranges = np.full(181, np.inf, np.float32) if empty else cast(laser, rng)
        step = slam.step(Frame(k * 10**8, Scan(ranges, spec), Pose2D.from_array(truth)))
        assert np.isfinite(step.poses).all()
    assert slam.n_updates >= 3
    assert np.abs(slam.trajectory(mode="matched").poses[:, 1] - 1.5).max() < 0.1
    assert slam.best_map().log_odds.any()


def test_a_reading_below_range_min_is_no_return_and_marks_nothing() -> None:
    """REP 117: a reading below ``range_min`` (a Hokuyo's error codes, a few millimetres) is no return, not a wall
    under the scanner."""
    spec = LidarSpec(-np.pi / 2, np.pi / 180, 181, 0.1, 10.0)
    rng = np.random.default_rng(2)
    slam = FastSlam(SlamConfig(n_particles=5), np.random.default_rng(0))
    truth = np.array([[1.5 + 0.1 * k, 1.5, 0.0] for k in range(40)])
    for k, pose in enumerate(truth):
        ranges = cast(pose, rng, spec)
        ranges[::7] = rng.uniform(0.001, 0.02, len(ranges[::7]))  # error codes on one beam in seven
        slam.step(Frame(k * 10**8, Scan(ranges, spec), Pose2D.from_array(pose)))
    grid = slam.best_map()
    occupied = np.argwhere(grid.log_odds > 0)
    xy = grid.spec.cell_to_world(occupied) if len(occupied) else np.zeros((0, 2))
    near_path = np.hypot(*(xy[:, None, :] - truth[None, :, :2]).transpose(2, 0, 1)).min(axis=1) < 0.3  # no wall within 1.5 m of it
    assert len(occupied) and not near_path.any()


def test_odometry_that_says_forward_while_the_robot_backs_up_is_caught() -> None:
    # FR079 does this around scan 840: the wheels report 0.1 m forward per scan while the scans show the robot
    # reversing.  Here the robot drives 3 m east along the room's south side, then backs up 1.5 m; the
    # odometry reports the backing up as driving on.
    rng = np.random.default_rng(3)
    truth = [np.array([2.0 + 0.1 * k, 1.5, 0.0]) for k in range(31)]
    truth += [np.array([5.0 - 0.1 * k, 1.5, 0.0]) for k in range(1, 16)]
    odom = [truth[0]]
    for _ in range(1, len(truth)):
        odom.append(compose(odom[-1], np.array([0.1, 0.0, 0.0])))  # always "forward"
    frames = [Frame(int(k * 1e8), Scan(cast(p, rng), LIDAR), Pose2D.from_array(o))
              for k, (p, o) in enumerate(zip(truth, odom, strict=True))]
    errors, rejected = {}, {}
    for wide in (True, False):
        slam = FastSlam(SlamConfig(n_particles=10, motion=MotionConfig(check_odometry=True), wide=WideConfig(search=wide),
                                   loops=LoopsConfig(closure=False)), np.random.default_rng(0))
        for f in frames:
            slam.step(f)
        est = slam.trajectory().poses
        errors[wide] = float(np.hypot(*(est[-1, :2] - truth[-1][:2])))
        rejected[wide] = slam.n_odometry_rejected
    # without the wide search the odometry is still caught: its steps are unlike what the robot was doing (backing
    # up) while the scans side with that, so their motion is found from the scans alone
    assert errors[True] < 0.2 and errors[False] < 0.2
    assert rejected[False] > 0


def test_an_odometry_jump_the_scans_contradict_is_undone_by_the_wide_search_and_counted() -> None:
    # the odometry reads one step as 0.8 m sideways (a slip read wrong); the scans show the robot drove straight on
    rng = np.random.default_rng(5)
    truth = true_path()[:70]
    odom = [truth[0]]
    for k in range(1, len(truth)):
        jump = np.array([0.0, 0.8, 0.0]) if k == 40 else np.zeros(3)
        odom.append(compose(odom[-1], relative(truth[k - 1], truth[k]) + jump))
    frames = [Frame(int(k * 1e8), Scan(cast(p, rng), LIDAR), Pose2D.from_array(o))
              for k, (p, o) in enumerate(zip(truth, odom, strict=True))]
    errors, jumps = {}, {}
    for wide in (True, False):
        slam = FastSlam(SlamConfig(n_particles=10, wide=WideConfig(search=wide), loops=LoopsConfig(closure=False)),
                        np.random.default_rng(0))
        for f in frames:
            slam.step(f)
        errors[wide] = float(np.hypot(*(slam.trajectory().poses[-1, :2] - truth[-1][:2])))
        jumps[wide] = slam.n_wide_jumps
    assert errors[True] < 0.2 < errors[False]  # without the wide search the filter keeps part of the jump
    assert jumps == {True: 1, False: 0}  # summary.json's wide_search_jumps


def _turn_without_odometry() -> tuple[list[np.ndarray], list[Frame], float, int]:
    """The robot drives 2 m east, turns 70° in place and drives on north-east; across the turn the log holds no
    odometry (``odom_known`` False), so that frame repeats the previous odometry pose."""
    rng = np.random.default_rng(4)
    truth = [np.array([2.0 + 0.1 * k, 2.0, 0.0]) for k in range(21)]
    turn = np.radians(70.0)
    truth += [np.array([4.0 + 0.1 * k * np.cos(turn), 2.0 + 0.1 * k * np.sin(turn), turn]) for k in range(0, 25)]
    gap = 21  # the frame after the turn
    odom = [truth[0]]
    for k in range(1, len(truth)):
        step = np.zeros(3) if k == gap else relative(truth[k - 1], truth[k])
        odom.append(compose(odom[-1], step))
    frames = [Frame(int(k * 1e8), Scan(cast(p, rng), LIDAR), Pose2D.from_array(o), odom_known=k != gap)
              for k, (p, o) in enumerate(zip(truth, odom, strict=True))]
    return truth, frames, turn, gap


def test_motion_the_log_does_not_hold_is_found_by_scan_matching() -> None:
    # Seattle's corrected log drops the odometry across one 81° turn in place; Örebro's across nearly every step.
    truth, frames, turn, _ = _turn_without_odometry()
    slam = FastSlam(SlamConfig(n_particles=10, loops=LoopsConfig(closure=False)), np.random.default_rng(0))
    for f in frames:
        slam.step(f)
    est = slam.trajectory().poses
    assert slam.n_unknown_motion == 1
    assert np.degrees(abs(np.angle(np.exp(1j * (est[-1, 2] - turn))))) < 2.0  # the 70° turn was found
    assert np.hypot(*(est[-1, :2] - truth[-1][:2])) < 0.15
    # read as "no motion", the same frames leave the robot facing east while it drives north-east
    blind = FastSlam(SlamConfig(n_particles=10, loops=LoopsConfig(closure=False)), np.random.default_rng(0))
    for f in frames:
        blind.step(Frame(f.stamp_ns, f.scan, f.odom))
    assert np.degrees(abs(np.angle(np.exp(1j * (blind.trajectory().poses[-1, 2] - turn))))) > 20.0


def test_motion_the_log_does_not_hold_is_predicted_from_the_robots_last_motion_not_from_two_online_poses() -> None:
    # The online trajectory jumps where a filter update makes another particle the best (its map may be shifted
    # from the last one's): the difference of two online poses is then no motion of the robot.  Predicting from it
    # once sent Örebro's particles off by kilometres, each bogus step feeding the next.  Here the online pose of
    # the scan before the last known one is moved 3 m, as such a switch would; the turn is found all the same.
    truth, frames, turn, gap = _turn_without_odometry()
    slam = FastSlam(SlamConfig(n_particles=10, loops=LoopsConfig(closure=False)), np.random.default_rng(0))
    for f in frames[:gap]:
        slam.step(f)
    slam._scan_online[-2] = slam._scan_online[-2] + np.array([-3.0, 1.0, 0.0])
    for f in frames[gap:]:
        slam.step(f)
    est = slam.trajectory().poses
    assert np.degrees(abs(np.angle(np.exp(1j * (est[-1, 2] - turn))))) < 2.0
    assert np.hypot(*(est[-1, :2] - truth[-1][:2])) < 0.15


def test_a_sparse_log_gets_the_particle_spread_its_odometry_needs_not_gmappings_per_step_noise() -> None:
    # The Radish corrected logs keep one scan per metre: gmapping's coefficients (per step) then draw 10-17° of
    # heading noise per scan where the odometry errs by a fraction of a degree.  Here: the loop with 0.8 m steps.
    rng = np.random.default_rng(7)
    truth = true_path()[::8]
    odom = drifting_odometry(truth, rng)
    frames = [Frame(int(k * 1e9), Scan(cast(p, rng), LIDAR), Pose2D.from_array(o))
              for k, (p, o) in enumerate(zip(truth, odom, strict=True))]
    spread, worst = {}, {}
    for measured in (True, False):
        slam = FastSlam(SlamConfig(n_particles=10, motion=MotionConfig(noise_from_log=measured)), np.random.default_rng(0))
        headings = [np.degrees(np.std(np.unwrap(slam.step(f).poses[:, 2]))) for f in frames]  # per-step spread
        spread[measured] = float(np.mean(headings[len(frames) // 2:]))
        est = slam.trajectory().poses
        worst[measured] = float(np.degrees(np.abs(np.angle(np.exp(1j * (est[:, 2] - truth[:, 2])))).max()))
        if measured:
            xy, rad = slam.noise_scale.scales()
            assert 0.05 <= rad < 0.5 and 0.05 <= xy < 0.8  # measured on the log: well below gmapping's model
    assert spread[True] < 0.5 * spread[False]
    assert worst[True] < 3.0 and worst[False] < 3.0  # a room this small holds either way


def test_refined_trajectory_stays_on_the_path_and_the_map_can_be_cast_from_it(world_run: tuple) -> None:
    truth, _, slam, steps = world_run
    tracked, refined = slam.trajectory(mode="tracked").poses, slam.trajectory(mode="refined").poses
    err_tracked = np.hypot(*(tracked[:, :2] - truth[:, :2]).T)
    err_refined = np.hypot(*(refined[:, :2] - truth[:, :2]).T)
    assert err_refined.mean() <= err_tracked.mean() + 0.005 and err_refined.max() < 0.25
    # the update scans index the trajectory where the filter updated: the tracked poses there are the update poses
    at_updates = slam.update_scans()
    assert at_updates.tolist() == [s.index for s in steps if s.updated]
    np.testing.assert_allclose(tracked[at_updates], slam.update_poses(), atol=1e-9)
    _spec, strips = slam.best_map_strips(poses=refined[at_updates])
    assert sum(hits.sum() for _, hits, _ in strips) > 0
    with pytest.raises(ValueError, match="one pose per update"):
        slam.best_map_strips(poses=refined)


def test_the_whole_log_graph_solves_the_updates_again_and_carries_the_scans_between(world_run: tuple) -> None:
    truth, _, slam, _ = world_run
    plain = slam.config
    try:  # the option is read when the refined trajectory is asked for
        slam.config = replace(plain, offline=OfflineConfig(whole_graph=True))
        solved = slam.trajectory(mode="refined").poses
        stats = slam.whole_graph_stats
    finally:
        slam.config = plain
    err = np.hypot(*(solved[:, :2] - truth[:, :2]).T)
    assert err.mean() < 0.05 and err.max() < 0.25
    assert stats is not None and stats.nodes == slam.n_updates
    assert stats.step_edges > stats.nodes and stats.odometry_edges > 0


def _stalled_turn() -> tuple[list[np.ndarray], list[Frame], int]:
    """The robot drives 2 m east, turns 90° in place, 15° a scan, and drives on north; the odometry stalls for the
    first four scans of the turn (it repeats its pose) and then catches up: 75° in one scan."""
    rng = np.random.default_rng(5)
    truth = [np.array([2.0 + 0.1 * k, 2.0, 0.0]) for k in range(21)]
    truth += [np.array([4.0, 2.0, np.radians(15.0 * k)]) for k in range(1, 7)]
    truth += [np.array([4.0, 2.0 + 0.1 * k, np.pi / 2]) for k in range(1, 30)]
    stalled = range(21, 25)
    odom = [truth[0]]
    for k in range(1, len(truth)):
        if k in stalled:
            odom.append(odom[-1])  # the driver repeats its last pose
        elif k == stalled.stop:  # and catches up: the whole turn so far in one step
            odom.append(compose(odom[-1], relative(truth[stalled.start - 1], truth[k])))
        else:
            odom.append(compose(odom[-1], relative(truth[k - 1], truth[k])))
    frames = [Frame(int(k * 1e8), Scan(cast(p, rng), LIDAR), Pose2D.from_array(o))
              for k, (p, o) in enumerate(zip(truth, odom, strict=True))]
    return truth, frames, stalled.stop


@pytest.mark.parametrize("seed", range(4))
def test_odometry_that_stalls_and_catches_up_is_applied_from_before_the_stall(seed: int) -> None:
    # MIT CSAIL's odometry does this around scan 1580: four scans at one pose while the robot turns, then 85° in one
    truth, frames, catch_up = _stalled_turn()
    slam = FastSlam(SlamConfig(n_particles=10, loops=LoopsConfig(closure=False)), np.random.default_rng(seed))
    online = [slam.step(f).best_pose for f in frames]
    heading_error_deg = [np.degrees(abs(np.angle(np.exp(1j * (p[2] - t[2]))))) for p, t in zip(online, truth, strict=True)]
    assert max(heading_error_deg[catch_up:]) < 3.0  # the catch-up step lands on the turn, not 60° past it
    assert np.hypot(*(online[-1][:2] - truth[-1][:2])) < 0.15
