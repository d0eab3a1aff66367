"""Loop closing: a pose graph over the filter updates, closed by wide correlative matches against old scans.

The particle filter keeps the map locally consistent; what it cannot do on its own is pull a long loop shut
when the error accumulated around it is larger than the particles' spread (ACES, FR079: the maps shear and
bend).  :class:`LoopCloser` keeps, for every filter update ("node"), the scan's end points and the path length
driven so far, and at each new node:

1. **Candidates**: nodes driven past more than ``loop_min_travel_m`` ago whose estimated pose lies within the
   search window (grown with the path driven since them: ``loop_window_m + loop_window_per_m · path``, capped)
   plus ``loop_reach_m``.  The nearest one and the scans around it (a *chain*: nodes within
   ``loop_chain_m`` of path from it) make a local likelihood map.
2. **Match**: the new scan is matched into that map by branch and bound over the whole window
   (:func:`mcnkit.slam.correlative.match_scan`), then refined below a cell.  A match is kept when its score
   (mean likelihood of the points) reaches ``loop_min_score`` and it is unique: the best pose found when the
   neighbourhood of the first match is excluded scores clearly lower (corridors are ambiguous along their axis).
3. **Graph**: nodes are connected by the filter's own relative poses (the best lineage's, between consecutive
   updates; weighted by the motion model and by what each update's scan match pinned down) and by the accepted
   loop matches; the graph is solved (:func:`mcnkit.slam.posegraph.optimize`) when a new loop match disagrees
   with the current estimate by more than its precision says (``loop_solve_chi2``).  A loop edge whose error
   after the solution stays far beyond its stated precision is an outlier: it is dropped and the graph solved
   again.

The corrected poses go back to the filter, which rebuilds its particles' maps on them (see
:meth:`mcnkit.slam.FastSlam`).

Example:
    >>> closer = LoopCloser(SlamConfig(), resolution_m=0.05)  # doctest: +SKIP
    >>> corrected = closer.add(points_base, lineage_poses)      # doctest: +SKIP
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray
from scipy import sparse
from scipy.sparse import csgraph

from mcnkit.geometry import compose, relative
from mcnkit.slam.config import SlamConfig
from mcnkit.slam.correlative import LikelihoodGrid, likelihood_grid, match_scan, thin_points
from mcnkit.slam.likelihood import contradiction, free_space, overlap, refine_match
from mcnkit.slam.posegraph import Edges, edge_errors, optimize
from mcnkit.slam.proposal import cap_information, match_information

__all__ = ["LoopAttempt", "LoopCloser", "LoopStats"]

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]


@dataclass(frozen=True)
class LoopAttempt:
    """One loop match that was scored: nodes, scores, and the relative pose j -> k it would add."""

    k: int
    j: int
    score: float
    """Mean likelihood of the scan's points that land where the old scans looked."""
    contradiction: float
    z: F64
    overlap: float
    explained: float
    """Mean likelihood over all the scan's points."""
    unique: bool
    window_m: float


@dataclass
class LoopStats:
    """What the loop closer did so far."""

    attempts: int = 0
    accepted: int = 0
    rejected_score: int = 0
    rejected_ambiguous: int = 0
    rejected_border: int = 0
    rejected_contradiction: int = 0
    rejected_outlier: int = 0
    unconfirmed: int = 0
    optimizations: int = 0
    accepted_nodes: list[tuple[int, int]] = field(default_factory=list)


class LoopCloser:
    """The pose graph of one run: nodes are filter updates, edges the filter's steps and loop matches."""

    def __init__(self, config: SlamConfig, resolution_m: float) -> None:
        self.config = config
        self.resolution_m = float(resolution_m)
        self.points: list[F32] = []  # per node: thinned hit points (M, 2) in the base frame
        self.travelled_m: list[float] = []
        self.anchor = -1  # nodes up to here have frozen sequential edges (their poses were solved)
        self._seq_z = np.zeros((0, 3))  # frozen sequential measurements: node m-1 -> m, for m = 1..anchor
        self._loops: list[tuple[int, int, F64, F64]] = []  # (old node, new node, relative pose, information)
        self._pending: list[tuple[int, int, F64, F64, F64]] = []  # unconfirmed matches, + the new node's matched pose
        self.stats = LoopStats()
        self._step_info: list[F64] = []  # per node: its scan match's information (3, 3), in its own frame
        self._cap = np.array([1.0 / config.graph.loop_sigma_xy_m**2, 1.0 / config.graph.loop_sigma_xy_m**2,
                              1.0 / config.graph.loop_sigma_rad**2])  # the most any one match is said to pin down
        self.attempts: list[LoopAttempt] = []
        """Every loop match that was scored, accepted or not (for benchmarks and plots)."""

    def __len__(self) -> int:
        return len(self.points)

    def add(self, points_base: F64, lineage: F64, grid: LikelihoodGrid | None = None) -> F64 | None:
        """Adds the newest node and tries to close a loop from it.

        Args:
            points_base: the node's scan end points (M, 2), base frame (hits only).
            lineage: the best particle's poses (K, 3) at every node so far, the new one last.
            grid: the likelihood field of the map the node's scan was matched against (the best particle's, before
                this update): what the scan pins down there weights the step from the previous node
                (``SlamConfig.graph_step_match_info``); None: the motion model alone.

        Returns:
            The solved poses (K, 3) of every node when a loop match moved them, else None.
        """
        cfg = self.config
        k = len(self.points)
        if len(lineage) != k + 1:
            raise ValueError(f"lineage has {len(lineage)} poses for {k + 1} nodes")
        step = float(np.hypot(*(lineage[k, :2] - lineage[k - 1, :2]))) if k else 0.0
        self.travelled_m.append((self.travelled_m[-1] if k else 0.0) + step)
        self.points.append(thin_points(points_base, 2 * self.resolution_m).astype(np.float32))
        weigh = cfg.graph.step_match_info and cfg.loops.closure and k > 0
        self._step_info.append(self._information(grid, points_base, lineage[k], float(lineage[k, 2]))
                               if weigh and grid is not None else np.zeros((3, 3)))
        if not cfg.loops.closure or k == 0 or len(self.points[k]) < 10:
            return None
        found = self._search(k, lineage)
        if found is None:
            return None
        j, z, info = found
        err = edge_errors(lineage, Edges.of([(j, k, z)], np.eye(3)))[0]
        if float(err @ info @ err) < cfg.graph.solve_chi2:
            self._loops.append((j, k, z, info))
            self.stats.accepted += 1
            self.stats.accepted_nodes.append((j, k))
            return None  # the estimate already agrees within the match's precision: nothing to solve
        # A match that would move the map must be confirmed by another one from a nearby node that places the
        # robot consistently (a look-alike place fools one scan far more often than two).
        world = compose(lineage[j], z)
        partner = self._confirming(k, world, lineage)
        self._pending = [p for p in self._pending if k - p[1] <= cfg.loops.confirm_nodes] + [(j, k, z, info, world)]
        if partner is None:
            self.stats.unconfirmed += 1
            return None
        self._pending = [p for p in self._pending if p[1] not in (partner[1], k)]
        self._loops.append(partner[:4])
        self._loops.append((j, k, z, info))
        return self._solve(lineage, 2)

    def _confirming(self, k: int, world: F64, lineage: F64) -> tuple[int, int, F64, F64, F64] | None:
        """A pending match from one of the last ``loop_confirm_nodes`` nodes whose placement of its node agrees
        with this one's: the two matched poses are as far apart as the filter's own poses of the two nodes."""
        cfg = self.config
        for cand in reversed(self._pending):
            m = cand[1]
            if k - m > cfg.loops.confirm_nodes or m == k:
                continue
            moved_matched = relative(cand[4], world)
            moved_filter = relative(lineage[m], lineage[k])
            dist = float(np.hypot(moved_filter[0], moved_filter[1]))
            d_xy = float(np.hypot(*(moved_matched[:2] - moved_filter[:2])))
            d_th = abs((moved_matched[2] - moved_filter[2] + np.pi) % (2 * np.pi) - np.pi)
            if d_xy <= cfg.loops.confirm_m + 0.05 * dist and d_th <= cfg.loops.confirm_rad:
                return cand
        return None

    # -- search ---------------------------------------------------------------------------------------------

    def _window(self, path_m: float) -> tuple[float, float]:
        cfg = self.config
        xy = min(cfg.loops.max_window_m, cfg.loops.window_m + cfg.loops.window_per_m * path_m)
        rad = min(cfg.loops.max_window_rad, cfg.loops.window_rad + cfg.loops.window_rad_per_m * path_m)
        return xy, rad

    def _search(self, k: int, lineage: F64) -> tuple[int, F64, F64] | None:
        cfg = self.config
        travelled = np.asarray(self.travelled_m)
        path = travelled[k] - travelled
        old = np.flatnonzero(path[:k] > cfg.loops.min_travel_m)
        if len(old) == 0:
            return None
        scan = self.points[k].astype(np.float64)
        ranges = np.hypot(scan[:, 0], scan[:, 1])
        # Scans overlap when they are about as far apart as what they see: the scan's median range.
        reach = float(np.clip(np.median(ranges), cfg.loops.min_reach_m, cfg.loops.max_reach_m))
        dist = np.hypot(lineage[old, 0] - lineage[k, 0], lineage[old, 1] - lineage[k, 1])
        drift_path = self._graph_distance(k)[old]  # path through the graph: loops already closed shorten it
        windows = np.array([self._window(p)[0] for p in drift_path])
        near = dist <= windows + reach
        if not near.any():
            return None
        # One try per earlier pass through the area (a run of consecutive candidate nodes), nearest first.
        cand = old[near]
        runs = np.split(cand, np.flatnonzero(np.diff(cand) > cfg.loops.run_gap) + 1)
        nearest = [int(r[np.argmin(dist[near][np.isin(cand, r)])]) for r in runs]
        order = np.argsort([dist[np.flatnonzero(old == j)[0]] for j in nearest])
        scan = scan[ranges <= cfg.loops.map_radius_m]
        if len(scan) < 20:
            return None
        for t in order[: cfg.loops.max_tries]:
            j = nearest[t]
            drift = float(drift_path[np.flatnonzero(old == j)[0]])
            found = self._try(k, j, lineage, scan, path, travelled, drift)
            if found is not None:
                return found
        return None

    def _try(self, k: int, j: int, lineage: F64, scan: F64, path: F64, travelled: F64,
             drift_m: float, window: tuple[float, float] | None = None) -> tuple[int, F64, F64] | None:
        """Matches scan ``k`` into the map of the chain of old scans around node ``j``; the chain node nearest to
        the match, the relative pose from it to node ``k`` and the match's information (what the scan pins down:
        little along a corridor's axis, at most the stated ``loop_sigma_*`` precision in any direction)."""
        cfg = self.config
        chain = np.flatnonzero((np.abs(travelled - travelled[j]) <= cfg.loops.chain_m) & (path > cfg.loops.min_travel_m))
        world = [compose(lineage[m], np.c_[self.points[m], np.zeros(len(self.points[m]))])[:, :2] for m in chain]
        sensors = np.concatenate([np.repeat(lineage[m, None, :2], len(w), axis=0) for m, w in zip(chain, world, strict=True)])
        pts_map = np.concatenate(world)
        win_xy, win_rad = window if window is not None else self._window(drift_m)
        keep = np.hypot(pts_map[:, 0] - lineage[k, 0], pts_map[:, 1] - lineage[k, 1]) <= win_xy + cfg.loops.map_radius_m
        pts_map, sensors = pts_map[keep], sensors[keep]
        if len(pts_map) < 20:
            return None
        self.stats.attempts += 1
        grid = likelihood_grid(pts_map, self.resolution_m, cfg.loops.sigma_m, win_xy + 1.0)
        best = match_scan(grid, scan, lineage[k], win_xy, win_rad, min_score=cfg.loops.min_explained)
        if best.score <= 0:
            self.stats.rejected_score += 1
            return None
        # A real match is a peak inside the window; one on its border only says the score kept rising that way
        # (a scan overlapping the old map in part slides until more of it overlaps, or the map drifted more than
        # the window allows): the window is doubled, up to its maximum, and the match searched again.
        off = best.pose - lineage[k]
        off[2] = (off[2] + np.pi) % (2 * np.pi) - np.pi
        margin = 2 * self.resolution_m
        on_xy, on_rad = max(abs(off[0]), abs(off[1])) >= win_xy - margin, abs(off[2]) >= win_rad - math.radians(1.0)
        if on_xy or on_rad:
            wider = (min(2 * win_xy, cfg.loops.max_window_m) if on_xy else win_xy,
                     min(2 * win_rad, cfg.loops.max_window_rad) if on_rad else win_rad)
            if wider != (win_xy, win_rad):
                return self._try(k, j, lineage, scan, path, travelled, drift_m, wider)
            self.stats.rejected_border += 1
            return None
        fine = refine_match(grid, scan, best.pose, 2 * self.resolution_m)
        free = free_space(grid, sensors, pts_map, cfg.loops.free_margin_m)
        seen = overlap(grid, free, scan, fine.pose)  # the scan's points that land where the old scans looked
        score = fine.score / max(seen, 1e-9)  # mean likelihood over those points
        wrong = contradiction(grid, free, scan, fine.pose, math.exp(-0.5 * (cfg.loops.free_margin_m / cfg.loops.sigma_m) ** 2))
        unique = self._unique(grid, scan, lineage[k], best.pose, best.score, win_xy, win_rad)
        self.attempts.append(LoopAttempt(k, j, score, wrong, relative(lineage[j], fine.pose), seen, fine.score, unique,
                                         win_xy))
        if fine.score < cfg.loops.min_explained or score < cfg.loops.min_score:
            self.stats.rejected_score += 1
            return None
        if not unique:
            self.stats.rejected_ambiguous += 1
            return None
        if wrong > cfg.loops.max_contradiction:
            self.stats.rejected_contradiction += 1
            return None
        # The match ties scan k to the part of the chain map it overlaps, i.e. to the chain's scans nearest to it:
        # the edge goes to the nearest one (tying it to j would add the chain's own drift between them).
        near = chain[np.argmin(np.hypot(lineage[chain, 0] - fine.pose[0], lineage[chain, 1] - fine.pose[1]))]
        z = relative(lineage[near], fine.pose)
        return int(near), z, self._information(grid, scan, fine.pose, float(lineage[near, 2]))

    def _information(self, grid: LikelihoodGrid, scan: F64, pose: F64, frame_yaw: float) -> F64:
        """What ``scan`` (M, 2) placed at ``pose`` on ``grid`` pins down (3, 3), at most the stated ``loop_sigma_*``
        precision, turned into the frame of a node with heading ``frame_yaw`` (an edge's error is in the frame of
        its first node; the curvature is measured in the world frame)."""
        c, s = math.cos(frame_yaw), math.sin(frame_yaw)
        rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        info_world = match_information(grid, scan, pose, self.config.updates.proposal_beams)
        return cap_information(rot.T @ info_world @ rot, self._cap)

    def _graph_distance(self, k: int) -> F64:
        """Path length (K,) from node ``k`` to every node through the graph, loop edges counting as short steps:
        how far the estimate can have drifted relative to each node."""
        travelled = np.asarray(self.travelled_m)
        n = len(travelled)
        steps = np.maximum(np.diff(travelled), 1e-3)
        rows = [np.arange(n - 1)]
        cols = [np.arange(1, n)]
        weights = [steps]
        if self._loops:
            li = np.array([lp[0] for lp in self._loops])
            lj = np.array([lp[1] for lp in self._loops])
            rows.append(li)
            cols.append(lj)
            weights.append(np.full(len(li), self.config.loops.edge_length_m))
        g = sparse.coo_matrix((np.concatenate(weights), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
        return np.asarray(csgraph.dijkstra(g.tocsr(), directed=False, indices=k))

    def _unique(self, grid: LikelihoodGrid, scan: F64, center: F64, pose: F64, score: float, win_xy: float,
                win_rad: float) -> bool:
        """True when no pose farther than ``loop_ambiguity_m`` (in x or y) from the match scores within
        ``loop_ambiguity_ratio`` of it: four boxes beside the match cover the rest of the window."""
        cfg = self.config
        d = cfg.loops.ambiguity_m
        bar = score * cfg.loops.ambiguity_ratio
        ox, oy = pose[0] - center[0], pose[1] - center[1]  # the match as an offset from the centre
        w = win_xy
        boxes = (
            (-w, ox - d, -w, w),  # left of the match
            (ox + d, w, -w, w),  # right
            (ox - d, ox + d, -w, oy - d),  # below, between the two
            (ox - d, ox + d, oy + d, w),  # above
        )
        for box in boxes:
            if match_scan(grid, scan, center, box, win_rad, min_score=bar).score >= bar:
                return False
        return True

    # -- graph ------------------------------------------------------------------------------------------------

    def _edges(self, lineage: F64) -> Edges:
        cfg = self.config
        k = len(lineage)
        z = relative(lineage[:-1], lineage[1:])
        z[: len(self._seq_z)] = self._seq_z
        step = np.hypot(z[:, 0], z[:, 1])
        sxy = cfg.graph.step_sigma_m + cfg.graph.step_sigma_per_m * step
        sth = cfg.graph.step_sigma_rad + cfg.graph.step_sigma_rad_per_m * step
        info = np.zeros((k - 1, 3, 3))
        info[:, 0, 0] = info[:, 1, 1] = 1.0 / sxy**2
        info[:, 2, 2] = 1.0 / sth**2
        if self.config.graph.step_match_info:
            body = np.array(self._step_info[1:k])  # (k-1, 3, 3): node m's match, m = 1..k-1
            c, s = np.cos(z[:, 2]), np.sin(z[:, 2])
            rot = np.zeros((k - 1, 3, 3))
            rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1], rot[:, 2, 2] = c, -s, s, c, 1.0
            info = info + rot @ body @ rot.transpose(0, 2, 1)
        seq = Edges(np.arange(k - 1), np.arange(1, k), z, info, np.zeros(k - 1, bool))
        n = len(self._loops)
        loops = Edges(np.array([lp[0] for lp in self._loops], np.int64).reshape(n),
                      np.array([lp[1] for lp in self._loops], np.int64).reshape(n),
                      np.array([lp[2] for lp in self._loops], np.float64).reshape(n, 3),
                      np.array([lp[3] for lp in self._loops], np.float64).reshape(n, 3, 3), np.ones(n, bool))
        return Edges.concat([seq, loops])

    def _solve(self, lineage: F64, n_new: int) -> F64 | None:
        """Solves the graph with the ``n_new`` newest loop edges; None when the newest turned out an outlier."""
        k = len(lineage) - 1
        while True:
            edges = self._edges(lineage)
            solved = optimize(lineage, edges, iterations=10, huber=self.config.graph.loop_huber, tolerance=1e-4)
            self.stats.optimizations += 1
            n_seq = k
            err = edge_errors(solved, edges)[n_seq:]
            chi2 = np.einsum("na,nab,nb->n", err, edges.info[n_seq:], err)
            worst = int(np.argmax(chi2))
            if chi2[worst] <= self.config.graph.max_chi2:
                break
            self._loops.pop(worst)
            self.stats.rejected_outlier += 1
            if not self._loops or self._loops[-1][1] != k:  # the new match itself was the outlier
                return None
        for lp in self._loops[-n_new:]:
            if lp[1] >= k - self.config.loops.confirm_nodes:
                self.stats.accepted += 1
                self.stats.accepted_nodes.append((lp[0], lp[1]))
        self._seq_z = relative(lineage[:-1], lineage[1:]) if len(self._seq_z) == 0 else np.concatenate(
            [self._seq_z, relative(lineage[len(self._seq_z) : -1], lineage[len(self._seq_z) + 1 :])]
        )
        self.anchor = k
        return solved
