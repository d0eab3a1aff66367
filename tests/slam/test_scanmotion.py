"""Motion from the scans alone: the motion prior and its spread, the search that places a scan without odometry,
and the filter on the test room run with its odometry ignored, missing or slipping."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mcnkit.geometry import compose, relative
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.slam.config import LoopsConfig, MotionConfig
from mcnkit.slam.correlative import LikelihoodGrid, likelihood_grid, with_unseen
from mcnkit.slam.lineage import LineageMap
from mcnkit.slam.scanmotion import MotionGuess, MotionPrior, motion_covariance, outlier_share, sample_increments
from mcnkit.slam.widesearch import seen_grid, unknown_motion_match
from mcnkit.types import Frame, Pose2D, Scan
from tests.slam.test_fastslam import LIDAR, cast, drifting_odometry, true_path


def test_constant_velocity_where_scans_come_at_a_steady_rate() -> None:
    prior = MotionPrior(window=50, default_sigma=np.ones(3), min_sigma=np.array([0.01, 0.01, 0.01]))
    for _ in range(40):
        prior.add(np.array([0.1, 0.0, 0.02]), 0.1)
    guess = prior.predict(0.15)  # a scan 1.5 times later than usual: 1.5 times the step
    assert prior.mode == "velocity"
    np.testing.assert_allclose(guess.mean, [0.15, 0.0, 0.03])
    np.testing.assert_allclose(guess.sigma, 0.01)  # steady so far: the floor
    assert prior.predict(None).mean[0] == pytest.approx(0.1)  # no usable time: the step


def test_constant_step_where_scans_are_kept_by_distance() -> None:
    # a sparse log keeps one scan per metre, seconds apart at random: the time between scans predicts nothing
    rng = np.random.default_rng(0)
    prior = MotionPrior(window=50, default_sigma=np.ones(3))
    for _ in range(60):
        prior.add(np.array([1.0 + rng.normal(0, 0.03), 0.0, rng.normal(0, 0.02)]), float(rng.uniform(1.0, 5.0)))
    guess = prior.predict(4.0)
    assert prior.mode == "step"
    assert guess.mean[0] == pytest.approx(1.0, abs=0.1)
    assert 0.02 < guess.sigma[0] < 0.1  # measured on the log


def test_the_spread_and_the_reach_are_the_logs_own() -> None:
    default = np.array([0.7, 0.7, 1.0])
    prior = MotionPrior(window=50, default_sigma=default, min_samples=30)
    for k in range(29):  # a robot that alternates 1 m steps and 30° turns in place
        prior.add(np.array([1.0, 0.0, 0.0]) if k % 2 else np.array([0.0, 0.0, math.radians(30)]), 2.0)
    assert prior.reach(2.0, math.pi) == (2.0, math.pi)  # too few steps yet: the most
    np.testing.assert_allclose(prior.predict(2.0).sigma, default)
    prior.add(np.array([1.0, 0.0, 0.0]), 2.0)
    xy, rad = prior.reach(2.0, math.pi)
    assert xy == pytest.approx(2.0) and rad == pytest.approx(math.radians(60))  # twice the fastest so far
    sigma = prior.predict(2.0).sigma
    assert sigma[0] > 0.5 and sigma[2] > math.radians(15)  # what this robot does from one scan to the next


def test_a_matched_motion_is_spread_along_the_corridor_and_pinned_across_it() -> None:
    # the match pins world y and the heading (a corridor along world x), not x
    info = np.diag([0.0, 400.0, 4000.0])
    sigma = np.array([0.5, 0.2, 0.3])
    along = motion_covariance(info, 0.0, sigma)  # the robot faces down the corridor
    assert math.sqrt(along[0, 0]) == pytest.approx(0.5, rel=1e-6)
    assert math.sqrt(along[1, 1]) < 0.05
    across = motion_covariance(info, math.pi / 2, sigma)  # facing world y: its own y runs along the corridor
    assert math.sqrt(across[1, 1]) == pytest.approx(0.2, rel=1e-6) and math.sqrt(across[0, 0]) < 0.05
    draws = sample_increments(np.zeros((4000, 3)), np.array([1.0, 0.0, 0.0]), along, np.random.default_rng(0))
    assert draws[:, 0].mean() == pytest.approx(1.0, abs=0.03)
    assert draws[:, 0].std() == pytest.approx(0.5, rel=0.05) and draws[:, 1].std() < 0.05


def _corridor() -> np.ndarray:
    """Hit points of two walls 2 m apart along x, 30 m long: a scan fits anywhere along them."""
    x = np.arange(-15.0, 15.0, 0.05)
    return np.r_[np.c_[x, np.full_like(x, 1.0)], np.c_[x, np.full_like(x, -1.0)]]


def test_near_ties_go_to_the_prediction() -> None:
    walls = _corridor()
    grid = likelihood_grid(walls, 0.1, 0.15, 0.1, depth=5)
    scan = walls[np.abs(walls[:, 0]) < 6.0] + 0.013  # what the robot at the origin sees
    cfg = SlamConfig()
    for x in (-0.8, 0.0, 0.6):  # wherever the prior says the robot went along the axis, it stays there
        predicted = np.array([x, 0.2, 0.05])  # off across the corridor and in heading too: those the scan pins
        found = unknown_motion_match(grid, np.zeros(3), MotionGuess(predicted, np.array([0.3, 0.3, 0.1])), (2.0, math.pi),
                                     scan, cfg)
        assert found is not None
        assert found[0] == pytest.approx(x, abs=0.25)
        assert abs(found[1]) < 0.06 and abs(found[2]) < math.radians(1.5)


def _drives_and_turns(steps: int) -> MotionPrior:
    """The prior of a log kept by distance: 1 m drives and 30° turns in place (either way), two drives to a turn,
    the last step a turn."""
    rng = np.random.default_rng(1)
    prior = MotionPrior(window=50, default_sigma=np.ones(3), min_sigma=np.array([0.02, 0.02, math.radians(1.0)]))
    for k in range(steps):
        if k % 3 == 2:
            step = np.array([0.02, 0.0, math.radians(30.0) * rng.choice([-1.0, 1.0]) + rng.normal(0, 0.03)])
        else:
            step = np.array([1.0 + rng.normal(0, 0.05), rng.normal(0, 0.02), rng.normal(0, 0.03)])
        prior.add(step, float(rng.uniform(1.0, 5.0)))
    return prior


def test_the_prior_knows_the_kinds_of_step_the_robot_makes() -> None:
    guess = _drives_and_turns(60).predict(3.0)  # the last step was a turn: the constant step predicts another
    assert abs(guess.mean[2]) > math.radians(20)
    drive, left, right = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.52]), np.array([0.0, 0.0, -0.52])
    quarter_turn, backwards = np.array([0.0, 0.0, math.pi / 2]), np.array([-1.0, 0.0, 0.0])
    dens = guess.log_density(np.stack([drive, left, right, quarter_turn, backwards]))
    assert dens[0] > dens[3] + 10 and min(dens[1], dens[2]) > dens[3] + 10  # every kind of step: likely
    assert dens[4] < dens[:3].min() - 2  # a step it never made: several times less (the last step's wide Gaussian keeps it possible)
    modes = guess.modes()  # where the search looks: the prediction and the densest kinds of step
    assert 3 <= len(modes) <= 4 and np.abs(modes[1:] - drive).sum(axis=1).min() < 0.1
    for turn in (left, right):  # each turn either way lies within three bandwidths of one of them
        assert (np.abs(modes - turn) / guess.bandwidth).max(axis=1).min() < 3


def test_the_share_of_steps_no_prediction_explains_is_measured() -> None:
    rng = np.random.default_rng(0)
    log_u = -math.log(4.0**2 * 2 * math.pi)
    well = rng.normal(2.0, 0.5, 200)  # every step predicted with a density well above the uniform's
    assert outlier_share(well, log_u) == pytest.approx(0.01)  # the floor
    mixed = np.where(rng.random(400) < 0.3, log_u - 5.0, 2.0)  # 30 % far beyond what the prediction expects
    assert outlier_share(mixed, log_u) == pytest.approx(0.3, abs=0.05)
    assert outlier_share(np.zeros(0), log_u) == 0.5


def test_after_a_turn_in_place_a_corridor_scan_is_placed_a_drive_on() -> None:
    # a corridor pins the heading and the side, not the axis: the prior decides how far the robot went.  The
    # last step predicts another turn in place, so no translation; the kinds of step this robot makes say a drive
    walls = _corridor()
    grid = likelihood_grid(walls, 0.1, 0.15, 0.1, depth=5)
    scan = walls[np.abs(walls[:, 0]) < 6.0] + 0.013  # the robot at the origin, facing down the corridor
    before = np.array([-1.0, 0.0, 0.0])
    prior = _drives_and_turns(60)
    guess = prior.predict(3.0)
    cfg = SlamConfig()
    alone = unknown_motion_match(grid, before, guess, (2.0, math.pi), scan, cfg, density=False)
    assert alone is not None and alone[0] < -0.6  # the last step alone: it stood still
    found = unknown_motion_match(grid, before, guess, (2.0, math.pi), scan, cfg)
    assert found is not None
    assert abs(found[0]) < 0.25 and abs(found[1]) < 0.06 and abs(found[2]) < math.radians(1.5)


def test_a_pose_far_from_the_prediction_wins_when_it_explains_the_scan_clearly_better() -> None:
    # the test room: the robot turned 60° in place where the prior expected it to drive on 1 m
    rng = np.random.default_rng(0)
    before = np.array([3.0, 2.0, 0.0])
    hits = []
    for yaw in np.radians(np.arange(0, 360, 30)):
        pose = before + np.array([0.0, 0.0, yaw])
        r = cast(pose, rng)
        ok = np.isfinite(r)
        a = pose[2] + LIDAR.angles_rad[ok]
        hits.append(np.c_[pose[0] + r[ok] * np.cos(a), pose[1] + r[ok] * np.sin(a)])
    grid = likelihood_grid(np.concatenate(hits), 0.1, 0.15, 0.1, depth=5)
    truth = before + np.array([0.0, 0.0, math.radians(60)])
    r = cast(truth, rng)
    ok = np.isfinite(r)
    scan = np.c_[r[ok] * np.cos(LIDAR.angles_rad[ok]), r[ok] * np.sin(LIDAR.angles_rad[ok])]
    drive_on = MotionGuess(np.array([1.0, 0.0, 0.0]), np.array([0.1, 0.05, 0.05]))  # the prior: 1 m ahead
    found = unknown_motion_match(grid, before, drive_on, (2.0, math.pi), scan, SlamConfig())
    assert found is not None
    assert np.hypot(*(found[:2] - truth[:2])) < 0.1 and abs(found[2] - truth[2]) < math.radians(1.5)


def test_a_prior_tighter_than_a_search_cell_still_beats_a_look_alike() -> None:
    # a corner the robot stands in, and 1.5 m away a copy of it turned 50° that the map holds a little sharper:
    # the scan explains the copy slightly better (not 1 / jump_ratio better), and a steady robot's prior is a few
    # centimetres, less than the search's 10 cm cell, so every pose the search can return near the prediction lies
    # several prior sigmas off
    rng = np.random.default_rng(3)
    arm = np.arange(0.3, 1.5, 0.02)
    corner = np.r_[np.c_[arm, np.full_like(arm, 0.4)], np.c_[np.full_like(arm, 0.4), arm], np.c_[arm, np.full_like(arm, -0.6)]]
    copy_pose = np.array([1.5, -0.2, math.radians(50)])
    c, s = math.cos(copy_pose[2]), math.sin(copy_pose[2])
    copy = corner @ np.array([[c, s], [-s, c]]) + copy_pose[:2]
    blurred = corner + rng.normal(0, 0.04, corner.shape)
    grid = likelihood_grid(np.r_[blurred, copy], 0.1, 0.1, 0.1, depth=5)
    scan = corner + rng.normal(0, 0.005, corner.shape)  # the robot at the origin
    steady = MotionGuess(np.array([0.04, -0.03, 0.01]), np.array([0.02, 0.02, math.radians(1.0)]))
    found = unknown_motion_match(grid, np.zeros(3), steady, (2.0, math.pi), scan, SlamConfig())
    assert found is not None
    assert np.hypot(found[0], found[1]) < 0.15 and abs(found[2]) < math.radians(3)


def test_a_scan_reaching_into_new_ground_is_not_folded_back_onto_mapped_walls() -> None:
    # the robot sees a mapped wall beside it (S1) and, ahead, a wall no scan has looked at yet (S2).  Elsewhere the
    # map holds a wall like S2, where a look-alike pose lays S2 on it and S1 in space the scans saw free.  Counted
    # as unexplained, the unseen returns make the look-alike win; counted as unknown (neither), the true pose wins
    s1 = np.c_[np.arange(0.0, 3.0, 0.05), np.full(60, 1.0)]
    s2 = np.c_[np.full(120, 4.0), np.arange(-3.0, 3.0, 0.05)]
    look_alike = np.array([-2.5, -0.5, 0.3])
    hits = np.r_[s1, compose(look_alike, np.c_[s2, np.zeros(len(s2))])[:, :2]] + 0.013
    grid = likelihood_grid(hits, 0.1, 0.15, 1.0, depth=5)
    cols = grid.origin_x_m + (np.arange(grid.shape[1]) + 0.5) * grid.resolution_m
    seen = np.broadcast_to(cols < 3.5, grid.shape)  # nothing beyond x = 3.5 m seen yet
    scan = np.r_[s1, s2] + 0.013  # the robot at the origin
    before, guess = np.array([-1.0, 0.0, 0.0]), MotionGuess(np.array([1.0, 0.0, 0.0]), np.array([2.0, 2.0, 1.0]))
    cfg = SlamConfig()
    folded = unknown_motion_match(grid, before, guess, (4.0, math.pi), scan, cfg, density=False)
    assert folded is not None and np.hypot(folded[0], folded[1]) > 1.0 and abs(folded[2] - look_alike[2]) < 0.05
    found = unknown_motion_match(with_unseen(grid, seen, 0.5), before, guess, (4.0, math.pi), scan, cfg, density=False)
    assert found is not None and np.hypot(found[0], found[1]) < 0.15 and abs(found[2]) < math.radians(1.5)


def test_the_cells_no_scan_has_seen_are_read_from_the_particles_ray_cast_counts() -> None:
    # one scan of three beams 2 m long from the origin: the cells along them are seen, the cells behind are not
    seen = LineageMap(0.1, np.array([-0.5, 0.0, 0.5]), np.zeros(3), max_range_m=10.0, usable_m=10.0, occ_thresh=0.25)
    seen.sync(np.zeros((1, 3)), [np.full(3, 2.0, np.float32)])
    grid = likelihood_grid(np.array([[-4.0, -4.0], [4.0, 4.0]]), 0.1, 0.15, 1.0, depth=5)
    lifted = seen_grid(grid, seen, 0.5)

    def at(g: LikelihoodGrid, x: float, y: float) -> float:
        col = int((x - g.origin_x_m) / g.resolution_m)
        row = int((y - g.origin_y_m) / g.resolution_m)
        return float(g.levels[0][row, col])

    assert at(lifted, 1.05, 0.05) == at(grid, 1.05, 0.05) == 0.0  # along a beam: seen free, explains nothing
    assert at(lifted, 2.05, 0.05) == at(grid, 2.05, 0.05)  # the beam's end
    assert at(lifted, -2.05, 0.05) == 0.5 and at(grid, -2.05, 0.05) == 0.0  # behind the scanner: unseen
    assert at(lifted, -3.95, -3.95) == at(grid, -3.95, -3.95) > 0.5  # a hit explains more than unknown space
    assert all(np.all(up >= low) for up, low in zip(lifted.levels[1:], lifted.levels[:-1], strict=True))  # upper bounds
    assert seen_grid(grid, seen, 0.0) is grid


def _frames(truth: np.ndarray, odom: np.ndarray, seed: int, dt_ns: int = 10**8) -> list[Frame]:
    rng = np.random.default_rng(seed)
    return [Frame(k * dt_ns, Scan(cast(p, rng), LIDAR), Pose2D.from_array(o))
            for k, (p, o) in enumerate(zip(truth, odom, strict=True))]


@pytest.mark.parametrize("unseen", [0.0, 0.5], ids=["unseen explains nothing", "unseen explains half"])
@pytest.mark.parametrize("every", [1, 8], ids=["10 Hz, 0.1 m steps", "one scan per 0.8 m"])
def test_the_room_is_mapped_from_its_scans_alone_with_the_odometry_ignored(every: int, unseen: float) -> None:
    truth = true_path()[::every]
    frames = _frames(truth, drifting_odometry(truth, np.random.default_rng(7)), 7)
    motion = MotionConfig(odometry="ignore", unseen_explains=unseen)
    slam = FastSlam(SlamConfig(n_particles=10, motion=motion), np.random.default_rng(0))
    for f in frames:
        slam.step(f)
    assert slam.lidar_only and slam.n_unknown_motion == len(frames) - 1 and slam.odometry_note() is None
    est = slam.trajectory().poses
    assert np.abs(est[0]).max() < 1e-9  # the ignored odometry's first pose does not place the map either
    moved = compose(truth[0], relative(est[0], est))  # the estimate from the true start
    err = np.hypot(*(moved[:, :2] - truth[:, :2]).T)
    yaw = np.degrees(np.abs(np.angle(np.exp(1j * (moved[:, 2] - truth[:, 2])))))
    assert err.max() < 0.2 and yaw.max() < 3.0


def test_odometry_that_slips_falls_back_to_the_motion_from_the_scans_and_is_counted() -> None:
    # the robot drives 5 m east, then its wheels spin for five scans (0.6 m each) while it stands still, then it
    # drives on
    truth = [np.array([1.5 + 0.1 * k, 1.5, 0.0]) for k in range(51)]
    truth += [truth[-1]] * 5 + [np.array([6.5 + 0.1 * k, 1.5, 0.0]) for k in range(1, 21)]
    odom = [truth[0]]
    for k in range(1, len(truth)):
        step = np.array([0.6, 0.0, 0.0]) if 51 <= k < 56 else relative(truth[k - 1], truth[k])
        odom.append(compose(odom[-1], step))
    slam = FastSlam(SlamConfig(n_particles=10, motion=MotionConfig(check_odometry=True), loops=LoopsConfig(closure=False)),
                    np.random.default_rng(0))
    for f in _frames(np.array(truth), np.array(odom), 3):
        slam.step(f)
    assert slam.n_odometry_rejected == 5 and not slam.lidar_only
    note = slam.odometry_note()
    assert note is not None and f"{slam.n_odometry_rejected} contradicted by the scans" in note
    est = slam.trajectory().poses
    assert np.hypot(*(est[-1, :2] - truth[-1][:2])) < 0.1  # the odometry ends 3 m ahead


def test_what_an_unseen_return_explains_is_a_share() -> None:
    with pytest.raises(ValueError, match="unseen_explains"):
        MotionConfig(unseen_explains=1.5)
