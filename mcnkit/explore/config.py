"""Exploration settings (:class:`ExploreConfig`, :class:`GainConfig`), apart from the algorithms so that the command
line can generate its ``--explore.FIELD`` / ``--gain.FIELD`` flags without importing numba or torch."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, get_args

from mcnkit.grid import SEEN_WINDOW_M

__all__ = ["PLANNERS", "ExploreConfig", "GainConfig", "GainKind", "PlannerName", "TradeOff"]

PlannerName = Literal["frontier", "mcn"]
PLANNERS: tuple[PlannerName, ...] = ("frontier", "mcn")
"""``frontier``: the nearest reachable frontier (Yamauchi 1997); ``mcn``: frontiers scored by the information the
K sampled completions expect there, against the path cost."""


GainKind = Literal["unknown", "disagreement", "observed", "consensus", "open", "free"]
TradeOff = Literal["ratio", "exp", "tour", "regret", "nearest"]


@dataclass(frozen=True)
class ExploreConfig:
    """The closed loop shared by every planner: when to plan, what a frontier is, when to stop."""

    budget_m: float = 120.0
    """Path budget: the run stops once the robot has driven this far [m]."""
    start_m: tuple[float, ...] = ()
    """Where the robot starts: ``X Y`` or ``X Y YAW_DEG`` in the plan's frame (a map_server YAML's origin applies)
    [m, °]; empty: a random place in the largest region the robot fits in, and a random heading (both by the
    seed)."""
    stop_coverage: float = 1.0
    """The run also stops once this share of the reachable free space is observed (1: only when no reachable
    frontier is left or the budget is spent)."""
    replan_m: float = 1.0
    """A new plan (goal and path) every time the robot has driven this far, and whenever it reached its goal [m]."""
    plan_resolution_m: float = 0.05
    """Cell size of the planning grid, the SLAM map pooled on it (occupied > free > unknown) [m]."""
    plan_max_cells: int = 400_000
    """A map with more cells than this at ``plan_resolution_m`` is planned on coarser cells (a whole multiple), so
    a planning step stays fast in a large building."""
    plan_margin_m: float = 0.05
    """Paths keep the robot radius plus this from the SLAM map's walls (less than the simulator's margin, which
    defines the reachable space: a map's walls come out a little thicker than the true ones) [m]."""
    frontier_min_m: float = 0.5
    """Frontier clusters (8-connected free cells next to unknown space) shorter than this are ignored [m]."""
    unknown_min_m2: float = 0.25
    """Unknown regions smaller than this (holes between beams) make no frontier [m²]."""
    segment_m: float = 2.0
    """Long frontiers are cut into pieces of at most this side, each with its own viewpoint [m]."""
    reach_m: float = 0.6
    """A frontier's viewpoint is the reachable cell nearest to it, at most this far from it [m]."""
    goal_tolerance_m: float = 0.3
    """The goal is reached within this distance [m]."""
    commit_m: float = 1.0
    """A planner that commits to its goal (the frontier planner; the mcn planner with --gain.commit) keeps it while
    a frontier viewpoint remains within this distance of it, until it is reached or given up, as Yamauchi's robot
    goes to its frontier; 0: every planner chooses afresh at every planning step [m]."""
    keep_returned: bool = True
    """A goal chosen again after the robot turned away from it (it was neither reached nor given up) is kept, as
    ``commit_m`` keeps a committing planner's, until it is reached or given up: re-choosing at every planning step
    otherwise lets two far goals of about equal worth, whose scores the samples' noise swaps from one step to the
    next, turn the robot back and forth between them without end."""
    release_empty: bool = False
    """A goal kept by ``keep_returned`` is let go as soon as the planner expects nothing there (gain 0: every
    sample walls off what the frontier hides), instead of being driven to for nothing."""
    blacklist_m: float = 0.5
    """Frontier viewpoints within this distance of a goal that was reached without its frontier going away, or that
    the robot could not get to, are dropped for the rest of the run [m]."""
    stuck_s: float = 8.0
    """A goal the robot gets no closer to for this long (by the path left to drive to it) is dropped [s]."""
    contact_keep_s: float = 60.0
    """Where the robot touched a wall (a move refused: its map put the wall elsewhere, or missed it), the contact
    point is an obstacle on the planning map for this long, as a bumper's in a costmap, so the next path goes around
    it instead of into it again [s]; 0: contacts are not marked."""
    coverage_rays: int = 1440
    """Rays over 360° that measure what the sensor saw (the coverage), finer than the lidar's beams."""
    coverage_lattice_m: float = 0.5
    """Spacing of the safe positions from which the reachable free space (every free cell a scan from a reachable
    place can see) is computed [m]."""

    def __post_init__(self) -> None:
        if not (self.budget_m > 0 and self.replan_m > 0 and self.plan_resolution_m > 0 and self.segment_m > 0
                and self.plan_margin_m >= 0 and self.plan_max_cells > 0 and self.commit_m >= 0
                and self.contact_keep_s >= 0):
            raise ValueError(f"budget, replan distance, planning resolution and segment must be positive, margins, "
                             f"commit distance and contact_keep_s not negative: {self}")
        if len(self.start_m) not in (0, 2, 3) or not all(math.isfinite(v) for v in self.start_m):
            raise ValueError(f"start_m takes X Y or X Y YAW_DEG, got {self.start_m}")
        if not 0 < self.stop_coverage <= 1:
            raise ValueError(f"stop_coverage must be in (0, 1], got {self.stop_coverage}")
        if self.coverage_rays < 4 or self.coverage_lattice_m <= 0:
            raise ValueError(f"coverage_rays must be >= 4 and coverage_lattice_m positive: {self}")


@dataclass(frozen=True)
class GainConfig:
    """How the ``mcn`` planner scores a frontier viewpoint from the K sampled completions (of the model the command
    line's ``--model`` names)."""

    samples: int = 32
    """K completions drawn at every planning step.  The expected gain is their average, and its sampling noise
    decides between viewpoints of about equal worth: with fewer samples, a long run turns back and forth between
    far goals whose scores the noise swaps."""
    gain: GainKind = "unknown"
    """``unknown``: the area unknown in the SLAM map that a scan from the viewpoint would see, ray-cast through each
    sample's own walls, averaged over the samples; ``disagreement``: the same cells weighted by how much the
    samples disagree on them (4·p·(1−p), p the share of samples that say occupied); ``observed``: no prediction,
    the unknown area seen through the SLAM map's known walls only (unknown space counted transparent);
    ``consensus``: the unknown area seen through the walls at least half the samples draw; ``open``: the unknown
    area the samples say is free (the share of them that do), seen through the SLAM map's known walls only: the
    samples say how far the house goes, not where its unseen inner walls stand; ``free``: in each sample, the unknown
    area that sample calls free, seen through its own walls (what the coverage counts: free floor, not walls or the
    outside)."""
    tradeoff: TradeOff = "ratio"
    """``ratio``: gain / (path cost + ``cost_floor_m``); ``exp``: gain · exp(−``cost_lambda_per_m`` · path cost);
    ``tour``: the first stop of the shortest tour from the robot through the (at most ``tour_places`` cheapest)
    viewpoints whose expected gain is at least ``tour_min_gain_m2`` (:mod:`mcnkit.explore.tour`); ``regret``: gain /
    (path cost + ``cost_floor_m`` + how much longer that tour gets when it starts there), over the same viewpoints;
    ``nearest``: the nearest viewpoint worth at least ``tour_min_gain_m2`` (Yamauchi's rule with the frontiers that
    the samples say hide nothing worth the trip left for last)."""
    cost_lambda_per_m: float = 0.3
    """λ of the ``exp`` trade-off [1/m]."""
    cost_floor_m: float = 1.0
    """Added to the path cost of the ``ratio`` trade-off, so a frontier at the robot's feet does not win by
    dividing by zero [m]."""
    tour_min_gain_m2: float = 1.0
    """The ``tour``, ``regret`` and ``nearest`` trade-offs (and ``local_m``) plan through the viewpoints the samples expect at
    least this much new area from [m²] (all of them when none does)."""
    tour_places: int = 12
    """The ``tour`` and ``regret`` trade-offs plan through at most this many viewpoints, the cheapest to reach."""
    local_m: float = 0.0
    """When positive, the viewpoints within this path cost that the samples expect at least ``tour_min_gain_m2`` from
    are chosen before any farther one (among themselves by the trade-off): what lies beside the robot is finished
    before it leaves for a larger but farther view, the local-then-global order of hierarchical explorers (TARE), so
    no room next to the robot is left for a trip back.  0: the trade-off alone decides [m]."""
    window_margin_m: float = SEEN_WINDOW_M[0]
    """The network's window: the SLAM map's seen bounds plus this margin, padded square (room for the part not seen
    yet; the frame the ``sampler-seen`` nets were trained on) [m]."""
    window_min_m: float = SEEN_WINDOW_M[1]
    """The window's side is at least this (early maps are small) [m]."""
    window_max_m: float = SEEN_WINDOW_M[2]
    """A map whose window would be wider than this (a building, not a house) is completed on a window of this side
    centred on the robot instead [m]."""
    beyond_reach: bool = True
    """Count the unknown space a scan would see past the window out to the sensor's range wherever it lies, not only
    where the seen map reaches past the window (:func:`mcnkit.explore.gain.beyond_window_gains`): a window that holds
    the seen map ends ``window_margin_m`` past it, short of what a scan from the map's edge reaches, so without it
    every viewpoint at that edge is worth at most the margin's strip.  Off: only the seen map's extent counts."""
    beams: int = 180
    """Rays per viewpoint of the visibility cast."""
    commit: bool = False
    """Keep the goal until it is reached, as the frontier planner does (ExploreConfig.commit_m); off: choose the best
    score afresh at every planning step."""
    sample_share: float = 1.0
    """The samples' share of a viewpoint's gain; the rest is the ``observed`` gain of the same viewpoint (the unknown
    area seen through the SLAM map's known walls, no prediction): a hedge against samples that close off space that
    is open, or draw the house ending where it goes on.  1: the samples' gain alone."""
    keep_bonus: float = 0.0
    """The viewpoint nearest the goal the robot is driving to (within ``ExploreConfig.commit_m``) scores this share
    more when the goal is chosen afresh: another must beat it by that much to take its place, so the noise of K
    samples does not turn the robot back and forth between two goals of about equal worth.  0: no such bonus."""
    same_noise: bool = False
    """Draw every planning step's samples from the same random numbers (common random numbers): two steps' samples
    then differ where the map does, not by chance, and so do their scores."""
    finish_share: float = 0.0
    """When positive, a pocket of a sample (unknown space its walls close off, not cut by the window's edge: a
    closet, a room behind a door) that a scan from the viewpoint would see at least this share of counts its whole
    area once more in that sample's gain: seen now it is done, left for later it costs a return trip.  0: no such
    bonus."""

    def __post_init__(self) -> None:
        if self.samples < 1 or self.beams < 4 or self.tour_places < 1 or self.tour_min_gain_m2 < 0:
            raise ValueError(f"samples and tour_places must be >= 1, beams >= 4, tour_min_gain_m2 >= 0: {self}")
        if not (0 <= self.finish_share <= 1 and 0 <= self.sample_share <= 1):
            raise ValueError(f"finish_share and sample_share must be in [0, 1]: {self}")
        if self.gain not in get_args(GainKind) or self.tradeoff not in get_args(TradeOff):
            raise ValueError(f"unknown gain {self.gain!r} or trade-off {self.tradeoff!r}")
        if (self.cost_lambda_per_m < 0 or self.cost_floor_m <= 0 or self.window_margin_m < 0 or self.local_m < 0
                or self.keep_bonus < 0):
            raise ValueError(f"cost_lambda_per_m, window_margin_m, local_m and keep_bonus must be >= 0, cost_floor_m "
                             f"> 0: {self}")
        if not 0 < self.window_min_m <= self.window_max_m:
            raise ValueError(f"need 0 < window_min_m <= window_max_m: {self}")
