"""Motion from the scans alone: the prior a scan's motion is searched around where no odometry gives it.

A log without odometry (a handheld scanner, a bag that recorded only ``/scan``), a log whose odometry is ignored
(``SlamConfig.motion.odometry``), and the steps of any log where the odometry has a gap, jumps or contradicts the
scans, leave the filter to find each scan's motion by matching the scan against the map.  What it searches around
is the robot's own recent motion as the tracking found it, :class:`MotionPrior`:

* **constant step**: the next scan moves the robot as the last one did;
* **constant velocity**: the same twist per second, scaled by the time between the scans (stamps that carry time).

Which of the two predicts *this* log better is measured on the log itself: each tracked step adds the residual of
both predictions, and the one with the smaller median residual over the last ``window`` steps is used.  A log whose
scans come at a steady rate gets constant velocity; a log that keeps one scan per metre (scans kept by distance,
their stamps seconds apart at random) gets constant step.  The prior's spread is measured the same way: a robust
scale of the chosen prediction's residuals, per component, so the search window fits the log's scan rate (a few
centimetres at 40 Hz, a metre in a log that keeps one scan per metre) without being told it.

Neither prediction foresees what a log kept by distance (a scan every metre or every half radian) does next: it
alternates drives and turns in place, either way, so the last step predicts the next one badly (the measured
spread in heading reaches tens of degrees) and a look-alike pose a quarter turn off costs little more than the
true one.  So the prior is a density, :meth:`MotionGuess.log_density`: half the Gaussian of the chosen
prediction and half a kernel density of the recent steps themselves (the kinds of step this robot makes: drives,
turns either way), and the search (:func:`mcnkit.slam.widesearch.unknown_motion_match`) mixes in a share ``ε`` of
steps that neither explains (the robot may do anything at any scan: a uniform over the region searched).  That
share is measured on the log, from how well each step was predicted before it was made (:func:`outlier_share`),
so a log whose steps the density predicts gets a prior that decides, and an erratic one a prior that lets the
scans decide.

The particles then move by the tracked motion, spread by what the match left undetermined
(:func:`motion_covariance`): the improved proposal's ``(H + P⁻¹)⁻¹`` with ``H`` the scan match's information and
``P`` the prior's covariance, so along a corridor's axis, which the scan does not pin, the particles keep the
prior's spread until a feature pins them, and across it they sit within centimetres.

Example:
    >>> prior = MotionPrior(window=20, default_sigma=np.array([1.0, 1.0, 1.0]), min_samples=10)
    >>> for _ in range(12):
    ...     prior.add(np.array([0.1, 0.0, 0.01]), 0.1)
    >>> guess = prior.predict(0.2)              # twice the time: constant velocity predicts twice the step
    >>> guess.mean.round(3).tolist(), prior.mode
    ([0.2, 0.0, 0.02], 'velocity')
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, wrap_angle

__all__ = ["MIN_DENSITY_STEPS", "MotionGuess", "MotionPrior", "motion_covariance", "outlier_share", "sample_increments"]

F64 = NDArray[np.float64]

_MIN_DT_S = 1e-3
"""Scans closer in time than this carry no usable time (duplicated or rebuilt stamps): constant step."""
MIN_DENSITY_STEPS = 10
"""Recent steps the density needs before it joins the prior."""
_MAX_RATE_CHANGE = 4.0
"""Constant velocity scales the last step by the ratio of the two scan intervals, at most this much either way (a
scan delayed by a hiccup of the driver must not predict a jump)."""


@dataclass(frozen=True)
class MotionGuess:
    """A predicted motion over one scan, in the robot's frame at the scan before."""

    mean: F64
    """``[dx_m, dy_m, dyaw_rad]``."""
    sigma: F64
    """Standard deviation of each component of ``mean`` (3,)."""
    recent: F64 = field(default_factory=lambda: np.zeros((0, 3)))
    """(N, 3) the recent tracked steps, the kernel density's centres (none before ``MIN_DENSITY_STEPS`` steps: the
    Gaussian alone)."""
    bandwidth: F64 = field(default_factory=lambda: np.ones(3))
    """(3,) the kernel density's bandwidth (Silverman's rule per component, at least the prior's ``min_sigma``)."""
    log_q_recent: F64 = field(default_factory=lambda: np.zeros(0))
    """(N,) the log density each recent step had under the guess made before it: how well this log is predicted
    (:func:`outlier_share`)."""

    def log_density(self, motions: F64, widen: F64 | None = None) -> F64:
        """Log density (P,) of motions (P, 3) under the guess: the Gaussian of ``mean`` and ``sigma`` alone, or,
        once recent steps are known, half that Gaussian and half their kernel density; every spread widened in
        quadrature by ``widen`` (3,; e.g. a search lattice's cell and angular step)."""
        motions = np.atleast_2d(np.asarray(motions, np.float64))
        w = np.zeros(3) if widen is None else np.asarray(widen, np.float64)
        gauss = _log_normal(motions[:, None, :], self.mean[None, None, :], np.sqrt(self.sigma**2 + w**2))[:, 0]
        if len(self.recent) == 0:
            return gauss
        kde = _log_normal(motions[:, None, :], self.recent[None, :, :], np.sqrt(self.bandwidth**2 + w**2))
        kde = np.logaddexp.reduce(kde, axis=1) - math.log(len(self.recent))
        return np.asarray(np.logaddexp(gauss, kde) - math.log(2.0), np.float64)

    def modes(self, most: int = 3) -> F64:
        """(M, 3) the prediction and the densest distinct recent steps (each at least three bandwidths from those
        before it), at most ``most`` of the latter: where the density has its peaks."""
        if len(self.recent) == 0:
            return self.mean[None, :].copy()
        density = self.log_density(self.recent)
        out = [self.mean]
        for k in np.argsort(-density):
            d = self.recent[k] - np.asarray(out)
            d[:, 2] = wrap_angle(d[:, 2])
            if (((d / self.bandwidth) ** 2).sum(axis=1) > 9.0).all():
                out.append(self.recent[k])
                if len(out) > most:
                    break
        return np.asarray(out)


class MotionPrior:
    """The robot's recent tracked motion, as a prediction of the next scan's motion and of how far off it may be.

    Args:
        window: steps over which each prediction's residuals are kept.
        default_sigma: the spread (3,) before ``min_samples`` steps were seen.
        min_sigma: the spread is never below this (3,): a robot that drove perfectly steadily so far may still
            brake.
        min_samples: residuals needed before the measured spread and the choice of prediction are used (the
            recent steps' density joins the Gaussian after ``MIN_DENSITY_STEPS``).
    """

    def __init__(self, window: int, default_sigma: F64, min_sigma: F64 | None = None, min_samples: int = 30) -> None:
        self._res: dict[str, deque[F64]] = {"step": deque(maxlen=window), "velocity": deque(maxlen=window)}
        self.default_sigma = np.asarray(default_sigma, np.float64)
        self.min_sigma = np.zeros(3) if min_sigma is None else np.asarray(min_sigma, np.float64)
        self.min_samples = min_samples
        self._last: F64 | None = None
        self._recent: deque[F64] = deque(maxlen=window)
        self._log_q: deque[float] = deque(maxlen=window)
        self._last_dt: float | None = None
        self._fastest = np.zeros(2)  # the largest translation (m) and turn (rad) over one scan so far
        self._steps = 0

    @property
    def mode(self) -> str:
        """``"velocity"`` or ``"step"``: the prediction with the smaller median residual over the window (velocity
        on a tie: stamps that carry time; step until both have ``min_samples``)."""
        step, vel = self._res["step"], self._res["velocity"]
        if len(vel) < self.min_samples or len(step) < self.min_samples:
            return "step"
        return "velocity" if _size(vel) <= _size(step) else "step"

    def _predictions(self, dt_s: float | None) -> dict[str, F64]:
        last = np.zeros(3) if self._last is None else self._last
        out = {"step": last}
        if self._last_dt is not None and dt_s is not None and self._last_dt > _MIN_DT_S and dt_s > _MIN_DT_S:
            out["velocity"] = last * float(np.clip(dt_s / self._last_dt, 1 / _MAX_RATE_CHANGE, _MAX_RATE_CHANGE))
        return out

    def predict(self, dt_s: float | None) -> MotionGuess:
        """The motion over the next scan, ``dt_s`` seconds after the last (None: no usable time)."""
        preds = self._predictions(dt_s)
        mode = self.mode if self.mode in preds else "step"
        res = self._res[mode]
        if len(res) < self.min_samples:
            sigma = self.default_sigma.copy()
        else:
            r = np.abs(np.asarray(res))
            sigma = np.percentile(r, 90, axis=0) / 1.645  # a Gaussian's 90th percentile: heavy tails widen it
        sigma = np.maximum(sigma, self.min_sigma)
        if len(self._recent) < MIN_DENSITY_STEPS:
            return MotionGuess(preds[mode].copy(), sigma)
        recent = np.asarray(self._recent)
        bandwidth = np.maximum(1.06 * recent.std(axis=0) * len(recent) ** -0.2, self.min_sigma)
        return MotionGuess(preds[mode].copy(), sigma, recent, bandwidth, np.asarray(self._log_q, np.float64))

    def add(self, motion: F64, dt_s: float | None, guess: MotionGuess | None = None) -> None:
        """The motion (3,) the tracking found over the last scan, ``dt_s`` after the scan before (None: no time);
        ``guess``: what :meth:`predict` said for it, if the caller kept it (else it is made again)."""
        motion = np.asarray(motion, np.float64)
        made = self.predict(dt_s) if guess is None else guess
        if len(made.recent):  # how well the density before it predicted this step
            self._log_q.append(float(made.log_density(motion[None, :])[0]))
        if self._last is not None:
            for mode, pred in self._predictions(dt_s).items():
                err = motion - pred
                err[2] = float(wrap_angle(err[2]))
                self._res[mode].append(err)
        self._last = motion.copy()
        self._recent.append(self._last)
        self._last_dt = dt_s
        self._fastest = np.maximum(self._fastest, [np.hypot(motion[0], motion[1]), abs(float(motion[2]))])
        self._steps += 1

    def reach(self, most_m: float, most_rad: float) -> tuple[float, float]:
        """How far (± m, ± rad) from the prediction a scan's pose is searched: twice the fastest motion over one
        scan the log has shown so far (its scan rate and its robot's pace), at most ``most_m`` / ``most_rad``
        and at least 3σ of :meth:`predict`; the most until ``min_samples`` steps were seen."""
        if self._steps < self.min_samples:
            return most_m, most_rad
        xy, rad = 2.0 * self._fastest
        return float(min(max(xy, 3.0 * self.min_sigma[:2].max()), most_m)), float(min(max(rad, 3.0 * self.min_sigma[2]), most_rad))


def outlier_share(log_q: F64, log_u: float, iterations: int = 30) -> float:
    """The share ``ε`` of steps that no prediction explains: the weight of a uniform density (``log_u``: over the
    region searched) in the mixture ``(1 − ε) q + ε u`` of the steps' predicted densities ``log_q`` (N,), by
    expectation-maximisation, its most probable value under a Beta(2, 2) prior (``(Σ r + 1) / (N + 2)`` with ``r``
    each step's responsibility of the uniform): 0.5 before any step is known, and a few well-predicted steps do not
    make it 0.  Within [0.01, 0.5]."""
    log_q = np.asarray(log_q, np.float64)
    eps = 0.1
    for _ in range(iterations):
        a = math.log(eps) + log_u
        b = math.log(1.0 - eps) + log_q
        r = np.exp(a - np.logaddexp(a, b))
        eps = float(np.clip((r.sum() + 1.0) / (len(log_q) + 2.0), 0.01, 0.5))
    return eps


def _log_normal(x: F64, mean: F64, sigma: F64) -> F64:
    """Log density of independent normals, the heading difference wrapped; broadcast over leading axes (a spread of
    0, a component that never varied, counts as a micrometre or microradian)."""
    d = x - mean
    d[..., 2] = wrap_angle(d[..., 2])
    sigma = np.maximum(np.broadcast_to(sigma, d.shape), 1e-6)
    return np.asarray(-0.5 * ((d / sigma) ** 2).sum(axis=-1) - np.log(sigma).sum(axis=-1) - 1.5 * math.log(2 * math.pi))


def _size(res: deque[F64]) -> float:
    """A residual's typical size: median translation (m) plus median heading error (rad, as metres at 1 m)."""
    r = np.asarray(res)
    return float(np.median(np.hypot(r[:, 0], r[:, 1])) + np.median(np.abs(r[:, 2])))


def motion_covariance(info_world: F64, yaw_rad: float, sigma: F64) -> F64:
    """The covariance (3, 3) of a scan-matched motion, in the robot's frame at ``yaw_rad``: the match's
    information ``info_world`` (3, 3; world axes, e.g. :func:`mcnkit.slam.proposal.match_information`) combined
    with a prior of standard deviations ``sigma`` (3,; robot axes): ``(H + P⁻¹)⁻¹``.  Where the scan pins the
    pose the match decides; along a corridor's axis the prior's spread remains."""
    c, s = np.cos(yaw_rad), np.sin(yaw_rad)
    rot = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # robot axes -> world axes
    info = rot.T @ np.asarray(info_world, np.float64) @ rot
    prior = np.diag(1.0 / np.maximum(np.asarray(sigma, np.float64), 1e-6) ** 2)
    cov: F64 = np.linalg.inv(info + prior)
    return 0.5 * (cov + cov.T)


def sample_increments(poses: F64, delta: F64, cov: F64, rng: np.random.Generator) -> F64:
    """Moves poses (N, 3) by the increment ``delta`` (3,; robot frame) with Gaussian noise of covariance ``cov``
    (3, 3; robot frame), drawn for every pose."""
    chol = np.linalg.cholesky(cov + 1e-12 * np.eye(3))
    noisy = np.asarray(delta, np.float64) + rng.standard_normal((len(poses), 3)) @ chol.T
    return compose(np.asarray(poses, np.float64), noisy)
