"""The scan-matched proposal: gmapping's hill climbing and scoring, for all particles in one compiled call.

Score of a pose (gmapping ``ScanMatcher::score``): for each usable beam, its end point ``e`` and the cells
in the (2k+1)² neighbourhood of ``e``'s cell that hold a hit (with ``free_check``, only those whose cell one
step, √2 · resolution, back along the beam holds none); ``d`` is the distance from ``e`` to the nearest such
cell's mean hit point; the beam adds ``exp(-d²/sigma)``.  The log-likelihood for the importance weight adds
``-d²/lsigma`` per beam, or ``-0.5/lsigma`` when no cell matched.

Hill climbing (``ScanMatcher::optimize``): from the predicted pose try ±lstep in world x and y and ±astep in
heading, move to the best improving candidate; when nothing improves halve both steps; stop when nothing
improves after ``iterations`` halvings.  A match scoring ≤ ``minimum_score`` keeps the predicted pose.

Everything runs in numba: particles one after the other, each against a dense window of its own map near
the scan (:mod:`mcnkit.slam.window`), about 115 score evaluations of 361 beams per particle on MIT CSAIL.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose
from mcnkit.slam.config import MatchingConfig, SlamConfig
from mcnkit.slam.maps import TiledHitMaps, cell_of
from mcnkit.slam.window import MapArrays, Window, end_points, fill_window, no_window, window

__all__ = ["MatchResult", "beam_points", "match_particles", "match_scans_to_map", "score_poses"]

F64 = NDArray[np.float64]
I32 = NDArray[np.int32]
F32 = NDArray[np.float32]
I64 = NDArray[np.int64]
Beams = tuple[F64, F64, F64, F64]  # end x, end y, back x, back y (M,) in the base frame


@dataclass(frozen=True)
class MatchResult:
    """Per particle: the matched pose (N, 3), its match score (N,) and log-likelihood (N,)."""

    poses: F64
    scores: F64
    log_likelihoods: F64


_jit = numba.njit(cache=True, fastmath=True, error_model="numpy")


@_jit
def _evaluate(
    maps: MapArrays,
    win: Window,
    p: int,
    px: float,
    py: float,
    pt: float,
    beams: Beams,
    res: float,
    kernel: int,
    free_check: bool,
    sigma: float,
    lsigma: float,
) -> tuple[float, float]:
    """(score, log-likelihood) of base pose (px, py, pt) for particle ``p``; beams (M,) in the base frame."""
    table, tx0, ty0, shift, count, mean_x, mean_y = maps
    bx, by, fx, fy = beams
    c = math.cos(pt)
    s = math.sin(pt)
    inv = 1.0 / res
    inv_sigma = 1.0 / sigma  # multiplications in the beam loop: a division there costs as much as the rest
    inv_lsigma = 1.0 / lsigma
    score = 0.0
    loglik = 0.0
    no_hit = -0.5 / lsigma
    for i in range(bx.shape[0]):
        x = px + c * bx[i] - s * by[i]
        y = py + s * bx[i] + c * by[i]
        ix = int(math.floor(x * inv))
        iy = int(math.floor(y * inv))
        best = 1e300
        ifx = 0
        ify = 0
        if free_check:
            ifx = int(math.floor((px + c * fx[i] - s * fy[i]) * inv))
            ify = int(math.floor((py + s * fx[i] + c * fy[i]) * inv))
        for dy in range(-kernel, kernel + 1):
            for dx in range(-kernel, kernel + 1):
                cell = cell_of(table, p, ix + dx, iy + dy, tx0, ty0, shift)
                if cell < 0 or count[cell] == 0:
                    continue
                if free_check:
                    fcell = cell_of(table, p, ifx + dx, ify + dy, tx0, ty0, shift)
                    if fcell >= 0 and fcell != cell and count[fcell] > 0:
                        continue
                ex = x - ((ix + dx) * res + mean_x[cell])
                ey = y - ((iy + dy) * res + mean_y[cell])
                d2 = ex * ex + ey * ey
                if d2 < best:
                    best = d2
        if best < 1e300:
            score += math.exp(-best * inv_sigma)
            loglik -= best * inv_lsigma
        else:
            loglik += no_hit
    return score, loglik


@_jit
def _evaluate_k1(
    maps: MapArrays,
    win: Window,
    p: int,
    px: float,
    py: float,
    pt: float,
    beams: Beams,
    res: float,
    sigma: float,
    lsigma: float,
) -> tuple[float, float]:
    """:func:`_evaluate` for gmapping's defaults (3 × 3 kernel, no free check), with constant loop bounds."""
    table, tx0, ty0, shift, count, mean_x, mean_y = maps
    wm, usable, _, wx0, wy0 = win
    bx, by = beams[0], beams[1]
    h, w = wm.shape[0], wm.shape[1]
    c = math.cos(pt)
    s = math.sin(pt)
    inv = 1.0 / res
    inv_sigma = 1.0 / sigma  # multiplications in the beam loop: a division there costs as much as the rest
    inv_lsigma = 1.0 / lsigma
    score = 0.0
    loglik = 0.0
    for i in range(bx.shape[0]):
        x = px + c * bx[i] - s * by[i]
        y = py + s * bx[i] + c * by[i]
        ix = int(math.floor(x * inv))
        iy = int(math.floor(y * inv))
        best = 1e300
        lx = ix - wx0
        ly = iy - wy0
        if 0 <= lx < w and 0 <= ly < h and usable[ly >> shift, lx >> shift] == 1:
            # dense window, branch-free: a cell without hits (offset -1) yields a huge distance
            ox0 = x - (ix - 1) * res
            oy0 = y - (iy - 1) * res
            for dy in range(3):
                for dx in range(3):
                    ox = wm[ly + dy - 1, lx + dx - 1, 0]
                    ex = ox0 - dx * res - ox
                    ey = oy0 - dy * res - wm[ly + dy - 1, lx + dx - 1, 1]
                    d2 = ex * ex + ey * ey
                    d2 = d2 if ox >= 0.0 else 1e300
                    best = min(best, d2)
        else:
            for dy in range(-1, 2):
                for dx in range(-1, 2):
                    cell = cell_of(table, p, ix + dx, iy + dy, tx0, ty0, shift)
                    if cell < 0 or count[cell] == 0:
                        continue
                    ex = x - ((ix + dx) * res + mean_x[cell])
                    ey = y - ((iy + dy) * res + mean_y[cell])
                    best = min(best, ex * ex + ey * ey)
        if best < 1e300:
            score += math.exp(-best * inv_sigma)
            loglik -= best * inv_lsigma
        else:
            loglik -= 0.5 * inv_lsigma
    return score, loglik


@_jit
def _score(
    maps: MapArrays,
    win: Window,
    p: int,
    px: float,
    py: float,
    pt: float,
    beams: Beams,
    res: float,
    kernel: int,
    free_check: bool,
    sigma: float,
    lsigma: float,
) -> tuple[float, float]:
    if kernel == 1 and not free_check:
        return _evaluate_k1(maps, win, p, px, py, pt, beams, res, sigma, lsigma)
    return _evaluate(maps, win, p, px, py, pt, beams, res, kernel, free_check, sigma, lsigma)


_AROUND = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0], [1.0, 1.0], [-1.0, -1.0], [1.0, -1.0],
                    [-1.0, 1.0]])
"""The eight neighbours :func:`_pinned` reads the score's curvature from, in steps of h."""


@_jit
def _pinned(
    maps: MapArrays, win: Window, p: int, x0: float, y0: float, cx: float, cy: float, ct: float, f0: float,
    beams: Beams, res: float, kernel: int, free_check: bool, sigma: float, lsigma: float, ratio: float,
) -> tuple[float, float]:
    """The matched position (cx, cy) with its move from the predicted (x0, y0) kept only along the directions the
    score pins down (``MatchingConfig.pinned_ratio``): the score's curvature in x and y by central differences of three
    cells (a one-cell step reads the noise of a flat score as curvature), its two eigen-directions, the weaker one's
    move scaled by its share of the stronger (over ``ratio``)."""
    h = 3.0 * res
    f = np.empty(8)  # at (+x, -x, +y, -y, ++, --, +-, -+) · h
    for k in range(8):
        f[k] = _score(maps, win, p, cx + h * _AROUND[k, 0], cy + h * _AROUND[k, 1], ct, beams, res, kernel,
                      free_check, sigma, lsigma)[0]
    fxp, fxm, fyp, fym, fpp, fmm, fpm, fmp = f[0], f[1], f[2], f[3], f[4], f[5], f[6], f[7]
    hxx = -(fxp - 2.0 * f0 + fxm)
    hyy = -(fyp - 2.0 * f0 + fym)
    hxy = -(fpp - fpm - fmp + fmm) / 4.0
    half = 0.5 * (hxx + hyy)
    disc = math.sqrt(max(0.25 * (hxx - hyy) ** 2 + hxy * hxy, 0.0))
    l1, l2 = half + disc, half - disc
    if l1 <= 0.0:
        return x0, y0  # nothing curves: the scan pins no direction down
    if abs(hxy) > 1e-12 * l1:
        v1x, v1y = l1 - hyy, hxy
        norm = math.hypot(v1x, v1y)
        v1x, v1y = v1x / norm, v1y / norm
    elif hxx >= hyy:
        v1x, v1y = 1.0, 0.0
    else:
        v1x, v1y = 0.0, 1.0
    w2 = min(max(l2 / (ratio * l1), 0.0), 1.0)
    dx, dy = cx - x0, cy - y0
    a1 = v1x * dx + v1y * dy
    a2 = (-v1y * dx + v1x * dy) * w2
    return x0 + a1 * v1x - a2 * v1y, y0 + a1 * v1y + a2 * v1x


@_jit
def _match_all(
    maps: MapArrays,
    win: Window,
    particles: I64,
    poses: F64,
    beams: Beams,
    prefilled: bool,
    res: float,
    kernel: int,
    free_check: bool,
    sigma: float,
    lsigma: float,
    lstep: float,
    astep: float,
    iterations: int,
    minimum_score: float,
    pinned_ratio: float,
) -> tuple[F64, F64, F64]:
    n = poses.shape[0]
    out = poses.copy()
    scores = np.zeros(n)
    logliks = np.zeros(n)
    use_window = win[2].shape[0] > 0 and not prefilled  # fill and empty the window per particle
    for j in range(n):
        p = particles[j]  # whose map pose j is matched against
        if use_window:
            fill_window(maps, p, win, True)
        cx, cy, ct = poses[j, 0], poses[j, 1], poses[j, 2]
        cur, _ = _score(maps, win, p, cx, cy, ct, beams, res, kernel, free_check, sigma, lsigma)
        ldelta, adelta = lstep, astep
        refinement = 0
        best = -1.0
        skip = -1  # the move back to the previous pose: its score is known to be lower
        while True:
            if best >= cur:
                refinement += 1
                ldelta *= 0.5
                adelta *= 0.5
            best = cur
            nx, ny, nt = cx, cy, ct
            chosen = -1
            for move in range(6):
                if move == skip:
                    continue
                qx, qy, qt = cx, cy, ct
                if move == 0:
                    qx += ldelta
                elif move == 1:
                    qx -= ldelta
                elif move == 2:
                    qy -= ldelta
                elif move == 3:
                    qy += ldelta
                elif move == 4:
                    qt += adelta
                else:
                    qt -= adelta
                sc, _ = _score(maps, win, p, qx, qy, qt, beams, res, kernel, free_check, sigma, lsigma)
                if sc > cur:
                    cur = sc
                    nx, ny, nt = qx, qy, qt
                    chosen = move
            cx, cy, ct = nx, ny, nt
            skip = chosen ^ 1 if chosen >= 0 else -1  # moves come in opposite pairs (0, 1), (2, 3), (4, 5)
            if not (cur > best or refinement < iterations):
                break
        scores[j] = best
        if best > minimum_score:
            if pinned_ratio > 0.0:
                cx, cy = _pinned(maps, win, p, poses[j, 0], poses[j, 1], cx, cy, ct, best, beams, res, kernel,
                                 free_check, sigma, lsigma, pinned_ratio)
            out[j, 0], out[j, 1], out[j, 2] = cx, cy, ct
        _, ll = _score(maps, win, p, out[j, 0], out[j, 1], out[j, 2], beams, res, kernel, free_check, sigma, lsigma)
        logliks[j] = ll
        if use_window:
            fill_window(maps, p, win, False)
    out[:, 2] = (out[:, 2] + np.pi) % (2.0 * np.pi) - np.pi
    return out, scores, logliks


def beam_points(
    ranges_m: NDArray[np.floating],
    angles_rad: F64,
    base_to_laser: F64,
    max_range_m: float,
    max_usable_range_m: float,
    back_m: float,
    lskip: int = 0,
) -> tuple[F64, F64]:
    """End points (M', 2) and points ``back_m`` before them (M', 2), in the base frame, of usable beams.

    A beam is usable when finite, > 0, ≤ ``max_range_m`` and ≤ ``max_usable_range_m``; with ``lskip`` > 0
    only every (lskip + 1)-th beam is kept.
    """
    r = np.asarray(ranges_m, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        use = np.isfinite(r) & (r > 0) & (r <= max_range_m) & (r <= max_usable_range_m)
    if lskip:
        use &= np.arange(len(r)) % (lskip + 1) == 0
    r, a = r[use], angles_rad[use]
    end = np.stack([r * np.cos(a), r * np.sin(a)], axis=-1)
    back = np.stack([(r - back_m) * np.cos(a), (r - back_m) * np.sin(a)], axis=-1)
    laser = np.asarray(base_to_laser, dtype=np.float64)
    z = np.zeros((len(r), 1))
    end_b = compose(laser, np.concatenate([end, z], axis=1))[:, :2]
    back_b = compose(laser, np.concatenate([back, z], axis=1))[:, :2]
    return np.ascontiguousarray(end_b), np.ascontiguousarray(back_b)


def _args(maps: TiledHitMaps) -> MapArrays:
    return maps.table, maps.tx0, maps.ty0, maps.shift, maps.count, maps.mean_x, maps.mean_y


def _settings(m: MatchingConfig) -> tuple[int, bool, float, float, float, float, int, float, float]:
    """The matcher's settings in the order :func:`_match_all` takes them."""
    return (m.kernel_size, m.free_check, m.sigma_m2, m.lsigma_m2, m.lstep_m, m.astep_rad, m.iterations,
            m.minimum_score, m.pinned_ratio)


def _beams(end_xy: F64, back_xy: F64) -> Beams:
    return (
        np.ascontiguousarray(end_xy[:, 0], dtype=np.float64),
        np.ascontiguousarray(end_xy[:, 1], dtype=np.float64),
        np.ascontiguousarray(back_xy[:, 0], dtype=np.float64),
        np.ascontiguousarray(back_xy[:, 1], dtype=np.float64),
    )


def match_particles(
    maps: TiledHitMaps, poses: F64, end_xy: F64, back_xy: F64, cfg: SlamConfig, reach_m: float = 0.8
) -> MatchResult:
    """Hill-climbs every particle's pose (N, 3) against its own map; beams (M, 2) in the base frame.

    Each particle's map is first copied into a dense window around the scan's end points (± margin) holding
    the mean hit point of every cell (x, y interleaved, -1 where no hit): a beam then reads three short
    rows of one array instead of going through the tile tables.  End points outside the window fall back to the tiles, so results do not depend on it.
    """
    poses = np.ascontiguousarray(poses, dtype=np.float64)
    use_window = len(end_xy) > 0 and not cfg.matching.free_check and cfg.matching.kernel_size == 1
    reach_tiles = max(1, round(reach_m / (maps.resolution_m * maps.tile_cells)))
    win = window(end_points(poses, end_xy), maps.resolution_m, maps.shift, reach_tiles) if use_window else no_window()
    out, scores, logliks = _match_all(
        _args(maps),
        win,
        np.arange(len(poses), dtype=np.int64),
        poses,
        _beams(end_xy, back_xy),
        False,
        maps.resolution_m,
        *_settings(cfg.matching),
    )
    return MatchResult(out, scores, logliks)


def score_poses(
    maps: TiledHitMaps, particle: int, poses: F64, end_xy: F64, back_xy: F64, cfg: SlamConfig
) -> tuple[F64, F64]:
    """Score and log-likelihood (K,) of candidate poses (K, 3) against one particle's map (tests, plots)."""
    scores, logliks = np.zeros(len(poses)), np.zeros(len(poses))
    beams = _beams(end_xy, back_xy)
    for k, (x, y, t) in enumerate(np.asarray(poses, dtype=np.float64)):
        scores[k], logliks[k] = _evaluate(
            _args(maps),
            no_window(),
            particle,
            x,
            y,
            t,
            beams,
            maps.resolution_m,
            cfg.matching.kernel_size,
            cfg.matching.free_check,
            cfg.matching.sigma_m2,
            cfg.matching.lsigma_m2,
        )
    return scores, logliks


def match_scans_to_map(
    maps: TiledHitMaps,
    particle: int,
    poses: F64,
    scans: list[tuple[F64, F64]],
    cfg: SlamConfig,
    chunk: int = 50,
) -> F64:
    """Hill-climbs each pose (S, 3) with its scan (end points, back points (M, 2) in the base frame) against
    one particle's map, without weights or map changes; scans with no usable beam keep their pose.

    Scans are processed ``chunk`` at a time, each chunk with one dense window around its end points.
    """
    out = np.array(poses, dtype=np.float64)
    use_window = cfg.matching.kernel_size == 1 and not cfg.matching.free_check
    args = _args(maps)
    who = np.array([particle], dtype=np.int64)
    for start in range(0, len(scans), chunk):
        todo = [k for k in range(start, min(start + chunk, len(scans))) if len(scans[k][0])]
        if not todo:
            continue
        win = no_window()
        if use_window:
            points = np.concatenate([end_points(out[k : k + 1], scans[k][0]) for k in todo])
            win = window(points, maps.resolution_m, maps.shift, 2)
            fill_window(args, particle, win, True)
        for k in todo:
            matched, _, _ = _match_all(
                args,
                win,
                who,
                out[k : k + 1].copy(),
                _beams(*scans[k]),
                True,
                maps.resolution_m,
                *_settings(cfg.matching),
            )
            out[k] = matched[0]
    return out
