"""Grid FastSLAM with gmapping's scan-matched proposal, vectorised over particles.

The names below are imported on first use (``import mcnkit.slam.config`` alone does not load numba)."""

from typing import TYPE_CHECKING

from mcnkit._lazy import lazy_exports

if TYPE_CHECKING:
    from mcnkit.slam.config import SlamConfig
    from mcnkit.slam.fastslam import FastSlam, SlamStep, counts_to_grid
    from mcnkit.slam.maps import TiledHitMaps
    from mcnkit.slam.motion import MotionNoise, sample_motion
    from mcnkit.slam.raycast import ray_cast_counts
    from mcnkit.slam.resample import effective_sample_size, low_variance_resample, normalize_log_weights

__all__ = [
    "FastSlam",
    "MotionNoise",
    "SlamConfig",
    "SlamStep",
    "TiledHitMaps",
    "counts_to_grid",
    "effective_sample_size",
    "low_variance_resample",
    "normalize_log_weights",
    "ray_cast_counts",
    "sample_motion",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "mcnkit.slam.config": ("SlamConfig",),
    "mcnkit.slam.fastslam": ("FastSlam", "SlamStep", "counts_to_grid"),
    "mcnkit.slam.maps": ("TiledHitMaps",),
    "mcnkit.slam.motion": ("MotionNoise", "sample_motion"),
    "mcnkit.slam.raycast": ("ray_cast_counts",),
    "mcnkit.slam.resample": ("effective_sample_size", "low_variance_resample", "normalize_log_weights"),
})
