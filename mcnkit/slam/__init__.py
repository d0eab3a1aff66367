"""Grid FastSLAM with gmapping's scan-matched proposal, vectorised over particles."""

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
