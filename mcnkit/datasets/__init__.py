"""Floor-plan datasets: HouseExpo, the procedural apartment domain, Pseudo-SLAM partial maps, cached pairs.

The names below are imported on first use."""

from typing import TYPE_CHECKING

from mcnkit._lazy import lazy_exports

if TYPE_CHECKING:
    from mcnkit.datasets.floorplans import (
        ApartmentConfig,
        ApartmentPlan,
        apply_mask,
        generate_apartment,
        homes_mask,
        rasterize_apartment,
    )
    from mcnkit.datasets.houseexpo import (
        HOUSEEXPO_SHA256,
        FloorPlan,
        PlanError,
        SkipLog,
        find_houseexpo,
        install_houseexpo,
        iter_plans,
        load_plan,
        rasterize_plan,
        read_split,
    )
    from mcnkit.datasets.pairs import (
        PairConfig,
        PairSet,
        PairSplits,
        PairStats,
        load_or_build_houseexpo_pairs,
        pair_stats,
        procedural_pairs,
    )
    from mcnkit.datasets.pseudoslam import PseudoSlamConfig, first_iteration, pseudo_slam_scan

__all__ = [
    "HOUSEEXPO_SHA256",
    "ApartmentConfig",
    "ApartmentPlan",
    "FloorPlan",
    "PairConfig",
    "PairSet",
    "PairSplits",
    "PairStats",
    "PlanError",
    "PseudoSlamConfig",
    "SkipLog",
    "apply_mask",
    "find_houseexpo",
    "first_iteration",
    "generate_apartment",
    "homes_mask",
    "install_houseexpo",
    "iter_plans",
    "load_or_build_houseexpo_pairs",
    "load_plan",
    "pair_stats",
    "procedural_pairs",
    "pseudo_slam_scan",
    "rasterize_apartment",
    "rasterize_plan",
    "read_split",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "mcnkit.datasets.floorplans": ("ApartmentConfig", "ApartmentPlan", "apply_mask", "generate_apartment",
                                   "homes_mask", "rasterize_apartment"),
    "mcnkit.datasets.houseexpo": ("HOUSEEXPO_SHA256", "FloorPlan", "PlanError", "SkipLog", "find_houseexpo",
                                  "install_houseexpo", "iter_plans", "load_plan", "rasterize_plan", "read_split"),
    "mcnkit.datasets.pairs": ("PairConfig", "PairSet", "PairSplits", "PairStats", "load_or_build_houseexpo_pairs",
                              "pair_stats", "procedural_pairs"),
    "mcnkit.datasets.pseudoslam": ("PseudoSlamConfig", "first_iteration", "pseudo_slam_scan"),
})
