"""gmapping's odometry motion model, sampled for all particles at once.

The odometry increment ``δ = ⊖odom_prev ⊕ odom_new`` (in the robot frame at the previous pose) is
perturbed per particle with zero-mean Gaussian noise whose standard deviations are

* ``σx = srr·|δx| + str·|δθ| + 0.3·srr·|δy|``,
* ``σy = srr·|δy| + str·|δθ| + 0.3·srr·|δx|``,
* ``σθ = stt·|δθ| + srt·√(δx² + δy²)``,

and composed onto each particle's pose (OpenSLAM gmapping, ``MotionModel::drawFromMotion``).

Example:
    >>> rng = np.random.default_rng(0)
    >>> poses = np.zeros((2, 3))
    >>> out = sample_motion(poses, np.zeros(3), np.array([1.0, 0, 0]), MotionNoise(0, 0, 0, 0), rng)
    >>> out.tolist()
    [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, relative

__all__ = ["MotionNoise", "motion_std", "sample_motion"]

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class MotionNoise:
    """gmapping's four odometry error coefficients (standard deviation per unit of motion)."""

    srr: float = 0.1
    srt: float = 0.2
    str_: float = 0.1
    stt: float = 0.2


def motion_std(delta: NDArray[np.floating], noise: MotionNoise) -> F64:
    """Standard deviations ``[σx_m, σy_m, σθ_rad]`` of the noise added to an increment ``delta`` (3,)."""
    dx, dy, dt = np.abs(np.asarray(delta, dtype=np.float64))
    sxy = 0.3 * noise.srr
    return np.array(
        [
            noise.srr * dx + noise.str_ * dt + sxy * dy,
            noise.srr * dy + noise.str_ * dt + sxy * dx,
            noise.stt * dt + noise.srt * np.hypot(dx, dy),
        ]
    )


def sample_motion(
    poses: NDArray[np.floating],
    odom_prev: NDArray[np.floating],
    odom_new: NDArray[np.floating],
    noise: MotionNoise,
    rng: np.random.Generator,
) -> F64:
    """Moves particle poses (N, 3) by the odometry increment from ``odom_prev`` to ``odom_new``, with noise."""
    poses = np.asarray(poses, dtype=np.float64)
    delta = relative(np.asarray(odom_prev, dtype=np.float64), np.asarray(odom_new, dtype=np.float64))
    std = motion_std(delta, noise)
    noisy = delta + rng.standard_normal((len(poses), 3)) * std  # (N, 3) per-particle increments
    return compose(poses, noisy)
