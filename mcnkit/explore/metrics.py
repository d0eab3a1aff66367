"""What an exploration run achieved: coverage against path length, the path to a coverage level, and the final
map scored against the ground truth (F-measure, free space positive, on the house's window: its bounding box
padded square on 64 × 64 cells, as the completion nets were trained) — of the SLAM map and of its completion.

Example:
    >>> curve = coverage_curve(explorer.records)                   # doctest: +SKIP
    >>> path_to_coverage(curve, 0.9), coverage_at(curve, 30.0)     # doctest: +SKIP
    (41.2, 0.83)
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from mcnkit.completion.scores import f_per_map
from mcnkit.explore.loop import Explorer, FrameRecord
from mcnkit.grid import pool_to_window
from mcnkit.sim import PlanRaster
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, GridSpec, TernaryMap

if TYPE_CHECKING:
    import torch

    from mcnkit.completion.nets import CompletionNet

__all__ = ["COVERAGE_LEVELS", "PATH_BUDGETS_M", "Curve", "ExploreSummary", "coverage_at", "coverage_curve",
           "final_map_f", "house_window", "map_f", "path_to_coverage", "summarize"]

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]


@dataclass(frozen=True)
class Curve:
    """Coverage (N,) against the path length driven (N,) [m], frame by frame."""

    path_length_m: F64
    coverage: F64


def coverage_curve(records: list[FrameRecord]) -> Curve:
    """The coverage curve of a run's frame records."""
    return Curve(np.array([r.path_length_m for r in records], np.float64),
                 np.array([r.coverage for r in records], np.float64))


def path_to_coverage(curve: Curve, level: float) -> float | None:
    """The path length [m] at which the coverage first reached ``level``; None if it never did."""
    reached = np.flatnonzero(curve.coverage >= level)
    return float(curve.path_length_m[reached[0]]) if len(reached) else None


def coverage_at(curve: Curve, budget_m: float) -> float:
    """The coverage reached within ``budget_m`` of path (the last value if the run stopped earlier)."""
    within = np.flatnonzero(curve.path_length_m <= budget_m)
    return float(curve.coverage[within[-1]]) if len(within) else 0.0


def house_window(raster: PlanRaster, size: int = 64) -> GridSpec:
    """The house's window: the bounding box of its free cells padded square, on ``size``² cells."""
    from mcnkit.mcn import map_window

    rc = np.argwhere(raster.free)
    g = raster.grid
    lo, hi = rc.min(axis=0), rc.max(axis=0) + 1
    bounds = (g.origin_x_m + lo[1] * g.resolution_m, g.origin_y_m + lo[0] * g.resolution_m,
              g.origin_x_m + hi[1] * g.resolution_m, g.origin_y_m + hi[0] * g.resolution_m)
    return map_window(bounds, size)


def _f_free(prediction: F32, truth: F32) -> float:
    return float(f_per_map(prediction[None], truth[None], "free")[0])


def map_f(raster: PlanRaster, slam_map: TernaryMap, completed: F32 | None = None,
          window: GridSpec | None = None) -> tuple[float, float | None, F32, F32]:
    """F-measure (free positive) of the SLAM map and, when given, of its completion ``completed`` (S, S, on the
    window), against the plan on the house's window; also the two pooled maps ``(partial, truth)``."""
    w = window if window is not None else house_window(raster)
    truth = pool_to_window(TernaryMap(np.where(raster.free, FREE, OCCUPIED).astype(np.float32), raster.grid), w,
                           outside=OCCUPIED)
    partial = pool_to_window(slam_map, w, outside=UNKNOWN)
    f_done = None if completed is None else _f_free(completed, truth)
    return _f_free(partial, truth), f_done, partial, truth


COVERAGE_LEVELS = (0.5, 0.8, 0.9, 0.95)
"""Coverage levels whose path length a summary reports."""
PATH_BUDGETS_M = (10.0, 20.0, 40.0, 80.0)
"""Path budgets at which a summary reports the coverage [m]."""


@dataclass(frozen=True)
class ExploreSummary:
    """One exploration run in numbers (what ``summary.json`` and the benchmark hold)."""

    map: str
    planner: str
    seed: int
    stop_reason: str
    coverage: float
    """Share of the reachable free space seen at the end."""
    path_length_m: float
    frames: int
    planning_steps: int
    collisions: int
    cpu_s: float
    """CPU time of the whole loop (simulation, SLAM, planning) [s]."""
    plan_cpu_s_mean: float
    plan_cpu_s_max: float
    path_to_coverage_m: dict[str, float | None]
    """Per coverage level (``"0.9"``), the path length at which it was reached (None: never)."""
    coverage_at_m: dict[str, float]
    """Per path budget (``"20"``), the coverage reached within it."""
    reachable_m2: float
    f_slam: float | None = None
    """F (free positive) of the final SLAM map on the house's window."""
    f_completed: float | None = None
    """F of its mean completion."""
    frontiers_left: int | None = None
    """Frontier segments on the map at the last planning step (None: no planning step): after ``explored``, the
    frontiers no path reaches (a door the map draws too narrow, space seen only through a window)."""

    def as_dict(self) -> dict[str, object]:
        """JSON-ready."""
        from dataclasses import asdict

        return asdict(self)


def summarize(explorer: Explorer, f_slam: float | None = None, f_completed: float | None = None) -> ExploreSummary:
    """The summary of a (finished or stopped) run."""
    curve = coverage_curve(explorer.records)
    plan_cpu = np.array([p.cpu_s for p in explorer.plans]) if explorer.plans else np.zeros(1)
    res = explorer.raster.grid.resolution_m
    return ExploreSummary(
        explorer.raster.name, explorer.planner.name, explorer.seed, explorer.stop_reason or "running",
        explorer.coverage, explorer.path_length_m, explorer.n_frames, len(explorer.plans), explorer.n_collisions,
        explorer.cpu_s, float(plan_cpu.mean()), float(plan_cpu.max()),
        {f"{c:g}": path_to_coverage(curve, c) for c in COVERAGE_LEVELS},
        {f"{b:g}": coverage_at(curve, b) for b in PATH_BUDGETS_M},
        float(explorer.reachable.sum() * res * res), f_slam, f_completed,
        explorer.plans[-1].frontiers if explorer.plans else None)


def final_map_f(explorer: Explorer, net: CompletionNet | None = None, samples: int = 8,
                generator: torch.Generator | None = None) -> tuple[float, float | None]:
    """F of the run's final SLAM map (the best particle's) and, with a completion net, of its mean completion
    (``samples`` draws), both on the house's window."""
    window = house_window(explorer.raster)
    f_slam, _, partial, _ = map_f(explorer.raster, explorer.slam.best_ternary(), window=window)
    if net is None:
        return f_slam, None
    import torch

    from mcnkit.explore.predict import complete_on

    _, mean = complete_on(net, partial, samples, generator if generator is not None else torch.Generator())
    return f_slam, map_f(explorer.raster, explorer.slam.best_ternary(), mean, window)[1]
