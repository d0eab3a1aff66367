"""gmapping's odometry motion model, sampled for all particles at once.

The odometry increment ``δ = ⊖odom_prev ⊕ odom_new`` (in the robot frame at the previous pose) is
perturbed per particle with zero-mean Gaussian noise whose standard deviations are

* ``σx = srr·|δx| + str·|δθ| + 0.3·srr·|δy|``,
* ``σy = srr·|δy| + str·|δθ| + 0.3·srr·|δx|``,
* ``σθ = stt·|δθ| + srt·√(δx² + δy²)``,

and composed onto each particle's pose (OpenSLAM gmapping, ``MotionModel::drawFromMotion``).

gmapping's coefficients are per step, so the noise a log gets depends on how far apart its scans are: a log that
keeps one scan per metre (the Radish "corrected" logs) gets 10-17° of heading noise per scan, where its odometry
errs by a fraction of a degree, and particles drawn that far off cannot be matched back.  :class:`NoiseScale`
measures, on the log itself, how far the odometry increments are from the scan-matched ones relative to what the
model allows, and scales the coefficients down to that (never up), except for a step whose own odometry and
scan-matched increments disagree by more: that step keeps noise spanning the disagreement (one of the two erred,
and scan matching does, grossly, now and then outdoors).  ``SlamConfig.motion_noise_from_log`` says what it
changes on the real buildings.

Example:
    >>> rng = np.random.default_rng(0)
    >>> poses = np.zeros((2, 3))
    >>> out = sample_motion(poses, np.zeros(3), np.array([1.0, 0, 0]), MotionNoise(0, 0, 0, 0), rng)
    >>> out.tolist()
    [[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]]
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, relative

__all__ = ["MotionNoise", "NoiseScale", "motion_std", "sample_motion"]

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


class NoiseScale:
    """How much of the motion model's noise the log's odometry needs, measured on the log itself.

    Each scan whose motion the odometry gives adds the residual between that odometry increment and the
    scan-matched one, in units of the model's standard deviation for the step (translation and heading
    separately).  The scale is the robust (median-based) standard deviation of the last ``window`` residuals, within
    ``[min_scale, 1]``; until ``min_samples`` came, 1 (the model as configured).
    """

    def __init__(self, window: int = 200, min_samples: int = 20, min_scale: float = 0.05) -> None:
        self._xy: deque[float] = deque(maxlen=window)
        self._rad: deque[float] = deque(maxlen=window)
        self.min_samples = min_samples
        self.min_scale = min_scale

    def add(self, odom_delta: NDArray[np.floating], matched_delta: NDArray[np.floating],
            noise: MotionNoise) -> tuple[float | None, float | None]:
        """One step: the odometry increment and the scan-matched one (3,), robot frame, under ``noise``; returns the
        step's own residuals ``(translation, heading)`` (the floor :meth:`noise` takes)."""
        xy, rad = _residuals(odom_delta, matched_delta, noise)
        if rad is not None:
            self._rad.append(rad)
        if xy is not None:
            self._xy.append(xy)
        return xy, rad

    def scales(self) -> tuple[float, float]:
        """``(translation, heading)`` scales: the median residual over the median of a residual drawn from the
        model itself (1.18/√2 for the 2-D distance, 0.674 for the heading)."""
        def one(values: deque[float], median_of_model: float) -> float:
            if len(values) < self.min_samples:
                return 1.0
            return float(np.clip(np.median(values) / median_of_model, self.min_scale, 1.0))
        return one(self._xy, 1.1774 / np.sqrt(2.0)), one(self._rad, 0.6745)

    def noise(self, base: MotionNoise, step: tuple[float | None, float | None] | None = None) -> MotionNoise:
        """``base`` with its translation (``srr``, ``str_``) and heading (``srt``, ``stt``) terms scaled by
        :meth:`scales`; never below ``step``, a step's own residuals as :meth:`add` returned them (a step whose
        odometry and scan matching disagree keeps noise that spans the disagreement, up to ``base``)."""
        xy, rad = self.scales()
        if step is not None:
            step_xy, step_rad = step
            xy = min(max(xy, step_xy if step_xy is not None else 0.0), 1.0)
            rad = min(max(rad, step_rad if step_rad is not None else 0.0), 1.0)
        return MotionNoise(base.srr * xy, base.srt * rad, base.str_ * xy, base.stt * rad)


def _residuals(odom_delta: NDArray[np.floating], matched_delta: NDArray[np.floating],
               noise: MotionNoise) -> tuple[float | None, float | None]:
    """How far the scan-matched increment is from the odometry's, in units of the model's standard deviation for
    the step: ``(translation, heading)``, None where the model allows no noise."""
    std = motion_std(odom_delta, noise)
    err = np.asarray(matched_delta, np.float64) - np.asarray(odom_delta, np.float64)
    err_rad = abs((err[2] + np.pi) % (2 * np.pi) - np.pi)
    rad = float(err_rad / std[2]) if std[2] > 1e-4 else None
    xy = float(np.hypot(err[0], err[1]) / np.hypot(std[0], std[1])) if np.hypot(std[0], std[1]) > 1e-4 else None
    return xy, rad
