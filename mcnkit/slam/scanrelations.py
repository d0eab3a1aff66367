"""Relations measured by a log's own scans: a check of a trajectory's shape that needs no reference.

Kümmerle et al. (2009) score a SLAM trajectory on *relations*: relative motions between pairs of scans that a
person verified (:func:`mcnkit.metrics.relations_error`).  Most logs come with no such file, only a "corrected"
trajectory that another SLAM system made.  Where an estimate and that reference disagree, the scans themselves can
say which of the two they support: :func:`scan_relations` matches pairs of scans onto each other and returns the
matched relative motions as :class:`mcnkit.metrics.Relations`, which any trajectory of the log is then scored on with
the same metric.

Each pair ``(i, j)`` is matched so that no trajectory is favoured: scan ``j``'s returns are searched exactly
(branch and bound, :func:`mcnkit.slam.correlative.match_scan`) on a likelihood field of scan ``i``'s returns, in a
window around the relative pose *each* candidate trajectory gives, refined by Gauss-Newton
(:func:`mcnkit.slam.likelihood.refine_match`), and the best-scoring match of all windows is the relation.  A pair is
dropped when its match explains too little of scan ``j`` or pins the translation down along one direction only (a
corridor: the weaker eigenvalue of the match information below ``min_conditioning`` of the stronger).  Scan ``j``'s
returns are used up to ``max_range_m``, scan ``i``'s farther out by the pair's distance and the window: cut at the
same range, a long wall's returns would end at the same distance in both scans and pull the match towards no
motion along the wall.  Scan ``i``'s field is drawn from its outline, not its bare returns: neighbouring returns closer
than ``outline_gap`` of their range are joined by a line (far along a wall, beams 1° apart land metres apart, and
a field of isolated dots would pin a corridor's axis where nothing does).

Two kinds of pairs (:func:`sequential_pairs`, :func:`revisit_pairs`) test two things: consecutive scans test the
local shape (each step's heading and length), scans of different passes through the same place (a loop) test the
global shape, which a trajectory can only get right by closing its loops consistently.  What the scans cannot pin
down goes unchecked: along a corridor's axis the pairs are dropped, so a step-length bias there is not seen, and a
bend that every pass through a loop shares leaves the revisits consistent.

Example (a square room seen from two poses; the match is good to the field's cells, 5 cm, and a trajectory whose
second pose is 3° off scores 3° worse):

    >>> import numpy as np
    >>> wall = np.linspace(-2.0, 2.0, 161)
    >>> room = np.r_[np.c_[wall, wall * 0 + 2], np.c_[wall, wall * 0 - 2], np.c_[wall * 0 + 2, wall], np.c_[wall * 0 - 2, wall]]
    >>> poses = np.array([[0.0, 0.0, 0.0], [0.3, 0.2, 0.1]])
    >>> seen = [(room - p[:2]) @ np.array([[np.cos(p[2]), -np.sin(p[2])], [np.sin(p[2]), np.cos(p[2])]]) for p in poses]
    >>> rel = scan_relations(seen, np.array([0, 1]), np.array([[0, 1]]), [poses])
    >>> bool(np.abs(rel.delta[0] - poses[1]).max() < 0.03)
    True
    >>> from mcnkit.metrics import relations_error
    >>> from mcnkit.types import Trajectory
    >>> bent = poses + [[0, 0, 0], [0, 0, np.radians(3.0)]]
    >>> [round(float(relations_error(Trajectory(np.array([0, 1]), p), rel).rotation_deg[0]), 1) for p in (poses, bent)]
    [0.0, 3.0]
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, relative, wrap_angle
from mcnkit.metrics import Relations, RelationsError, relations_error
from mcnkit.slam.correlative import likelihood_grid, match_scan
from mcnkit.slam.likelihood import refine_match
from mcnkit.slam.proposal import match_information
from mcnkit.types import Scan, Trajectory

__all__ = ["Consistency", "consistency", "outline", "revisit_pairs", "scan_relations", "scan_returns",
           "sequential_pairs"]

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


def scan_returns(scans: Sequence[Scan], max_range_m: float = math.inf) -> list[F64]:
    """Each scan's returns (M, 2) in the base frame (the scanner's mount applied), in beam order, up to
    ``max_range_m`` and short of the scanner's maximum range (a max-range reading is no return)."""
    out = []
    for scan in scans:
        spec, r = scan.spec, scan.ranges_m.astype(np.float64)
        use = scan.valid & (r < min(spec.range_max_m, max_range_m))
        a = spec.angles_rad[use]
        local = np.column_stack([r[use] * np.cos(a), r[use] * np.sin(a), np.zeros(int(use.sum()))])
        out.append(compose(spec.base_to_laser.as_array(), local)[:, :2])
    return out


def outline(points: F64, spacing_m: float, gap: float) -> F64:
    """The returns (M, 2), in beam order, with points every ``spacing_m`` added between neighbours that lie closer
    than ``gap`` times their range (one surface seen by both beams)."""
    if len(points) < 2:
        return points
    a, b = points[:-1], points[1:]
    length = np.hypot(*(b - a).T)
    join = length < gap * np.minimum(np.hypot(*a.T), np.hypot(*b.T))
    steps = np.where(join, np.ceil(length / spacing_m), 0).astype(np.int64)
    owner = np.repeat(np.arange(len(a)), steps)
    frac = (np.arange(int(steps.sum())) - np.repeat(np.cumsum(steps) - steps, steps)) / np.maximum(steps[owner], 1)
    return np.concatenate([points, a[owner] + frac[:, None] * (b - a)[owner]])


def sequential_pairs(n_scans: int, steps: Sequence[int] = (1, 2)) -> I64:
    """Pairs ``(i, i + s)`` (K, 2) for every scan ``i`` and step ``s``: the local shape."""
    pairs = [np.column_stack([np.arange(n_scans - s), np.arange(s, n_scans)]) for s in steps if 0 < s < n_scans]
    return np.concatenate(pairs).astype(np.int64) if pairs else np.zeros((0, 2), np.int64)


def revisit_pairs(poses: F64, *, min_gap_scans: int = 40, max_distance_m: float = 2.5,
                  max_turn_rad: float = 1.0, bin_scans: int = 4) -> I64:
    """Pairs (K, 2) of scans at least ``min_gap_scans`` apart in the log whose poses (N, 3) lie within
    ``max_distance_m`` and ``max_turn_rad`` of each other: one place seen on two passes (the global shape).

    One pair is kept per ``bin_scans`` × ``bin_scans`` block of ``(i, j)``: a pass that runs alongside another
    would otherwise give hundreds of near-identical pairs."""
    poses = np.asarray(poses, np.float64)
    kept: dict[tuple[int, int], tuple[int, int]] = {}
    for i in range(len(poses) - min_gap_scans):
        later = poses[i + min_gap_scans :]
        near = np.hypot(later[:, 0] - poses[i, 0], later[:, 1] - poses[i, 1]) < max_distance_m
        near &= np.abs(wrap_angle(later[:, 2] - poses[i, 2])) < max_turn_rad
        for j in np.flatnonzero(near) + i + min_gap_scans:
            kept.setdefault((i // bin_scans, int(j) // bin_scans), (i, int(j)))
    return np.array(sorted(kept.values()), np.int64).reshape(-1, 2)


def scan_relations(returns_base: Sequence[F64], stamps_ns: I64, pairs: I64, candidates: Sequence[F64], *,
                   max_range_m: float = 20.0, resolution_m: float = 0.05, sigma_m: float = 0.05, window_m: float = 0.4,
                   window_rad: float = math.radians(4.0), min_score: float = 0.4,
                   min_conditioning: float = 0.15, outline_gap: float = 0.15,
                   progress: Callable[[Iterable[NDArray[np.int64]]], Iterable[NDArray[np.int64]]] | None = None,
                   ) -> Relations:
    """The relative motions of ``pairs`` (K, 2) of scans that the scans' own returns say (see the module).

    Args:
        returns_base: per scan, its returns (M, 2) in the base frame, all of them (see ``max_range_m``), in beam
            order (see ``outline_gap``).
        stamps_ns: one stamp per scan, the relations' ``t1_ns`` / ``t2_ns``.
        pairs: scan indices ``(i, j)``.
        candidates: trajectories (N, 3) of the log, one pose per scan; each pair is searched around every one's
            relative pose, so the relations favour none of them.
        max_range_m: scan ``j``'s returns are matched up to this range (see the module).
        resolution_m, sigma_m: cell size and width of the likelihood field of scan ``i``.
        window_m, window_rad: the exact search window around each candidate, ± in x, y and heading.
        min_score: a match must reach this mean likelihood over scan ``j``'s returns ...
        min_conditioning: ... and pin the translation down in both directions (see the module).
        outline_gap: neighbouring returns of scan ``i`` closer than this fraction of their range are joined.
        progress: wraps the iteration over the pairs (e.g. ``tqdm``).
    """
    t1, t2, deltas = [], [], []
    rows: Iterable[NDArray[np.int64]] = np.asarray(pairs, np.int64).reshape(-1, 2)
    for i, j in progress(rows) if progress is not None else rows:
        centres = [relative(np.asarray(poses[i], np.float64), np.asarray(poses[j], np.float64)) for poses in candidates]
        reach_m = max_range_m + max(float(np.hypot(c[0], c[1])) for c in centres) + window_m + 1.0
        a, b = np.asarray(returns_base[i], np.float64), np.asarray(returns_base[j], np.float64)
        a, b = a[np.hypot(a[:, 0], a[:, 1]) < reach_m], b[np.hypot(b[:, 0], b[:, 1]) < max_range_m]
        if len(a) < 10 or len(b) < 10:
            continue
        grid = likelihood_grid(outline(a, resolution_m, outline_gap), resolution_m, sigma_m, window_m + 1.0)
        best = None
        for centre in centres:
            found = match_scan(grid, b, centre, window_m, window_rad)
            found = refine_match(grid, b, found.pose, 2 * resolution_m)
            if best is None or found.score > best.score:
                best = found
        if best is None or best.score < min_score:
            continue
        strength = np.linalg.eigvalsh(match_information(grid, b, best.pose, 1.0)[:2, :2])
        if not (strength[1] > 0 and strength[0] >= min_conditioning * strength[1]):
            continue
        t1.append(stamps_ns[i])
        t2.append(stamps_ns[j])
        deltas.append(best.pose)
    return Relations(np.asarray(t1, np.int64), np.asarray(t2, np.int64), np.asarray(deltas, np.float64).reshape(-1, 3))


@dataclass(frozen=True)
class Consistency:
    """One kind of pairs (sequential or revisits): the relations the scans measured, and each trajectory's error."""

    pairs: int
    """Pairs tried."""
    relations: Relations
    """The relations measured (their stamps are scan indices)."""
    errors: list[RelationsError | None]
    """Per trajectory, its error on them (None when no relation was measured)."""


def consistency(returns_base: Sequence[F64], trajectories: Sequence[F64], *, revisits_of: F64 | None = None,
                progress: Callable[[Iterable[NDArray[np.int64]], str], Iterable[NDArray[np.int64]]] | None = None,
                ) -> dict[str, Consistency]:
    """How well trajectories (each (N, 3), one pose per scan) agree with their log's scans: the relations of
    :func:`sequential_pairs` and of :func:`revisit_pairs` (of ``revisits_of``, default the first trajectory) measured
    around all of them (:func:`scan_relations`), and each one's relations error on them.  ``progress(pairs, kind)``
    wraps the iteration over each kind's pairs."""
    n = len(returns_base)
    index = np.arange(n, dtype=np.int64)  # stamped by scan number: logs with degenerate stamps are fine
    kinds = {"sequential": sequential_pairs(n),
             "revisits": revisit_pairs(trajectories[0] if revisits_of is None else revisits_of)}
    out = {}
    for kind, pairs in kinds.items():
        wrap = None if progress is None else (lambda rows, kind=kind: progress(rows, kind))
        rel = scan_relations(returns_base, index, pairs, trajectories, progress=wrap)
        errors = [relations_error(Trajectory(index, np.asarray(p, np.float64)), rel, 0.0) if len(rel) else None
                  for p in trajectories]
        out[kind] = Consistency(len(pairs), rel, errors)
    return out
