"""The improved proposal's spread: how precisely one scan pins the pose down, per direction.

gmapping samples each particle from its odometry motion model and hill-climbs it onto the map; the climb ends
wherever the score stops rising, so the particles' spread after matching is whatever the motion noise left
along the directions the scan does not constrain — and a sampled noise of ±10° per metre shows up as jitter in
every lineage.  The *improved proposal* (Grisetti et al. 2007) instead samples each particle around its scan-
matched pose from the product of the match likelihood and the motion model:

    Σ = (H / c + Σ_motion⁻¹)⁻¹,

with ``H`` the curvature (negative Hessian) of the scan's log-likelihood at the matched pose and ``Σ_motion`` the
motion model's covariance for the step.  In a corridor ``H`` is ~0 along the axis, so the particles keep the
motion model's spread there instead of collapsing onto one guess; across it they sit within centimetres.  The
scan's beams are not independent (neighbours hit the same wall), so the curvature is counted as that of
``proposal_beams`` independent beams: ``c = n_points / proposal_beams``.

:func:`proposal_covariance` measures ``H`` by central differences of the log-likelihood on a likelihood field.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from mcnkit.slam.correlative import LikelihoodGrid, thin_points

__all__ = ["cap_information", "match_information", "proposal_covariance"]

F64 = NDArray[np.float64]


def _log_likelihood(grid: LikelihoodGrid, px: F64, py: F64, pose: F64, floor: float) -> float:
    """Σ log(L + floor) over the points: ``floor`` keeps points far from any hit from dominating."""
    c, s = math.cos(pose[2]), math.sin(pose[2])
    res = grid.resolution_m
    fx = (pose[0] + c * px - s * py - grid.origin_x_m) / res - 0.5
    fy = (pose[1] + s * px + c * py - grid.origin_y_m) / res - 0.5
    field = grid.levels[0]
    h, w = field.shape
    ix = np.floor(fx).astype(np.int64)
    iy = np.floor(fy).astype(np.int64)
    ok = (ix >= 0) & (iy >= 0) & (ix + 1 < w) & (iy + 1 < h)
    ax, ay = fx[ok] - ix[ok], fy[ok] - iy[ok]
    i, j = iy[ok], ix[ok]
    v = ((1 - ay) * ((1 - ax) * field[i, j] + ax * field[i, j + 1]) + ay * ((1 - ax) * field[i + 1, j]
                                                                         + ax * field[i + 1, j + 1]))
    return float(np.log(v + floor).sum() + np.count_nonzero(~ok) * math.log(floor))


def match_information(grid: LikelihoodGrid, points_base: F64, pose: F64, beams: float, floor: float = 0.1) -> F64:
    """The information (3, 3) one scan's points (M, 2) carry about ``pose`` (3,) on a likelihood field: the
    curvature of Σ log(L + ``floor``) by central differences, counted as that of ``beams`` independent beams, with
    its negative directions (a saddle or slope says nothing) set to zero.  ~0 along a corridor's axis."""
    pts = thin_points(points_base, grid.resolution_m)
    if len(pts) < 3:
        return np.zeros((3, 3))
    px, py = np.ascontiguousarray(pts[:, 0]), np.ascontiguousarray(pts[:, 1])
    reach = max(float(np.percentile(np.hypot(px, py), 75)), grid.resolution_m)
    steps = np.array([grid.resolution_m, grid.resolution_m, grid.resolution_m / reach])
    p0 = np.asarray(pose, np.float64)
    f0 = _log_likelihood(grid, px, py, p0, floor)
    hess = np.zeros((3, 3))
    for a in range(3):
        ea = np.zeros(3)
        ea[a] = steps[a]
        fp, fm = _log_likelihood(grid, px, py, p0 + ea, floor), _log_likelihood(grid, px, py, p0 - ea, floor)
        hess[a, a] = (fp - 2 * f0 + fm) / steps[a] ** 2
        for b in range(a + 1, 3):
            eb = np.zeros(3)
            eb[b] = steps[b]
            fpp = _log_likelihood(grid, px, py, p0 + ea + eb, floor)
            fpm = _log_likelihood(grid, px, py, p0 + ea - eb, floor)
            fmp = _log_likelihood(grid, px, py, p0 - ea + eb, floor)
            fmm = _log_likelihood(grid, px, py, p0 - ea - eb, floor)
            hess[a, b] = hess[b, a] = (fpp - fpm - fmp + fmm) / (4 * steps[a] * steps[b])
    info = -hess * (beams / len(pts))
    vals, vecs = np.linalg.eigh(0.5 * (info + info.T))
    out: F64 = ((vecs * np.maximum(vals, 0.0)) @ vecs.T).astype(np.float64)
    return out


def cap_information(info: F64, cap: F64) -> F64:
    """``info`` (3, 3) with every direction's information at most the diagonal ``cap`` (3,) allows: a match can
    be less precise than stated in some direction (a corridor's axis), never more precise."""
    scale = np.sqrt(np.asarray(cap, np.float64))
    unit = info / np.outer(scale, scale)  # in units where the cap is the identity
    vals, vecs = np.linalg.eigh(0.5 * (unit + unit.T))
    capped = (vecs * np.clip(vals, 0.0, 1.0)) @ vecs.T
    out: F64 = (capped * np.outer(scale, scale)).astype(np.float64)
    return out


def proposal_covariance(
    grid: LikelihoodGrid, points_base: F64, pose: F64, motion_sigma: F64, beams: float, floor: float = 0.1
) -> F64:
    """The covariance (3, 3) of the improved proposal around a matched ``pose`` (3,).

    Args:
        grid: a likelihood field of the map near the pose.
        points_base: the scan's hit points (M, 2), base frame.
        pose: the matched pose.
        motion_sigma: the motion model's standard deviations ``[σx, σy, σθ]`` for the step (a floor of 1 mm and
            0.05° keeps the inverse finite).
        beams: how many independent beams the scan counts as.
        floor: added to every point's likelihood before the log.
    """
    prior = np.diag(1.0 / np.maximum(np.asarray(motion_sigma, np.float64), [1e-3, 1e-3, math.radians(0.05)]) ** 2)
    out: F64 = np.linalg.inv(match_information(grid, points_base, pose, beams, floor) + prior).astype(np.float64)
    return out
