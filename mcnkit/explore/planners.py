"""The two planners and the planning step they share.

A planning step (:func:`decide`) pools the best particle's map onto the planning grid (:func:`planning_view`),
finds the frontier segments and their viewpoints, runs one Dijkstra from the robot (:mod:`mcnkit.explore.paths`),
lets the planner score the viewpoints and takes the best score (ties: the cheapest to reach) unless the planner
commits to the goal it is driving to (``ExploreConfig.commit_m``), then traces the path.

* :class:`FrontierPlanner` — the nearest reachable frontier (Yamauchi 1997): score = −path cost; it commits.
* :class:`McnPlanner` — K completions of the map (:func:`mcnkit.explore.predict.predict`), the information a scan
  from each viewpoint is expected to bring in them (:mod:`mcnkit.explore.gain`), traded against the path cost.

Both see the same map, frontiers, viewpoints and path costs; only the score differs.

Example:
    >>> view = planning_view(lineage, pose, 0.1)                                        # doctest: +SKIP
    >>> d = decide(view, FrontierPlanner(), ExploreConfig(), 0.2, np.zeros((0, 2)))       # doctest: +SKIP
    >>> d.path_m.shape                                                                  # doctest: +SKIP
    (31, 2)
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

import numpy as np
from numpy.typing import NDArray

from mcnkit.explore.config import ExploreConfig, GainConfig
from mcnkit.explore.frontiers import Frontiers, Viewpoints, find_frontiers, planning_map, viewpoints
from mcnkit.explore.gain import beyond_window_gains, expected_gains, trade_off
from mcnkit.explore.paths import CostField, cost_field
from mcnkit.explore.tour import open_tour, tour_length
from mcnkit.slam.lineage import LineageMap
from mcnkit.types import GridSpec

if TYPE_CHECKING:
    import torch

    from mcnkit.completion.nets import CompletionNet
    from mcnkit.explore.predict import Prediction

__all__ = ["Decision", "FrontierPlanner", "McnPlanner", "Planner", "PlanningView", "decide", "local_first",
           "planning_view", "regret_scores", "tour_scores"]

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]


@dataclass(frozen=True)
class PlanningView:
    """What a planner sees: the best particle's map pooled on the planning grid, the robot's estimated pose and the
    map itself (for the completions' window)."""

    grid: GridSpec
    image: F32
    """(H, W) ternary planning map (:func:`mcnkit.explore.frontiers.planning_map`)."""
    pose: F64
    """(3,) the robot's estimated pose."""
    lineage: LineageMap


def planning_view(lineage: LineageMap, pose: F64, resolution_m: float, max_cells: int | None = None) -> PlanningView:
    """The map of ``lineage`` pooled onto a grid covering what it saw and the robot, its thin unknown cells made free
    (:func:`mcnkit.explore.frontiers.planning_map`); cells of ``resolution_m``, or the smallest whole multiple of it
    that keeps the grid within ``max_cells``."""
    x0, y0, x1, y1 = lineage.seen_bounds_m()
    if max_cells is not None:
        cells = (x1 - x0 + 2 * resolution_m) * (y1 - y0 + 2 * resolution_m) / resolution_m**2
        resolution_m *= max(1, math.ceil(math.sqrt(cells / max_cells)))
    x0, x1 = min(x0, pose[0]) - resolution_m, max(x1, pose[0]) + resolution_m
    y0, y1 = min(y0, pose[1]) - resolution_m, max(y1, pose[1]) + resolution_m
    ox, oy = math.floor(x0 / resolution_m) * resolution_m, math.floor(y0 / resolution_m) * resolution_m
    grid = GridSpec(resolution_m, ox, oy, math.ceil((x1 - ox) / resolution_m), math.ceil((y1 - oy) / resolution_m))
    return PlanningView(grid, planning_map(lineage.pooled(grid)), np.asarray(pose, np.float64), lineage)


class Planner(Protocol):
    """Scores frontier viewpoints: ``(gain (V,), score (V,), prediction or None)``, higher scores first;
    ``commits``: it keeps its goal until reached (``ExploreConfig.commit_m``); ``keep_bonus``: otherwise, the share by
    which the viewpoint at its goal scores more when it chooses afresh."""

    name: str

    @property
    def commits(self) -> bool: ...

    @property
    def keep_bonus(self) -> float: ...

    def score(self, view: PlanningView, points: Viewpoints, field: CostField) -> tuple[F64, F64, Prediction | None]:
        ...


class FrontierPlanner:
    """The nearest reachable frontier: score = −path cost (no gain); the robot goes there until it is reached or
    its frontier is gone (Yamauchi 1997)."""

    name = "frontier"
    commits = True
    keep_bonus = 0.0

    def score(self, view: PlanningView, points: Viewpoints, field: CostField) -> tuple[F64, F64, Prediction | None]:
        """Zero gain, score −cost."""
        return np.zeros(len(points)), -points.cost_m, None


class McnPlanner:
    """Viewpoints scored by the information the K sampled completions expect there, against the path cost."""

    name = "mcn"

    def __init__(self, net: CompletionNet, config: GainConfig, range_m: float, generator: torch.Generator) -> None:
        self.net = net
        self.config = config
        self.range_m = float(range_m)
        self.generator = generator
        self._noise = generator.get_state()

    @property
    def commits(self) -> bool:
        """``GainConfig.commit``."""
        return self.config.commit

    @property
    def keep_bonus(self) -> float:
        """``GainConfig.keep_bonus``."""
        return self.config.keep_bonus

    def score(self, view: PlanningView, points: Viewpoints, field: CostField) -> tuple[F64, F64, Prediction | None]:
        """Expected gain (V,) [m²] and its trade-off against the path cost (V,) (``field``: the robot's path costs,
        for the ``tour`` and ``regret`` trade-offs' costs between viewpoints); the prediction it came from."""
        cfg = self.config
        pred = self.prediction(view)
        if len(points) == 0:
            return np.zeros(0), np.zeros(0), pred
        gain = self.window_gains(pred, points.xy_m)
        gain = gain + self._beyond_window(view, pred.window, points.xy_m, gain)
        if cfg.tradeoff == "tour":
            score = tour_scores(gain, points, field, cfg.tour_min_gain_m2, cfg.tour_places)
        elif cfg.tradeoff == "nearest":
            score = nearest_worth(gain, points.cost_m, cfg.tour_min_gain_m2)
        elif cfg.tradeoff == "regret":
            score = regret_scores(gain, points, field, cfg.tour_min_gain_m2, cfg.tour_places, cfg.cost_floor_m)
        else:
            score = trade_off(gain, points.cost_m, cfg.tradeoff, cfg.cost_lambda_per_m, cfg.cost_floor_m)
        if cfg.local_m > 0:
            score = local_first(score, gain, points.cost_m, cfg.local_m, cfg.tour_min_gain_m2)
        return gain, score, pred

    def window_gains(self, pred: Prediction, xy_m: F64) -> F64:
        """(V,) the gains [m²] from viewpoints ``xy_m`` (V, 2) inside the completions' window
        (:func:`mcnkit.explore.gain.expected_gains` on ``pred``'s samples)."""
        w = pred.window
        return expected_gains(pred.samples, pred.partial, w.world_to_cells_xy(xy_m), self.config,
                              self.range_m / w.resolution_m, w.resolution_m**2)

    def prediction(self, view: PlanningView) -> Prediction:
        """The completions the gains are computed on: K samples of the net on the window around the seen map
        (:func:`mcnkit.explore.predict.predict`).  A subclass may supply others: the true plan, for the bound that a
        perfect predictor would reach with the same scoring."""
        from mcnkit.explore.predict import predict

        if self.config.same_noise:
            self.generator.set_state(self._noise)
        return predict(self.net, view.lineage, self.config, self.generator, view.pose[:2])

    def _beyond_window(self, view: PlanningView, window: GridSpec, xy_m: F64, window_gains: F64) -> F64:
        """(V,) the gains beyond the completions' window (:func:`mcnkit.explore.gain.beyond_window_gains`), on a grid
        of the window's cells grown to hold the whole seen map (and, with ``GainConfig.beyond_reach``, the sensor's
        range around the window); zeros when that grid is the window."""
        res = window.resolution_m
        x0, y0, x1, y1 = view.lineage.seen_bounds_m()
        wx1, wy1 = window.origin_x_m + window.width * res, window.origin_y_m + window.height * res
        reach = math.ceil(self.range_m / res) if self.config.beyond_reach else 0  # cells around the window
        left = max(reach, math.ceil((window.origin_x_m - x0) / res))
        below = max(reach, math.ceil((window.origin_y_m - y0) / res))
        right = max(reach, math.ceil((x1 - wx1) / res))
        above = max(reach, math.ceil((y1 - wy1) / res))
        if left + below + right + above == 0:
            return np.zeros(len(xy_m))
        outer = GridSpec(res, window.origin_x_m - left * res, window.origin_y_m - below * res,
                         window.width + left + right, window.height + below + above)
        inside = np.zeros((outer.height, outer.width), bool)
        inside[below:below + window.height, left:left + window.width] = True
        origins = outer.world_to_cells_xy(xy_m)
        return beyond_window_gains(view.lineage.pooled(outer), inside, window_gains, origins, self.config.beams,
                                   self.range_m / res, res**2)


def nearest_worth(gain: F64, cost_m: F64, min_gain_m2: float) -> F64:
    """Scores (V,) that rank the viewpoints worth at least ``min_gain_m2`` by path cost, nearest first, above every
    other (also by path cost; all of them when none is worth it)."""
    cost = np.asarray(cost_m, np.float64)
    worth = np.asarray(gain) >= min_gain_m2
    return np.where(worth | ~worth.any(), -cost, -cost - (float(cost.max(initial=0.0)) + 1.0))


def local_first(score: F64, gain: F64, cost_m: F64, local_m: float, min_gain_m2: float) -> F64:
    """Scores (V,) that rank the viewpoints within ``local_m`` of path cost and at least ``min_gain_m2`` of expected
    gain above every other (in their own order of ``score``), the others as they were."""
    score = np.asarray(score, np.float64).copy()
    near = (np.asarray(cost_m) <= local_m) & (np.asarray(gain) >= min_gain_m2)
    if near.any() and not near.all():
        score[near] += float(score.max() - score[near].min()) + 1.0
    return score


def _tour_stops(gain: F64, points: Viewpoints, min_gain_m2: float, places: int) -> tuple[F64, NDArray[np.intp]]:
    """The viewpoints a tour goes through (expected gain at least ``min_gain_m2``, all when none is; the ``places``
    cheapest of them), and scores (V,) in (−1, 0] that rank every viewpoint by path cost, below any stop's score."""
    score = -np.asarray(points.cost_m, np.float64) / (1.0 + float(np.max(points.cost_m, initial=0.0)))
    worth = np.flatnonzero(gain >= min_gain_m2)
    if len(worth) == 0:
        worth = np.arange(len(gain))
    return score, worth[np.argsort(points.cost_m[worth], kind="stable")[:places]]


def regret_scores(gain: F64, points: Viewpoints, field: CostField, min_gain_m2: float, places: int,
                  cost_floor_m: float) -> F64:
    """Scores (V,): gain / (path cost + the tour's regret + ``cost_floor_m``) for the viewpoints worth a visit (as
    :func:`tour_scores` chooses them), where the regret is how much longer the shortest tour through all of them gets
    when it starts at that viewpoint (a goal that leaves a room behind costs the trip back); the others below them
    by path cost."""
    score, nodes = _tour_stops(gain, points, min_gain_m2, places)
    cost = points.cost_m[nodes]
    between = field.costs_between(points.cells[nodes])
    lengths = np.empty(len(nodes))
    for i in range(len(nodes)):
        rest = np.delete(np.arange(len(nodes)), i)
        among = between[np.ix_(rest, rest)]
        lengths[i] = cost[i] + tour_length(open_tour(between[i, rest], among), between[i, rest], among)
    regret = lengths - lengths.min()
    score[nodes] = np.maximum(gain[nodes], 1e-9) / (cost + regret + cost_floor_m)
    return score


def tour_scores(gain: F64, points: Viewpoints, field: CostField, min_gain_m2: float, places: int) -> F64:
    """Scores (V,) that rank the viewpoints worth a visit (expected gain at least ``min_gain_m2``; all when none is;
    the ``places`` cheapest of them) in the order of the shortest open tour from the robot through them
    (:func:`mcnkit.explore.tour.open_tour`; the first stop scores highest), and the others below them by path cost."""
    score, nodes = _tour_stops(gain, points, min_gain_m2, places)
    order = open_tour(points.cost_m[nodes], field.costs_between(points.cells[nodes]))
    score[nodes[order]] = np.arange(len(order), 0, -1, dtype=np.float64)
    return score


@dataclass(frozen=True)
class Decision:
    """One planning step: the frontiers, their viewpoints and scores, the choice and its path."""

    map_image: F32
    """(H, W) the planning map it planned on (on ``frontiers.grid``)."""
    frontiers: Frontiers
    points: Viewpoints
    field: CostField
    gain: F64
    """(V,) expected gain of each viewpoint [m²] (zeros for the frontier planner)."""
    score: F64
    """(V,) the planner's score (higher is better)."""
    choice: int | None
    """Index of the chosen viewpoint; None when no frontier is reachable (exploration is over)."""
    path_m: F64 | None
    """(P, 2) path from the robot to the goal [m]."""
    prediction: Prediction | None = None
    cpu_s: float = 0.0
    """CPU time of the step (map pooling, frontiers, Dijkstra, completions, gains, path) [s]."""
    kept: bool = False
    """True when the choice is the goal the robot was already driving to (``ExploreConfig.commit_m``)."""

    @property
    def goal_xy_m(self) -> F64 | None:
        """The chosen viewpoint [m], or None."""
        return None if self.choice is None else self.points.xy_m[self.choice]


def decide(view: PlanningView, planner: Planner, config: ExploreConfig, robot_radius_m: float,
           blacklist_xy_m: F64, goal_xy_m: F64 | None = None, keep_goal: bool = False) -> Decision:
    """One planning step (see the module docstring); paths keep ``robot_radius_m + config.plan_margin_m`` from the
    map's walls, or only the radius when that leaves no frontier within reach (a door the map draws narrower than it
    is, a robot that drifted close to a wall), and then with the cells under the robot free (a map that pinches the
    corridor the robot stands in).  With the current ``goal_xy_m`` and a planner that commits, the
    viewpoint nearest to it is kept when within ``config.commit_m`` (the planner still scores them all); with a
    planner's ``keep_bonus``, it is kept unless another scores that share more; ``keep_goal`` keeps it as a
    committing planner's is kept, whatever the planner (a goal the robot came back to, ``keep_returned``)."""
    t0 = time.process_time()
    frontiers = find_frontiers(view.image, view.grid, config)
    # no frontier within reach: squeeze through with no margin, then with the robot's own footprint free
    for margin, footprint in ((config.plan_margin_m, False), (0.0, False), (0.0, True)):
        field_ = cost_field(view.image, view.grid, view.pose[:2], robot_radius_m, margin, footprint)
        points = viewpoints(frontiers, field_, config, blacklist_xy_m)
        if len(points) or frontiers.n_segments == 0:
            break
    gain, score, pred = planner.score(view, points, field_)
    choice = None
    path = None
    kept = False
    if len(points):
        # best score; among equal scores the cheapest (points are sorted by cost, argmax takes the first)
        choice = int(np.argmax(score))
        if goal_xy_m is not None and config.commit_m > 0 and (planner.commits or keep_goal or planner.keep_bonus > 0):
            d = np.hypot(*(points.xy_m - goal_xy_m).T)
            at_goal = int(np.argmin(d))
            if d[at_goal] <= config.commit_m:
                empty = config.release_empty and gain[at_goal] <= 0
                if planner.commits or (keep_goal and not empty):
                    choice, kept = at_goal, True
                elif score[at_goal] + planner.keep_bonus * abs(score[at_goal]) >= score[choice]:
                    choice, kept = at_goal, True
        path = field_.path_to(points.cells[choice])
    return Decision(view.image, frontiers, points, field_, gain, score, choice, path, pred, time.process_time() - t0,
                    kept)
