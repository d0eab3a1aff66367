"""The whole log as one pose graph, solved once the run is over: every filter update linked to its neighbours and
to the other updates that see the same place by what their scans measure of each other, and by the odometry.

Online, the loop closer's graph (:mod:`mcnkit.slam.loops`) links the filter updates by the filter's own steps plus
the loop matches it found while driving.  Where a corridor pins nothing along its axis, the steps there say less
than they claim, and a loop's misfit lands on whichever stretch costs least: seeds of one long corridor log end
metres apart, each consistent with its scans.  Once the log is over, :func:`whole_log_graph` builds the graph that
every scan supports:

- **scan-to-scan edges** between each node and the next ``steps`` nodes, and between nodes that see one place
  (*revisits*: within ``revisit_m`` and ``revisit_rad`` of each other, at least ``revisit_path_m`` of driving
  apart: two passes through it, or two nodes of one pass beyond the next ``steps``; matched only with their
  neighbours, the nodes' headings wander a few tenths of a degree from pair to pair, adding up over a loop).
  Scan ``j`` is found on scan ``i`` around their current relative pose by a correlative search on ``i``'s
  likelihood field, then laid onto ``i``'s outline by point-to-line ICP: a grid's cells place a wall to
  a few tenths of a degree per pair, the outline's lines to a few hundredths.  Only the returns of ``j`` that
  scan ``i`` saw take part (a return of ``i`` in that direction at least as far, and its neighbours too): the
  part of a wall that ``j`` sees beyond ``i``'s view has nothing to land on.  The edge carries the fit's own
  information, without its weaker translation direction where that is pinned less than ``min_pinned`` times as
  well as the stronger one (along a corridor's axis: there the step's length is the odometry's to say).
- **odometry edges** between consecutive nodes whose motion the odometry gave, with its stated precision.
- **filter-step edges** where no odometry edge is (a lidar-only log, a gap, an odometry edge dropped below): the
  filter's own step with the online graph's step precision, so that nothing is left free.

Scan-to-scan and odometry edges are robust (Huber).  After a solution, every revisit or odometry edge whose error
exceeds ``max_chi2`` is dropped and the graph solved again: a revisit matched around a wrong estimate is wrong with
it, and odometry can contradict the scans (a wheel that slipped, a robot that backed up while its odometry counted
forward).  Each kind of edge then gets the precision its errors at the solution show (``calibrate``), and the graph
is solved once more.  The revisits are found again around each solution, ``passes`` times in all (a pass that was
metres off finds its partners only then).  The nodes are the filter updates; the scans between two updates keep
their offset from the update before them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from mcnkit.geometry import compose, inverse, relative, wrap_angle
from mcnkit.slam.config import OfflineConfig
from mcnkit.slam.correlative import LikelihoodGrid, likelihood_grid, match_scan
from mcnkit.slam.posegraph import Edges, edge_errors, optimize
from mcnkit.slam.proposal import cap_information
from mcnkit.slam.scanrelations import outline

__all__ = ["WholeGraphScans", "WholeGraphStats", "odometry_links", "revisit_pairs_by_path", "whole_log_graph"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


@dataclass(frozen=True)
class WholeGraphScans:
    """The nodes' scans: ranges (N, B) in metres (NaN: no return), the beams' angles (B,), the scanner's mount and
    the range up to which returns are used."""

    ranges_m: Sequence[NDArray[np.floating]]
    angles_rad: F64
    base_to_laser: F64
    max_range_m: float

    def returns(self, k: int) -> F64:
        """Scan ``k``'s returns (M, 2) in the base frame, in beam order."""
        r = np.asarray(self.ranges_m[k], np.float64)
        with np.errstate(invalid="ignore"):
            use = np.isfinite(r) & (r > 0) & (r < self.max_range_m)
        a = self.angles_rad[use]
        local = np.column_stack([r[use] * np.cos(a), r[use] * np.sin(a), np.zeros(int(use.sum()))])
        return compose(self.base_to_laser, local)[:, :2]


@dataclass
class WholeGraphStats:
    """What the last solution used: nodes, edges of each kind (after the dropped ones) and the passes made."""

    nodes: int = 0
    step_edges: int = 0
    """Between neighbouring nodes (scan-to-scan)."""
    revisit_edges: int = 0
    """Between two passes through one place (scan-to-scan)."""
    odometry_edges: int = 0
    filter_step_edges: int = 0
    """Where no odometry edge is."""
    passes: int = 0


def odometry_links(nodes: I64, odometry_gave: NDArray[np.bool_]) -> NDArray[np.bool_]:
    """(K - 1,) True where the odometry gave every step from node ``k`` to node ``k + 1``: ``nodes`` (K,) are scan
    indices, ``odometry_gave`` (N,) says of each scan whether the odometry gave the motion from the scan before."""
    nodes = np.asarray(nodes, np.int64)
    missing_before = np.r_[0, np.cumsum(~np.asarray(odometry_gave, bool))]
    out: NDArray[np.bool_] = missing_before[nodes[1:] + 1] - missing_before[nodes[:-1] + 1] == 0
    return out


def revisit_pairs_by_path(poses: F64, path_m: F64, distance_m: float, turn_rad: float, min_path_m: float,
                          bin_nodes: int) -> I64:
    """Pairs ``(i, j)`` (K, 2), ``i < j``, of nodes within ``distance_m`` and ``turn_rad`` of each other whose path
    lengths ``path_m`` (N,) differ by at least ``min_path_m``: one place on two passes.  One pair is kept per
    ``bin_nodes`` × ``bin_nodes`` block of ``(i, j)`` (two passes side by side would otherwise give hundreds of
    near-identical pairs)."""
    poses = np.asarray(poses, np.float64)
    if len(poses) < 2:
        return np.zeros((0, 2), np.int64)
    pairs = cKDTree(poses[:, :2]).query_pairs(distance_m, output_type="ndarray").astype(np.int64)
    if len(pairs) == 0:
        return pairs.reshape(0, 2)
    pairs = np.sort(pairs, axis=1)
    i, j = pairs[:, 0], pairs[:, 1]
    keep = (path_m[j] - path_m[i] >= min_path_m) & (np.abs(wrap_angle(poses[j, 2] - poses[i, 2])) < turn_rad)
    pairs = pairs[keep]
    pairs = pairs[np.lexsort((pairs[:, 1], pairs[:, 0]))]
    _, first = np.unique((pairs[:, 0] // bin_nodes) * (len(poses) + 1) + pairs[:, 1] // bin_nodes, return_index=True)
    return pairs[np.sort(first)]


def _seen_by(scans: WholeGraphScans, i: int, points_base_i: F64, margin_m: float, free_m: float = 0.3,
             ) -> NDArray[np.bool_]:
    """Which points (M, 2), in the base frame of node ``i``, scan ``i`` saw: its beam towards each has a return no
    nearer than the point (less ``free_m``: not hidden behind something), and so do the beams within ``margin_m``
    of it on either side (the surface goes on past it in ``i``'s view)."""
    r = np.asarray(scans.ranges_m[i], np.float64)
    n = len(r)
    with np.errstate(invalid="ignore"):
        hit = np.isfinite(r) & (r > 0) & (r < scans.max_range_m)
    q = compose(inverse(scans.base_to_laser), np.column_stack([points_base_i, np.zeros(len(points_base_i))]))
    dist = np.hypot(q[:, 0], q[:, 1])
    a0, inc = float(scans.angles_rad[0]), float(scans.angles_rad[1] - scans.angles_rad[0])
    k = np.round(wrap_angle(np.arctan2(q[:, 1], q[:, 0]) - a0) / inc).astype(np.int64)
    m = np.ceil(margin_m / np.maximum(dist, 0.5) / abs(inc)).astype(np.int64)
    if abs(inc) * n >= 2 * math.pi - 1.5 * abs(inc):  # a 360° scanner: beam indices wrap round
        k %= n
        prefix = np.r_[0, np.cumsum(np.concatenate([hit, hit, hit]))]
        count = prefix[k + m + n + 1] - prefix[k - m + n]
        inside = m < n // 2
    else:
        k = np.where(k < 0, k + int(round(2 * math.pi / abs(inc))), k)  # bearings behind the scanner: out of range
        inside = (k - m >= 0) & (k + m < n)
        prefix = np.r_[0, np.cumsum(hit)]
        count = np.where(inside, prefix[np.clip(k + m + 1, 0, n)] - prefix[np.clip(k - m, 0, n)], 0)
    reached = np.nan_to_num(r[np.clip(k, 0, n - 1)], nan=0.0) >= dist - free_m
    return inside & (count == 2 * m + 1) & reached


def _surface(points: F64, radius_m: float = 0.5, k: int = 24, flatness: float = 0.05,
             ) -> tuple[cKDTree, F64, NDArray[np.bool_]]:
    """The outline (M, 2) of a scan as a surface: a tree of its points, each point's normal (M, 2) from its ``k``
    nearest neighbours within ``radius_m`` (the direction they spread least in), and whether they lie on a line
    (the spread across under ``flatness`` times the spread along: a corner or clutter has no normal)."""
    tree = cKDTree(points)
    dist, idx = tree.query(points, k=min(k, len(points)), distance_upper_bound=radius_m)
    near = np.isfinite(dist)
    idx = np.where(near, idx, np.arange(len(points))[:, None])
    weight = near.astype(np.float64)
    count = weight.sum(axis=1)
    mean = (points[idx] * weight[..., None]).sum(axis=1) / count[:, None]
    spread = (points[idx] - mean[:, None, :]) * weight[..., None]
    cov = np.einsum("nki,nkj->nij", spread, spread) / count[:, None, None]
    vals, vecs = np.linalg.eigh(cov)
    return tree, vecs[:, :, 0], (count >= 3) & (vals[:, 0] < flatness * vals[:, 1])


def _point_to_line(surface: tuple[cKDTree, F64, NDArray[np.bool_]], target: F64, points: F64, start: F64,
                   config: OfflineConfig, iterations: int = 20) -> tuple[F64, F64] | None:
    """The pose (3,) that lays ``points`` (M, 2) onto the surface of ``target`` (its tree, normals and flat points:
    :func:`_surface`), by Gauss-Newton on the points' distances to the surface's tangent lines from ``start``
    (point-to-line ICP, Huber-weighted beyond ``icp_huber_m``; partners farther than the shrinking search radius
    are left out), and its information (3, 3); None when fewer than 10 points find a partner."""
    tree, normals, flat = surface
    pose = np.asarray(start, np.float64).copy()
    reach = config.window_m
    hess = np.zeros((3, 3))
    used = 0
    for it in range(iterations):
        c, s = math.cos(pose[2]), math.sin(pose[2])
        q = np.column_stack([pose[0] + c * points[:, 0] - s * points[:, 1],
                             pose[1] + s * points[:, 0] + c * points[:, 1]])
        dist, idx = tree.query(q, distance_upper_bound=max(config.icp_reach_m, reach * (1 - 2 * it / iterations)))
        ok = np.isfinite(dist)
        ok[ok] = flat[idx[ok]]
        used = int(ok.sum())
        if used < 10:
            return None
        n, q = normals[idx[ok]], q[ok]
        r = np.einsum("ij,ij->i", n, q - target[idx[ok]])
        jac = np.column_stack([n[:, 0], n[:, 1], n[:, 1] * (q[:, 0] - pose[0]) - n[:, 0] * (q[:, 1] - pose[1])])
        w = np.where(np.abs(r) < config.icp_huber_m, 1.0, config.icp_huber_m / np.maximum(np.abs(r), 1e-12))
        hess = jac.T @ (w[:, None] * jac)
        step = -np.linalg.solve(hess + (1e-6 * np.trace(hess) + 1e-12) * np.eye(3), jac.T @ (w * r))
        pose += step
        if np.abs(step).max() < 1e-6:
            break
    pose[2] = wrap_angle(pose[2])
    return pose, hess * (config.beams / used) / config.icp_sigma_m**2


def _unpinned_dropped(info: F64, min_pinned: float) -> F64:
    """``info`` (3, 3) without its weaker translation direction when that direction is pinned less than
    ``min_pinned`` times as well as the stronger one: along a corridor's axis a fit's information is made of the
    noise of the walls' normals and the ends of door frames seen edge-on, and states a precision the match does not
    have (the step's length there is the odometry's to say)."""
    vals, vecs = np.linalg.eigh(info[:2, :2])
    if vals[1] <= 0 or vals[0] >= min_pinned * vals[1]:
        return info
    rot = np.eye(3)
    rot[:2, :2] = vecs  # columns: the weak direction, the strong one
    turned = rot.T @ info @ rot
    turned[0, :] = 0.0
    turned[:, 0] = 0.0
    out: F64 = rot @ turned @ rot.T
    return out


def _match(scans: WholeGraphScans, returns: Sequence[F64], pairs: I64, poses: F64, window_m: float,
           config: OfflineConfig) -> Edges:
    """Scan-to-scan edges for ``pairs`` (K, 2): scan ``j`` laid onto scan ``i`` around their relative pose in
    ``poses``, first by a correlative search within ``window_m`` on ``i``'s likelihood field (a pair whose best pose
    there scores below ``min_score`` gives no edge), then by point-to-line ICP onto ``i``'s outline (a grid's
    cells place a wall to a few tenths of a degree per pair, the outline's lines to a few hundredths)."""
    cap = np.array([1.0 / config.cap_sigma_m**2] * 2 + [1.0 / config.cap_sigma_rad**2])
    rows: list[tuple[int, int, F64, F64]] = []
    surfaces: dict[int, tuple[F64, tuple[cKDTree, F64, NDArray[np.bool_]], LikelihoodGrid]] = {}  # i's outline
    for i, j in np.asarray(pairs, np.int64).reshape(-1, 2):
        a, b = returns[i], returns[j]
        if len(a) < 10 or len(b) < 10:
            continue
        centre = relative(poses[i], poses[j])
        b = b[_seen_by(scans, int(i), compose(centre, np.column_stack([b, np.zeros(len(b))]))[:, :2], window_m)]
        if len(b) < 10:
            continue
        if int(i) not in surfaces:  # the pairs come sorted by i: a few scans' outlines at a time
            if len(surfaces) > 4:
                surfaces.clear()
            target = outline(a, config.resolution_m, 0.15)
            surfaces[int(i)] = (target, _surface(target),
                                likelihood_grid(target, config.resolution_m, config.sigma_m, window_m + 1.0))
        target, surface, grid = surfaces[int(i)]
        found = match_scan(grid, b, centre, window_m, config.window_rad)
        if found.score < config.min_score:
            continue
        fine = _point_to_line(surface, target, b, found.pose, config)
        if fine is None or np.hypot(*(fine[0][:2] - found.pose[:2])) > window_m or \
                abs(wrap_angle(fine[0][2] - found.pose[2])) > config.window_rad:
            continue
        # the fit's information is about j's pose in i's frame; an edge's error is in the frame of its measurement
        turn = np.eye(3)
        c, s = math.cos(fine[0][2]), math.sin(fine[0][2])
        turn[:2, :2] = [[c, -s], [s, c]]
        info = turn.T @ _unpinned_dropped(fine[1], config.min_pinned) @ turn
        rows.append((int(i), int(j), fine[0], cap_information(info, cap)))
    n = len(rows)
    return Edges(np.array([r[0] for r in rows], np.int64).reshape(n),
                 np.array([r[1] for r in rows], np.int64).reshape(n),
                 np.array([r[2] for r in rows], np.float64).reshape(n, 3),
                 np.array([r[3] for r in rows], np.float64).reshape(n, 3, 3), np.ones(n, bool))


def _steps(poses: F64, links: NDArray[np.bool_], sigma_m: float, sigma_per_m: float, sigma_rad: float,
           sigma_rad_per_m: float, sigma_rad_per_rad: float, robust: bool = False) -> Edges:
    """Edges ``k -> k + 1`` for every ``k`` with ``links[k]``: the step between ``poses`` (N, 3), stated as precise
    as ``sigma_m + sigma_per_m · length`` in translation, ``sigma_rad + sigma_rad_per_m · length +
    sigma_rad_per_rad · turn`` in heading."""
    k = np.flatnonzero(links)
    z = relative(poses[k], poses[k + 1])
    length, turn = np.hypot(z[:, 0], z[:, 1]), np.abs(z[:, 2])
    sxy = sigma_m + sigma_per_m * length
    sth = sigma_rad + sigma_rad_per_m * length + sigma_rad_per_rad * turn
    info = np.zeros((len(k), 3, 3))
    info[:, 0, 0] = info[:, 1, 1] = 1.0 / sxy**2
    info[:, 2, 2] = 1.0 / sth**2
    return Edges(k, k + 1, z, info, np.full(len(k), robust))


def _chi2(poses: F64, edges: Edges) -> F64:
    """Each edge's squared Mahalanobis error (E,) at ``poses``."""
    err = edge_errors(poses, edges)
    out: F64 = np.einsum("na,nab,nb->n", err, edges.info, err)
    return out


def _calibrated(solved: F64, *kinds: Edges) -> list[Edges]:
    """Each kind of edge with its information scaled so that its mean squared Mahalanobis error at ``solved`` is
    its degrees of freedom (variance component estimation; each edge's error counted up to 3 standard deviations
    per degree of freedom): a kind stated more precise than its measurements turn out to be is loosened, one stated
    too loose is tightened."""
    out = []
    for e in kinds:
        if len(e) == 0:
            out.append(e)
            continue
        dof = np.linalg.matrix_rank(e.info, tol=1e-9 * float(np.abs(e.info).max())).astype(np.float64)
        factor = float(dof.sum() / max(np.minimum(_chi2(solved, e), 9.0 * dof).sum(), 1e-12))
        out.append(Edges(e.i, e.j, e.z, e.info * factor, e.robust))
    return out


def whole_log_graph(poses: F64, scans: WholeGraphScans, odom: F64, odom_links: NDArray[np.bool_],
                    config: OfflineConfig) -> tuple[F64, WholeGraphStats]:
    """The nodes' poses (N, 3) re-solved as one graph over the whole log (see the module), and what it used.

    Args:
        poses: the run's pose at every node (the filter updates), the starting point.
        scans: the nodes' scans.
        odom: the odometry pose at every node (N, 3).
        odom_links: (N - 1,) True where the odometry gave the motion from node ``k`` to ``k + 1``.
        config: the graph's settings.
    """
    poses = np.asarray(poses, np.float64)
    n = len(poses)
    stats = WholeGraphStats(nodes=n)
    if n < 3:
        return poses.copy(), stats
    returns = [scans.returns(k) for k in range(n)]
    odom_links = np.asarray(odom_links, bool)
    odometry = _steps(odom, odom_links, config.odom_sigma_m, config.odom_sigma_per_m, config.odom_sigma_rad,
                      config.odom_sigma_rad_per_m, config.odom_sigma_rad_per_rad, robust=True)
    filter_steps = _steps(poses, np.ones(n - 1, bool), config.step_sigma_m, config.step_sigma_per_m,
                          config.step_sigma_rad, config.step_sigma_rad_per_m, config.step_sigma_rad_per_rad)
    near = np.concatenate([np.column_stack([np.arange(n - s), np.arange(s, n)]) for s in range(1, config.steps + 1)
                           if s < n]).astype(np.int64)
    near = near[np.lexsort((near[:, 1], near[:, 0]))]  # by i: each outline built once
    step_edges = _match(scans, returns, near, poses, config.window_m, config)
    stats.step_edges = len(step_edges)
    moved = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    path = np.r_[0.0, np.cumsum(moved)]
    solved = poses
    for p in range(config.passes):
        pairs = revisit_pairs_by_path(solved, path, config.revisit_m, config.revisit_rad, config.revisit_path_m,
                                      config.revisit_bin)
        revisits = _match(scans, returns, pairs, solved, config.revisit_window_m, config)
        start, trusted = solved, odometry
        while True:  # a revisit matched around a wrong estimate, or odometry the scans contradict (a wheel that
            # slipped, a robot that backed up while its odometry counted forward): the other edges say so
            unlinked = np.ones(n - 1, bool)
            unlinked[trusted.i] = False  # the filter's own step stands in where no odometry is trusted
            solved = optimize(start, Edges.concat([trusted, filter_steps.subset(unlinked), step_edges, revisits]),
                              iterations=config.iterations, huber=config.huber, tolerance=1e-5)
            wrong = [_chi2(solved, e) > config.max_chi2 for e in (trusted, revisits)]
            if not any(w.any() for w in wrong):
                break
            trusted, revisits = trusted.subset(~wrong[0]), revisits.subset(~wrong[1])
        if config.calibrate:
            trusted, stand_ins, step_edges, revisits = _calibrated(solved, trusted, filter_steps.subset(unlinked),
                                                                    step_edges, revisits)
            solved = optimize(solved, Edges.concat([trusted, stand_ins, step_edges, revisits]),
                              iterations=config.iterations, huber=config.huber, tolerance=1e-5)
        stats.filter_step_edges = int(unlinked.sum())
        stats.odometry_edges = len(trusted)
        stats.revisit_edges = len(revisits)
        stats.passes = p + 1
    return solved, stats
