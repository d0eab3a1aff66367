"""SE(2) algebra on pose arrays.

Poses are float64 arrays ``[..., 3] = [x_m, y_m, yaw_rad]``; every function broadcasts over leading
dimensions, so a particle set (N, 3) is handled in one call.

Example:
    >>> a = np.array([1.0, 0.0, np.pi / 2])
    >>> compose(a, np.array([1.0, 0.0, 0.0])).round(6).tolist()
    [1.0, 1.0, 1.570796]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "compose",
    "interpolate_poses",
    "inverse",
    "quaternion_to_yaw",
    "relative",
    "transform_points",
    "wrap_angle",
    "yaw_to_quaternion",
]

F64 = NDArray[np.float64]


def wrap_angle(angle_rad: NDArray[np.floating] | float) -> F64:
    """Wraps angles to ``[-pi, pi)``."""
    a = np.asarray(angle_rad, dtype=np.float64)
    return np.asarray((a + np.pi) % (2.0 * np.pi) - np.pi)


def compose(a: NDArray[np.floating], b: NDArray[np.floating]) -> F64:
    """``a ⊕ b``: pose ``b`` expressed in frame ``a``, mapped to the frame ``a`` is expressed in."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = a[..., 0] + c * b[..., 0] - s * b[..., 1]
    y = a[..., 1] + s * b[..., 0] + c * b[..., 1]
    return np.stack([x, y, wrap_angle(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a: NDArray[np.floating]) -> F64:
    """``⊖a``: the inverse transform, so that ``compose(a, inverse(a))`` is the identity."""
    a = np.asarray(a, dtype=np.float64)
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    x = -c * a[..., 0] - s * a[..., 1]
    y = s * a[..., 0] - c * a[..., 1]
    return np.stack([x, y, wrap_angle(-a[..., 2])], axis=-1)


def relative(a: NDArray[np.floating], b: NDArray[np.floating]) -> F64:
    """``⊖a ⊕ b``: pose ``b`` seen from pose ``a`` (the motion from ``a`` to ``b``)."""
    return compose(inverse(a), b)


def transform_points(pose: NDArray[np.floating], points_xy: NDArray[np.floating]) -> F64:
    """Maps points (..., M, 2) from the frame of ``pose`` (..., 3) into the frame the pose lives in."""
    pose = np.asarray(pose, dtype=np.float64)
    p = np.asarray(points_xy, dtype=np.float64)
    c = np.cos(pose[..., 2])[..., None]
    s = np.sin(pose[..., 2])[..., None]
    x = pose[..., 0, None] + c * p[..., 0] - s * p[..., 1]
    y = pose[..., 1, None] + s * p[..., 0] + c * p[..., 1]
    return np.stack([x, y], axis=-1)


def interpolate_poses(
    stamps_ns: NDArray[np.int64], poses: NDArray[np.floating], query_ns: NDArray[np.int64]
) -> F64:
    """Linearly interpolates poses (N, 3) stamped ``stamps_ns`` (sorted) at ``query_ns`` (M,).

    Headings are interpolated along the shorter arc.  Queries before the first or after the last stamp
    take the nearest end pose (no extrapolation).
    """
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    q = np.asarray(query_ns, dtype=np.int64)
    poses = np.asarray(poses, dtype=np.float64)
    if len(stamps) == 1:
        return np.repeat(poses[:1], len(q), axis=0)
    hi = np.clip(np.searchsorted(stamps, q, side="left"), 1, len(stamps) - 1)
    lo = hi - 1
    span = (stamps[hi] - stamps[lo]).astype(np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        u = np.where(span > 0, (q - stamps[lo]).astype(np.float64) / span, 1.0)
    u = np.clip(u, 0.0, 1.0)[:, None]
    a, b = poses[lo], poses[hi]
    d = b - a
    d[:, 2] = wrap_angle(d[:, 2])
    out = a + u * d
    out[:, 2] = wrap_angle(out[:, 2])
    return out


def yaw_to_quaternion(yaw_rad: NDArray[np.floating] | float) -> F64:
    """Unit quaternion(s) ``[..., 4] = [x, y, z, w]`` for a rotation about +z."""
    h = 0.5 * np.asarray(yaw_rad, dtype=np.float64)
    zeros = np.zeros_like(h)
    return np.stack([zeros, zeros, np.sin(h), np.cos(h)], axis=-1)


def quaternion_to_yaw(q_xyzw: NDArray[np.floating]) -> F64:
    """Heading about +z of quaternion(s) ``[..., 4] = [x, y, z, w]`` (roll and pitch ignored)."""
    q = np.asarray(q_xyzw, dtype=np.float64)
    x, y, z, w = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    return np.asarray(np.arctan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))
