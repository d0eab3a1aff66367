"""Catching odometry that is far off: a wide branch-and-bound search before the particles' hill climbing.

gmapping's proposal hill-climbs each particle from its odometry-predicted pose: it recovers errors of a few
centimetres and degrees, which is what the motion model spreads the particles over.  Real logs hold worse:
wheels that slip, a robot pushed, odometry that says *forward* while the scans show the robot backing up
(FR079, around scan 840: 1.3 m off within ten scans), or 10-15° heading errors between two kept scans of a
sparse log.  Then every particle starts outside the matcher's basin and the map tears.

:func:`wide_match` searches the best particle's map around its predicted pose over a window that grows with
the odometry step (:class:`~mcnkit.slam.SlamConfig` ``wide_*`` fields), exactly, by branch and bound on a coarse
likelihood field (:mod:`mcnkit.slam.correlative`).  It proposes a jump only when the wide optimum explains the
scan clearly better than the best pose near the prediction (``wide_jump_ratio``): where both explain it about
equally well — along a corridor, whose walls fit anywhere along its axis — the odometry keeps the say; and it
looks wide at all only when the region the motion model allows explains little of the scan (``wide_max_near_score``):
a scan that fits where the odometry put it is never moved to a look-alike place farther away.

:func:`unknown_motion_match` finds a scan's pose where no odometry gives its motion (``Frame.odom_known`` False,
or the odometry ignored): the most probable under the match and the motion prior's prediction
(:mod:`mcnkit.slam.scanmotion`), over any turn.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, relative
from mcnkit.slam.config import SlamConfig
from mcnkit.slam.correlative import LikelihoodGrid, angular_step, likelihood_grid, match_scan, thin_points, with_unseen
from mcnkit.slam.lineage import LineageMap
from mcnkit.slam.maps import TiledHitMaps
from mcnkit.slam.scanmotion import MotionGuess, outlier_share

__all__ = ["seen_grid", "tracking_grid", "unknown_motion_match", "wide_match", "wide_window"]

F64 = NDArray[np.float64]


def wide_window(config: SlamConfig, step_m: float, turn_rad: float) -> tuple[float, float]:
    """The search window (± metres, ± radians) after an odometry step of ``step_m`` and ``turn_rad``."""
    xy = min(config.wide.max_window_m, config.wide.window_m + config.wide.window_per_m * step_m)
    rad = min(
        config.wide.max_window_rad,
        config.wide.window_rad + config.wide.window_rad_per_m * step_m + config.wide.window_rad_per_rad * turn_rad,
    )
    return xy, rad


def tracking_grid(maps: TiledHitMaps, particle: int, center: F64, config: SlamConfig) -> LikelihoodGrid | None:
    """The coarse likelihood field of a particle's map around ``center`` (3,), for the wide searches until the
    next update (the maps change only at updates); None while the map holds too few hits."""
    reach = config.loops.map_radius_m + config.wide.max_window_m + 2.0
    x, y = float(center[0]), float(center[1])
    pts = maps.hit_points(particle, x - reach, y - reach, x + reach, y + reach)
    if len(pts) < 20:
        return None
    return likelihood_grid(pts, config.wide.resolution_m, config.wide.sigma_m, config.wide.resolution_m, depth=5)


def _search_points(points_base: F64, cell_m: float, config: SlamConfig) -> F64 | None:
    """The scan's hit points (M, 2) the wide searches use: one per field cell, within the local map's radius;
    None when fewer than 20 are left (too little to place the scan by)."""
    scan = thin_points(points_base, cell_m)
    scan = scan[np.hypot(scan[:, 0], scan[:, 1]) <= config.loops.map_radius_m]
    return scan if len(scan) >= 20 else None


def wide_match(
    grid: LikelihoodGrid, nominal: F64, points_base: F64, config: SlamConfig, motion_sigma: F64, step_m: float,
    turn_rad: float,
) -> tuple[F64, bool] | None:
    """The mode of the scan's likelihood around an odometry prediction ``nominal`` (3,).

    Searches the motion model's 3σ region (``motion_sigma`` = [σx, σy, σθ]) and the wide window; returns the
    wide optimum and True when it explains the scan's hit points (M, 2) clearly better than the best pose of the
    3σ region (a jump), else that best pose and False; None when the map explains the scan too poorly.
    """
    res = grid.resolution_m
    scan = _search_points(points_base, res, config)
    if scan is None:
        return None
    win_xy, win_rad = wide_window(config, step_m, turn_rad)
    near_xy = min(max(3.0 * float(max(motion_sigma[0], motion_sigma[1])), 2 * res), win_xy)
    near_rad = min(max(3.0 * float(motion_sigma[2]), math.radians(2.0)), win_rad)
    near = match_scan(grid, scan, nominal, near_xy, near_rad)
    if near.score <= 0:
        return None
    if near.score < config.wide.max_near_score:  # the prediction cannot explain the scan: look wider
        wide = match_scan(grid, scan, nominal, win_xy, win_rad, min_score=near.score / config.wide.jump_ratio)
        if wide.score > 0 and wide.score >= config.wide.min_score:
            return wide.pose, True
    if near.score < config.wide.min_score:
        return None
    return near.pose, False


def seen_grid(grid: LikelihoodGrid, seen: LineageMap, unseen_explains: float) -> LikelihoodGrid:
    """``grid`` with the cells that no scan of ``seen`` (the same particle's map as ray-cast counts, on cells of the
    grid's size) has passed through or ended in explaining ``unseen_explains``
    (:func:`mcnkit.slam.correlative.with_unseen`); ``grid`` itself when that is 0."""
    if unseen_explains <= 0.0:
        return grid
    res = grid.resolution_m
    if not math.isclose(seen.resolution_m, res):
        raise ValueError(f"the seen map's cells ({seen.resolution_m} m) are not the grid's ({res} m)")
    h, w = grid.shape
    mask = np.zeros((h, w), bool)
    sh, sw = seen.hits.shape
    # grid cell (row, col) is seen cell (row + dy, col + dx)
    dx = int(round(grid.origin_x_m / res)) - seen.ix0
    dy = int(round(grid.origin_y_m / res)) - seen.iy0
    r0, r1 = max(0, -dy), min(h, sh - dy)
    c0, c1 = max(0, -dx), min(w, sw - dx)
    if r0 < r1 and c0 < c1:
        rows, cols = slice(r0 + dy, r1 + dy), slice(c0 + dx, c1 + dx)
        mask[r0:r1, c0:c1] = (seen.hits[rows, cols] > 0) | (seen.passes[rows, cols] > 0)
    return with_unseen(grid, mask, unseen_explains)


def unknown_motion_match(grid: LikelihoodGrid, before: F64, guess: MotionGuess, reach: tuple[float, float],
                         points_base: F64, config: SlamConfig, density: bool = True) -> F64 | None:
    """The scan's most probable pose when no odometry gives its motion: the scan's match times the motion prior.

    ``before`` (3,) is the robot's pose at the scan before and ``guess`` what the motion prior
    (:class:`mcnkit.slam.scanmotion.MotionPrior`) says of the motion since: the robot predicted at
    ``predicted = before ⊕ guess.mean``, ``guess.sigma`` (3,; its frame) how far off that may be.  A pose scores
    ``beams · log(score) - min(d² / 2, cap)``:
    the match's mean likelihood counted as ``updates.proposal_beams`` independent beams (as the improved proposal
    counts a scan), and the squared Mahalanobis distance ``d²`` from the prediction (the prior's spread widened by
    the search lattice, a cell and an angular step: the lattice pose nearest the prediction is often a cell off, and
    a prior tighter than a cell would otherwise push it to the cap, where any look-alike pose can outscore it),
    whose penalty stops at
    ``cap = beams · log(1 / wide.jump_ratio)`` (about 3σ): the robot may change what it does at any scan, and a
    pose beyond the prior's reach wins when it explains the scan ``1 / jump_ratio`` times better, as the wide
    search lets a pose far from the odometry's prediction win.  The candidates are the best match in windows
    around the prediction, from its 3σ region halved down to a cell and a degree, and the best anywhere within
    ``reach`` (± m, ± rad) of the pose before (:meth:`mcnkit.slam.scanmotion.MotionPrior.reach`: twice the log's
    fastest motion over one scan, within ``motion.unknown_window_m`` × ``motion.unknown_window_rad``), searched
    only for a pose that could win.  So where the
    scan cannot tell poses apart (a corridor's axis, a room seen half a turn apart by a 180° scanner) the one
    nearest the prediction wins.

    With ``density`` and a guess that knows the recent steps (:class:`mcnkit.slam.scanmotion.MotionGuess`) the
    distance term is the guess's own density instead: ``log p(step) = log((1 − ε) q(step) + ε / V)``, ``q`` its
    :meth:`~mcnkit.slam.scanmotion.MotionGuess.log_density` (spreads widened by the lattice, as above), ``V`` the
    volume searched (``reach``) and ``ε`` the share of this log's steps that ``q`` did not predict
    (:func:`mcnkit.slam.scanmotion.outlier_share`); a pose's penalty is how much less probable its step is than
    the most probable one.  Windows are searched around each of the density's modes.  A pose a quarter turn from
    every kind of step the robot makes then wins only where it explains the scan as much better as the log has
    shown such steps to be rare.  None when the map explains the scan too poorly."""
    scan = _search_points(points_base, grid.resolution_m, config)
    if scan is None:
        return None
    beams = config.updates.proposal_beams
    res, floor_rad = grid.resolution_m, math.radians(1.0)
    win_xy, win_rad = reach
    predicted, sigma = compose(before, guess.mean), np.asarray(guess.sigma, np.float64)

    # the prior's spread widened by the search lattice (see the docstring)
    astep = angular_step(scan, res)  # the heading step of every search below (found once)
    lattice = np.array([res, res, astep])
    if density and len(guess.recent):
        log_u = -math.log((2.0 * win_xy) ** 2 * 2.0 * win_rad)
        eps = outlier_share(guess.log_q_recent, log_u)
        modes = guess.modes()
        most = float(np.max(guess.log_density(np.r_[modes, guess.recent], lattice)))  # the most probable step
        top = float(np.logaddexp(math.log(1.0 - eps) + most, math.log(eps) + log_u))

        def penalty(pose: F64) -> float:
            q = float(guess.log_density(relative(before, pose)[None, :], lattice)[0])
            return max(0.0, top - float(np.logaddexp(math.log(1.0 - eps) + q, math.log(eps) + log_u)))

        centres = [(compose(before, m), guess.sigma if k == 0 else guess.bandwidth) for k, m in enumerate(modes)]
    else:
        cap = beams * math.log(1.0 / config.wide.jump_ratio)
        spread = np.sqrt(sigma**2 + lattice**2)

        def penalty(pose: F64) -> float:
            d = relative(predicted, pose) / spread
            return min(0.5 * float(d @ d), cap)

        centres = [(predicted, sigma)]

    def value(pose: F64, score: float) -> float:
        return beams * math.log(score) - penalty(pose)

    best: tuple[float, F64] | None = None
    for centre, around in centres:
        xy = min(max(3.0 * float(max(around[0], around[1])), res), config.motion.unknown_window_m)
        rad = min(max(3.0 * float(around[2]), floor_rad), config.motion.unknown_window_rad)
        while True:
            # a pose wins only if it scores above exp(best value / beams) (its penalty is never negative): the
            # search skips every branch that cannot
            bar = math.exp(best[0] / beams) if best is not None else 0.0
            found = match_scan(grid, scan, centre, xy, rad, astep, min_score=bar)
            if found.score > 0 and (best is None or value(found.pose, found.score) > best[0]):
                best = (value(found.pose, found.score), found.pose)
            if xy <= res and rad <= floor_rad:
                break
            xy, rad = max(xy / 2, res), max(rad / 2, floor_rad)
    # a pose of the whole window wins only if it scores above exp(best value / beams) (its distance adds nothing)
    bar = math.exp(best[0] / beams) if best is not None else 0.0
    wide = match_scan(grid, scan, before, win_xy, win_rad, astep, min_score=bar)
    if wide.score > 0 and (best is None or value(wide.pose, wide.score) > best[0]):
        best = (value(wide.pose, wide.score), wide.pose)
    if best is None:
        return None
    peak = match_scan(grid, scan, best[1], 2 * res, 2 * floor_rad, astep)  # the top of the chosen mode, prior aside
    return peak.pose if peak.score >= config.wide.min_score else None
