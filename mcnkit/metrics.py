"""Trajectory metrics: Kümmerle et al. (2009) relations error, ATE and RPE, and TUM trajectory files.

**Relations** (Kümmerle et al., "On measuring the accuracy of SLAM algorithms", 2009): each ground-truth
relation gives the relative motion ``δ*`` of the robot between the scans stamped ``t1`` and ``t2``.  The
estimate's relative motion is ``δ = ⊖x(t1) ⊕ x(t2)``; the error transform is ``e = ⊖δ* ⊕ δ``; the
translation error is ``‖(e_x, e_y)‖`` (metres) and the rotation error ``|e_θ|`` (degrees).  Reported: mean
and standard deviation of these absolute errors over all relations.

**Timestamp matching**: a relation stamp is matched to the trajectory pose with the *nearest* stamp,
provided it lies within ``tolerance_s`` (default 5 ms; scans are ~0.2 s apart and the relation stamps
are the scans' own stamps, so each one matches exactly one scan).  Relations with an end that has no
pose within the tolerance are skipped and counted in ``n_skipped``.

**ATE**: reference poses are matched to estimate poses by nearest stamp (same rule), or, with
``match="order"``, the k-th pose of one to the k-th of the other (for logs whose stamps carry no time, when both
trajectories hold one pose per scan); the estimate is rigidly aligned to the reference (2-D rotation +
translation, least squares); ATE is the RMSE of the position differences.  **RPE**: over consecutive matched
pairs, the relations error with ``δ*`` taken from the reference.

**Refusals**: a score over a few matched poses, or over stamps that cannot be matched, reads like a result and is
not one.  Matching by stamp raises :class:`EvaluationError` when a trajectory's stamps repeat (e.g. all equal:
the log's clock carried no time), and every metric raises it when fewer than ``min_matched`` poses (relations)
or less than ``min_fraction`` of the reference's match; the message says how many matched and what to do.

**Hit cells** (:func:`hit_cells`, needs no reference): how many grid cells the scans' end points fall in when each
scan is placed at its pose.  A trajectory that agrees better with its own scans draws thinner walls, so fewer
cells; comparing the count for an estimate with the count for the reference says which of the two the scans
support, where the reference is itself the output of a SLAM system (the "corrected" Radish logs).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, inverse, quaternion_to_yaw, relative, wrap_angle, yaw_to_quaternion
from mcnkit.types import Scan, Trajectory

__all__ = [
    "AteResult",
    "EvaluationError",
    "Relations",
    "RelationsError",
    "absolute_trajectory_error",
    "align_rigid_2d",
    "align_similarity_2d",
    "hit_cells",
    "match_poses",
    "match_stamps",
    "read_relations",
    "read_tum",
    "relations_error",
    "relative_pose_error",
    "write_tum",
]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


class EvaluationError(ValueError):
    """Two trajectories (or a trajectory and relations) that cannot be scored against each other: too few poses
    match, or stamps that cannot be matched (the message says why and what to do)."""


def _seconds_to_ns(text: str) -> int:
    if "e" in text.lower():  # 1.305031102e+09: through float (nan and inf are not stamps)
        value = float(text)
        if not math.isfinite(value):
            raise ValueError(f"not a time stamp: {text!r}")
        return round(value * 1e9)
    sign = -1 if text.startswith("-") else 1
    whole, _, frac = text.lstrip("+-").partition(".")
    return sign * (int(whole or 0) * 1_000_000_000 + int((frac + "000000000")[:9] or 0))


def _ns_to_seconds(stamp_ns: int) -> str:
    sign = "-" if stamp_ns < 0 else ""
    s, ns = divmod(abs(int(stamp_ns)), 1_000_000_000)
    return f"{sign}{s}.{ns:09d}"


def read_tum(path: Path) -> Trajectory:
    """Reads a TUM file (``t x y z qx qy qz qw`` per line, t in seconds; ``#`` comments) as a planar trajectory."""
    stamps, poses = [], []
    for line in Path(path).read_text().splitlines():
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        if len(tok) != 8:
            raise ValueError(f"{path}: a TUM line has 8 fields, got {len(tok)}: {line!r}")
        q = np.array([float(v) for v in tok[4:8]])
        pose = (float(tok[1]), float(tok[2]), float(quaternion_to_yaw(q)))
        if not (np.isfinite(q).all() and np.isfinite(pose).all()) or not np.any(q):
            raise ValueError(f"{path}: a TUM line with a non-finite position or no rotation: {line!r}")
        stamps.append(_seconds_to_ns(tok[0]))
        poses.append(pose)
    return Trajectory(np.asarray(stamps, dtype=np.int64), np.asarray(poses, dtype=np.float64).reshape(-1, 3))


def write_tum(path: Path, trajectory: Trajectory) -> None:
    """Writes a planar trajectory as TUM lines (z = 0, t with nanosecond digits)."""
    q = yaw_to_quaternion(trajectory.poses[:, 2])
    lines = [
        f"{_ns_to_seconds(t)} {p[0]:.6f} {p[1]:.6f} 0 {qq[0]:.9f} {qq[1]:.9f} {qq[2]:.9f} {qq[3]:.9f}"
        for t, p, qq in zip(trajectory.stamps_ns, trajectory.poses, q, strict=True)
    ]
    Path(path).write_text("\n".join(lines) + "\n")


@dataclass(frozen=True)
class Relations:
    """Ground-truth relations: stamps ``t1_ns``, ``t2_ns`` (K,) and relative motions ``delta`` (K, 3)."""

    t1_ns: I64
    t2_ns: I64
    delta: F64

    def __len__(self) -> int:
        return len(self.t1_ns)


def read_relations(path: Path) -> Relations:
    """Reads a Kümmerle relations file: ``t1 t2 x y z roll pitch yaw`` per line (seconds, metres, radians)."""
    t1, t2, d = [], [], []
    for line in Path(path).read_text().splitlines():
        tok = line.split()
        if not tok or tok[0].startswith("#"):
            continue
        if len(tok) != 8:
            raise ValueError(f"{path}: a relation line has 8 fields, got {len(tok)}: {line!r}")
        t1.append(_seconds_to_ns(tok[0]))
        t2.append(_seconds_to_ns(tok[1]))
        d.append((float(tok[2]), float(tok[3]), float(tok[7])))
    return Relations(np.asarray(t1, np.int64), np.asarray(t2, np.int64), np.asarray(d, np.float64).reshape(-1, 3))


def match_stamps(stamps_ns: I64, query_ns: I64, tolerance_s: float) -> I64:
    """Index of the nearest stamp in sorted ``stamps_ns`` for each query, or -1 when none is within tolerance."""
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    q = np.asarray(query_ns, dtype=np.int64)
    if len(stamps) == 0:
        return np.full(len(q), -1, dtype=np.int64)
    hi = np.clip(np.searchsorted(stamps, q), 1, max(len(stamps) - 1, 1))
    lo = np.maximum(hi - 1, 0)
    nearest = np.where(np.abs(stamps[hi] - q) < np.abs(stamps[lo] - q), hi, lo)
    ok = np.abs(stamps[nearest] - q) <= round(tolerance_s * 1e9)
    return np.where(ok, nearest, -1).astype(np.int64)


@dataclass(frozen=True)
class RelationsError:
    """Absolute relation errors: per relation (K',) and their mean ± std; ``n_skipped`` relations unmatched."""

    translation_m: F64
    rotation_deg: F64
    n_skipped: int

    @property
    def translation_mean_m(self) -> float:
        """Mean translation error."""
        return float(np.mean(self.translation_m)) if len(self.translation_m) else float("nan")

    @property
    def translation_std_m(self) -> float:
        """Standard deviation of the translation error."""
        return float(np.std(self.translation_m)) if len(self.translation_m) else float("nan")

    @property
    def rotation_mean_deg(self) -> float:
        """Mean rotation error."""
        return float(np.mean(self.rotation_deg)) if len(self.rotation_deg) else float("nan")

    @property
    def rotation_std_deg(self) -> float:
        """Standard deviation of the rotation error."""
        return float(np.std(self.rotation_deg)) if len(self.rotation_deg) else float("nan")

    def as_dict(self) -> dict[str, float | int]:
        """Summary numbers for JSON output."""
        return {
            "translation_mean_m": self.translation_mean_m,
            "translation_std_m": self.translation_std_m,
            "rotation_mean_deg": self.rotation_mean_deg,
            "rotation_std_deg": self.rotation_std_deg,
            "n_relations": len(self.translation_m),
            "n_skipped": self.n_skipped,
        }


def _relation_errors(est_delta: F64, ref_delta: F64) -> tuple[F64, F64]:
    e = compose(inverse(ref_delta), est_delta)
    return np.hypot(e[:, 0], e[:, 1]), np.degrees(np.abs(wrap_angle(e[:, 2])))


def relations_error(trajectory: Trajectory, relations: Relations, tolerance_s: float = 0.005, *,
                    min_matched: int = 0, min_fraction: float = 0.0) -> RelationsError:
    """The Kümmerle relations metric of ``trajectory`` (stamps matched as described in the module doc).

    Raises :class:`EvaluationError` when the trajectory's stamps repeat, or fewer than ``min_matched`` relations
    (or less than ``min_fraction`` of them) have both ends matched."""
    traj = _by_stamp(trajectory, "trajectory")
    i = match_stamps(traj.stamps_ns, relations.t1_ns, tolerance_s)
    j = match_stamps(traj.stamps_ns, relations.t2_ns, tolerance_s)
    ok = (i >= 0) & (j >= 0)
    _enough(int(np.count_nonzero(ok)), len(ok), "relations", min_matched, min_fraction,
            f"have both ends within {tolerance_s} s of a trajectory pose",
            "the relations belong to another log, or the trajectory's stamps are not the log's own")
    trajectory = traj
    est = relative(trajectory.poses[i[ok]], trajectory.poses[j[ok]])
    t, r = _relation_errors(est, relations.delta[ok])
    return RelationsError(t, r, int(np.count_nonzero(~ok)))


@dataclass(frozen=True)
class AteResult:
    """Absolute trajectory error after 2-D alignment: RMSE, mean, max (m) over ``n_matched`` poses; ``scale`` is the
    factor the estimate was scaled by (1 for the rigid alignment)."""

    rmse_m: float
    mean_m: float
    max_m: float
    n_matched: int
    scale: float = 1.0

    def as_dict(self) -> dict[str, float | int]:
        """Summary numbers for JSON output."""
        return {"rmse_m": self.rmse_m, "mean_m": self.mean_m, "max_m": self.max_m, "n_matched": self.n_matched,
                "scale": self.scale}


def _by_stamp(trajectory: Trajectory, what: str) -> Trajectory:
    """``trajectory`` in stamp order; :class:`EvaluationError` when stamps repeat (nearest-stamp matching would
    pick one of the poses sharing a stamp at random)."""
    stamps = np.asarray(trajectory.stamps_ns, dtype=np.int64)
    order = np.argsort(stamps, kind="stable")
    sorted_stamps = stamps[order]
    repeats = int(np.count_nonzero(np.diff(sorted_stamps) == 0))
    if repeats:
        distinct = len(sorted_stamps) - repeats
        raise EvaluationError(
            f"the {what}'s stamps repeat ({len(sorted_stamps)} poses, {distinct} distinct stamp"
            f"{'s' if distinct != 1 else ''}): poses cannot be matched by stamp; if both trajectories hold one "
            "pose per scan of the same log, match them by order (--match order)")
    if (order == np.arange(len(order))).all():
        return trajectory
    return Trajectory(sorted_stamps, np.asarray(trajectory.poses)[order])


_NOT_THE_SAME_RUN = ("the trajectories do not cover the same run, or their stamps differ (another clock, or "
                     "rebuilt stamps: try --match order)")


def _enough(n_matched: int, n_total: int, what: str, min_matched: int, min_fraction: float, how: str,
            why: str = _NOT_THE_SAME_RUN) -> None:
    need = max(min_matched, math.ceil(min_fraction * n_total - 1e-9), 1)
    if n_matched < need:
        raise EvaluationError(f"only {n_matched} of {n_total} {what} {how} (at least {need} needed): {why}")


def match_poses(estimate: Trajectory, reference: Trajectory, tolerance_s: float = 0.005, *,
                match: str = "stamp", min_matched: int = 2, min_fraction: float = 0.0) -> tuple[F64, F64]:
    """The estimate's and the reference's poses that correspond, ``(M, 3)`` each.

    ``match="stamp"``: each reference pose with the estimate pose of the nearest stamp within ``tolerance_s``;
    ``match="order"``: the k-th pose of each (both must hold the same number).  :class:`EvaluationError` when
    stamps repeat (by stamp), the counts differ (by order), or fewer than ``min_matched`` poses (or less than
    ``min_fraction`` of the reference's) match."""
    if match == "order":
        if len(estimate) != len(reference):
            raise EvaluationError(f"matching by order needs one estimate pose per reference pose, got "
                                  f"{len(estimate)} estimate and {len(reference)} reference poses")
        _enough(len(reference), len(reference), "reference poses", min_matched, min_fraction, "are present")
        return np.asarray(estimate.poses, np.float64), np.asarray(reference.poses, np.float64)
    if match != "stamp":
        raise ValueError(f"match must be 'stamp' or 'order', got {match!r}")
    est, ref = _by_stamp(estimate, "estimate"), _by_stamp(reference, "reference")
    k = match_stamps(est.stamps_ns, ref.stamps_ns, tolerance_s)
    ok = k >= 0
    _enough(int(np.count_nonzero(ok)), len(ref), "reference poses", min_matched, min_fraction,
            f"have an estimate within {tolerance_s} s")
    return est.poses[k[ok]], ref.poses[ok]


def align_rigid_2d(points: F64, onto: F64) -> F64:
    """``points`` (N, 2) moved by the least-squares rigid 2-D transform (rotation + translation) onto ``onto``."""
    return _aligned_2d(points, onto, with_scale=False)[0]


def align_similarity_2d(points: F64, onto: F64) -> tuple[F64, float]:
    """``points`` (N, 2) moved by the least-squares similarity 2-D transform (rotation, translation and one scale
    factor; Umeyama 1991) onto ``onto``, and that factor.  The ATE left after it is what a difference in size
    between two trajectories does not explain."""
    return _aligned_2d(points, onto, with_scale=True)


def _aligned_2d(points: F64, onto: F64, *, with_scale: bool) -> tuple[F64, float]:
    """The least-squares 2-D rotation and translation (and, ``with_scale``, scale) of ``points`` onto ``onto``."""
    ca, cb = points.mean(axis=0), onto.mean(axis=0)
    centred = points - ca
    h = centred.T @ (onto - cb)
    along, across = h[0, 0] + h[1, 1], h[0, 1] - h[1, 0]
    angle = np.arctan2(across, along)  # rotation maximising alignment (2-D Kabsch)
    rot = np.array([[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]])
    spread = float(np.sum(centred**2))
    scale = float(np.hypot(along, across)) / spread if with_scale and spread > 0 else 1.0
    return scale * centred @ rot.T + cb, scale


def absolute_trajectory_error(estimate: Trajectory, reference: Trajectory, tolerance_s: float = 0.005, *,
                              match: str = "stamp", min_matched: int = 2, min_fraction: float = 0.0,
                              scale: bool = False) -> AteResult:
    """ATE of ``estimate`` against ``reference`` after the least-squares rigid alignment of positions, or with
    ``scale`` the similarity alignment (:func:`align_similarity_2d`); poses matched by :func:`match_poses`, which
    says when it refuses."""
    est, ref = match_poses(estimate, reference, tolerance_s, match=match, min_matched=min_matched,
                           min_fraction=min_fraction)
    aligned, factor = _aligned_2d(est[:, :2], ref[:, :2], with_scale=scale)
    err = np.linalg.norm(aligned - ref[:, :2], axis=1)
    return AteResult(float(np.sqrt(np.mean(err**2))), float(err.mean()), float(err.max()), len(err), factor)


def relative_pose_error(estimate: Trajectory, reference: Trajectory, tolerance_s: float = 0.005, *,
                        match: str = "stamp", min_matched: int = 2, min_fraction: float = 0.0) -> RelationsError:
    """RPE: the relations error over consecutive matched reference poses (matched by :func:`match_poses`)."""
    est, ref = match_poses(estimate, reference, tolerance_s, match=match, min_matched=max(min_matched, 2),
                           min_fraction=min_fraction)
    t, r = _relation_errors(relative(est[:-1], est[1:]), relative(ref[:-1], ref[1:]))
    return RelationsError(t, r, 0)


def hit_cells(scans: Sequence[Scan], poses: F64, resolution_m: float = 0.05, max_range_m: float = 20.0) -> int:
    """The number of ``resolution_m`` cells hit by the returns of ``scans`` placed at ``poses`` (N, 3) of the base.

    Returns beyond ``max_range_m`` are left out: far end points spread with the beam spacing, whatever the
    trajectory.  Fewer cells: walls drawn thinner, a trajectory the scans agree with better (see the module)."""
    if len(scans) != len(poses):
        raise EvaluationError(f"{len(scans)} scans but {len(poses)} poses: hit cells needs one pose per scan")
    keys = []
    for scan, pose in zip(scans, np.asarray(poses, np.float64), strict=True):
        spec, r = scan.spec, scan.ranges_m.astype(np.float64)
        use = scan.valid & (r < min(spec.range_max_m, max_range_m))
        mount = spec.base_to_laser
        laser = compose(pose, np.array([mount.x_m, mount.y_m, mount.yaw_rad]))
        a = laser[2] + spec.angles_rad[use]
        ix = np.floor((laser[0] + r[use] * np.cos(a)) / resolution_m).astype(np.int64)
        iy = np.floor((laser[1] + r[use] * np.sin(a)) / resolution_m).astype(np.int64)
        keys.append((ix << 32) ^ (iy & 0xFFFFFFFF))
    return int(len(np.unique(np.concatenate(keys)))) if keys else 0
