"""Exploration: a simulated robot that chooses where to look next, by the nearest frontier or by what K sampled
completions of its map expect a scan to reveal (:mod:`mcnkit.explore.loop` is the closed loop).

The names below are imported on first use."""

from typing import TYPE_CHECKING

from mcnkit._lazy import lazy_exports

if TYPE_CHECKING:
    from mcnkit.explore.config import PLANNERS, ExploreConfig, GainConfig, PlannerName
    from mcnkit.explore.loop import EXPLORE_SLAM, Explorer, FrameRecord
    from mcnkit.explore.planners import Decision, FrontierPlanner, McnPlanner, Planner
    from mcnkit.explore.predict import Prediction

__all__ = ["EXPLORE_SLAM", "PLANNERS", "Decision", "ExploreConfig", "Explorer", "FrameRecord", "FrontierPlanner",
           "GainConfig", "McnPlanner", "Planner", "PlannerName", "Prediction"]

__getattr__, __dir__ = lazy_exports(__name__, {
    "mcnkit.explore.config": ("PLANNERS", "ExploreConfig", "GainConfig", "PlannerName"),
    "mcnkit.explore.loop": ("EXPLORE_SLAM", "Explorer", "FrameRecord"),
    "mcnkit.explore.planners": ("Decision", "FrontierPlanner", "McnPlanner", "Planner"),
    "mcnkit.explore.predict": ("Prediction",),
})
