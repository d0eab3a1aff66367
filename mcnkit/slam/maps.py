"""Per-particle maps: hit accumulators in copy-on-write tiles (the output map is :mod:`mcnkit.slam.raycast`'s).

**Particle maps** (as in OpenSLAM gmapping's particle maps, where only beam end points are written): each
cell counts the beams that ended in it and keeps the *mean* of those end points (sub-cell precision).  A
cell is addressed by the global integers ``ix = floor(x_m / res)``, ``iy = floor(y_m / res)``.  Cells are
grouped in square tiles of ``tile_cells``² cells; every particle has a table of tile ids (N, TH, TW) into
one shared pool.  After resampling, copies share tiles (reference counted); a write to a shared tile first
copies it (copy on write).  The table grows by ``enlarge_m`` when a scan leaves it.
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from mcnkit.slam.limits import MAX_TABLE_BYTES, MapLimitError
from mcnkit.types import GridSpec

__all__ = ["MAX_TABLE_BYTES", "MapLimitError", "TiledHitMaps", "cell_of"]


F64 = NDArray[np.float64]
I32 = NDArray[np.int32]


@numba.njit(cache=True, inline="always")
def cell_of(table: I32, p: int, ix: int, iy: int, tx0: int, ty0: int, shift: int) -> int:
    """Flat pool index of cell (ix, iy) in particle ``p``'s map, or -1 where no tile holds it."""
    tx = (ix >> shift) - tx0
    ty = (iy >> shift) - ty0
    if tx < 0 or ty < 0 or ty >= table.shape[1] or tx >= table.shape[2]:
        return -1
    t = table[p, ty, tx]
    if t < 0:
        return -1
    mask = (1 << shift) - 1
    return (t << (2 * shift)) + ((iy & mask) << shift) + (ix & mask)


@numba.njit(cache=True)
def _integrate(
    table: I32,
    tx0: int,
    ty0: int,
    shift: int,
    count: I32,
    mean_x: NDArray[np.float32],
    mean_y: NDArray[np.float32],
    refcount: I32,
    free_stack: I32,
    n_free: int,
    end_x: F64,
    end_y: F64,
    res: float,
) -> int:
    """Adds end points (N, M) in metres (NaN = skip) to each particle's map; returns the new free count."""
    tile_size = 1 << (2 * shift)
    mask = (1 << shift) - 1
    for p in range(end_x.shape[0]):
        for i in range(end_x.shape[1]):
            x = end_x[p, i]
            y = end_y[p, i]
            if math.isnan(x):
                continue
            ix = int(math.floor(x / res))
            iy = int(math.floor(y / res))
            ty = (iy >> shift) - ty0
            tx = (ix >> shift) - tx0
            t = table[p, ty, tx]
            if t < 0:  # a new tile
                n_free -= 1
                t = free_stack[n_free]
                base = t * tile_size
                count[base : base + tile_size] = 0
                refcount[t] = 1
                table[p, ty, tx] = t
            elif refcount[t] > 1:  # shared: copy on write
                n_free -= 1
                u = free_stack[n_free]
                src, dst = t * tile_size, u * tile_size
                count[dst : dst + tile_size] = count[src : src + tile_size]
                mean_x[dst : dst + tile_size] = mean_x[src : src + tile_size]
                mean_y[dst : dst + tile_size] = mean_y[src : src + tile_size]
                refcount[t] -= 1
                refcount[u] = 1
                table[p, ty, tx] = u
                t = u
            c = (t << (2 * shift)) + ((iy & mask) << shift) + (ix & mask)
            n = count[c] + 1
            count[c] = n
            # mean of the end points, stored relative to the cell corner for float32 precision
            mean_x[c] += np.float32((x - ix * res - mean_x[c]) / n)
            mean_y[c] += np.float32((y - iy * res - mean_y[c]) / n)
    return n_free


@numba.njit(cache=True)
def _hit_points(
    table: I32, tx0: int, ty0: int, shift: int, count: I32, mean_x: NDArray[np.float32], mean_y: NDArray[np.float32],
    p: int, tx_lo: int, ty_lo: int, tx_hi: int, ty_hi: int, res: float,
) -> F64:
    """Mean hit points (K, 2) of particle ``p``'s cells with hits in tiles tx_lo..tx_hi × ty_lo..ty_hi."""
    side = 1 << shift
    n = 0
    for pass_ in range(2):
        if pass_ == 1:
            out = np.empty((n, 2))
            n = 0
        for ty in range(max(ty_lo, ty0), min(ty_hi, ty0 + table.shape[1] - 1) + 1):
            for tx in range(max(tx_lo, tx0), min(tx_hi, tx0 + table.shape[2] - 1) + 1):
                t = table[p, ty - ty0, tx - tx0]
                if t < 0:
                    continue
                base = t << (2 * shift)
                for cy in range(side):
                    for cx in range(side):
                        c = base + (cy << shift) + cx
                        if count[c] > 0:
                            if pass_ == 1:
                                out[n, 0] = (tx * side + cx) * res + mean_x[c]
                                out[n, 1] = (ty * side + cy) * res + mean_y[c]
                            n += 1
    return out


class TiledHitMaps:
    """The hit-accumulator maps of N particles, stored as shared copy-on-write tiles.

    Args:
        n_particles: N.
        resolution_m: cell size.
        tile_cells: tile side in cells (power of two).
        enlarge_m: margin added around the area a scan needs when the tile table grows.
    """

    def __init__(self, n_particles: int, resolution_m: float, tile_cells: int = 16, enlarge_m: float = 10.0):
        self.resolution_m = float(resolution_m)
        self.shift = int(tile_cells).bit_length() - 1
        self.tile_cells = 1 << self.shift
        self.enlarge_tiles = max(1, math.ceil(enlarge_m / (self.resolution_m * self.tile_cells)))
        self.table = np.full((n_particles, 0, 0), -1, dtype=np.int32)  # (N, TH, TW) tile ids
        self.tx0 = 0
        self.ty0 = 0
        self.count = np.zeros(0, dtype=np.int32)  # (P·T²,) hits per cell
        self.mean_x = np.zeros(0, dtype=np.float32)  # (P·T²,) mean end point - cell corner, metres
        self.mean_y = np.zeros(0, dtype=np.float32)
        self.refcount = np.zeros(0, dtype=np.int32)  # (P,) particles using each tile
        self.free_stack = np.zeros(0, dtype=np.int32)
        self.n_free = 0

    @property
    def n_particles(self) -> int:
        """N."""
        return int(self.table.shape[0])

    @property
    def n_tiles_used(self) -> int:
        """Tiles referenced by at least one particle."""
        return int(np.count_nonzero(self.refcount))

    @property
    def nbytes(self) -> int:
        """Memory held by the pool and the tables."""
        arrays = (self.table, self.count, self.mean_x, self.mean_y, self.refcount, self.free_stack)
        return int(sum(a.nbytes for a in arrays))

    def _cover(self, end_x: F64, end_y: F64) -> None:
        """Grows the tile table so that every finite end point lies in it."""
        finite = np.isfinite(end_x)
        if not finite.any():
            return
        span = self.resolution_m * self.tile_cells
        lo_x = math.floor(float(end_x[finite].min()) / span)
        hi_x = math.floor(float(end_x[finite].max()) / span)
        lo_y = math.floor(float(end_y[finite].min()) / span)
        hi_y = math.floor(float(end_y[finite].max()) / span)
        n, th, tw = self.table.shape
        if th and lo_x >= self.tx0 and lo_y >= self.ty0 and hi_x < self.tx0 + tw and hi_y < self.ty0 + th:
            return
        e = self.enlarge_tiles
        if th:
            lo_x, lo_y = min(lo_x, self.tx0), min(lo_y, self.ty0)
            hi_x, hi_y = max(hi_x, self.tx0 + tw - 1), max(hi_y, self.ty0 + th - 1)
        new_tx0, new_ty0 = lo_x - e, lo_y - e
        shape = (n, hi_y + e - new_ty0 + 1, hi_x + e - new_tx0 + 1)
        if shape[0] * shape[1] * shape[2] * 4 > MAX_TABLE_BYTES:
            raise MapLimitError(
                f"the map would span {shape[2] * span:.0f} m × {shape[1] * span:.0f} m, {shape[0]} particles × "
                f"{shape[1] * shape[2] * 4 / 2**20:.0f} MiB of tile tables, more than the limit of "
                f"{MAX_TABLE_BYTES / 2**30:.0f} GiB")
        table = np.full(shape, -1, dtype=np.int32)
        oy, ox = self.ty0 - new_ty0, self.tx0 - new_tx0
        table[:, oy : oy + th, ox : ox + tw] = self.table
        self.table, self.tx0, self.ty0 = table, new_tx0, new_ty0

    def _reserve(self, n_tiles: int) -> None:
        """Makes sure at least ``n_tiles`` tiles are free in the pool (doubling it when needed)."""
        if self.n_free >= n_tiles:
            return
        old = len(self.refcount)
        new = max(old + old // 4, old + n_tiles - self.n_free, 256)  # grow by 25 %: peak memory matters
        size = self.tile_cells**2
        self.count = np.concatenate([self.count, np.zeros((new - old) * size, np.int32)])
        self.mean_x = np.concatenate([self.mean_x, np.zeros((new - old) * size, np.float32)])
        self.mean_y = np.concatenate([self.mean_y, np.zeros((new - old) * size, np.float32)])
        self.refcount = np.concatenate([self.refcount, np.zeros(new - old, np.int32)])
        stack = np.concatenate([self.free_stack[: self.n_free], np.arange(new - 1, old - 1, -1, dtype=np.int32)])
        self.free_stack, self.n_free = stack, len(stack)

    def _tiles_needed(self, end_x: F64, end_y: F64) -> int:
        """How many tiles a write of these end points may take from the pool: new tiles and shared ones."""
        p, i = np.nonzero(np.isfinite(end_x))
        span = self.resolution_m * self.tile_cells
        tx = np.floor(end_x[p, i] / span).astype(np.int64) - self.tx0
        ty = np.floor(end_y[p, i] / span).astype(np.int64) - self.ty0
        _, th, tw = self.table.shape
        slots = np.unique((p * th + ty) * tw + tx)  # distinct (particle, tile) pairs written
        tiles = self.table.reshape(-1)[slots]
        shared = tiles[tiles >= 0]
        return int(np.count_nonzero(tiles < 0) + np.count_nonzero(self.refcount[shared] > 1))

    def integrate(self, end_x: F64, end_y: F64) -> None:
        """Adds beam end points (N, M) in metres, one row per particle (NaN entries are skipped)."""
        end_x = np.ascontiguousarray(end_x, dtype=np.float64)
        end_y = np.ascontiguousarray(end_y, dtype=np.float64)
        self._cover(end_x, end_y)
        self._reserve(self._tiles_needed(end_x, end_y))
        self.n_free = _integrate(
            self.table,
            self.tx0,
            self.ty0,
            self.shift,
            self.count,
            self.mean_x,
            self.mean_y,
            self.refcount,
            self.free_stack,
            self.n_free,
            end_x,
            end_y,
            self.resolution_m,
        )

    def hit_points(self, p: int, x_min_m: float, y_min_m: float, x_max_m: float, y_max_m: float) -> F64:
        """The mean hit points (K, 2) of particle ``p``'s cells in (the tiles overlapping) a box, in metres."""
        span = self.resolution_m * self.tile_cells
        if self.table.shape[1] == 0:
            return np.zeros((0, 2))
        return _hit_points(self.table, self.tx0, self.ty0, self.shift, self.count, self.mean_x, self.mean_y, int(p),
                           math.floor(x_min_m / span), math.floor(y_min_m / span), math.floor(x_max_m / span),
                           math.floor(y_max_m / span), self.resolution_m)

    def rebuild_shared(self, end_x: F64, end_y: F64) -> None:
        """Replaces every particle's map by one map of the end points (M,) in metres, shared by all.

        After a loop closure moved the trajectory the particles' maps are rebuilt on it: one pool of tiles,
        referenced by every particle (copy on write keeps later writes apart)."""
        n = self.n_particles
        # the old pool goes first: the rebuilt one takes its place instead of adding to the peak
        self.table = np.full((n, 0, 0), -1, dtype=np.int32)
        self.count = np.zeros(0, np.int32)
        self.mean_x = self.mean_y = np.zeros(0, np.float32)
        self.refcount = self.free_stack = np.zeros(0, np.int32)
        one = TiledHitMaps(1, self.resolution_m, self.tile_cells)
        one.enlarge_tiles = self.enlarge_tiles
        one.integrate(np.asarray(end_x, np.float64)[None, :], np.asarray(end_y, np.float64)[None, :])
        self.table = np.ascontiguousarray(np.repeat(one.table, n, axis=0))
        self.tx0, self.ty0 = one.tx0, one.ty0
        self.count, self.mean_x, self.mean_y = one.count, one.mean_x, one.mean_y
        self.refcount = (one.refcount * n).astype(np.int32)
        self.free_stack, self.n_free = one.free_stack, one.n_free

    def resample(self, indices: NDArray[np.integer]) -> None:
        """Particle k becomes a copy of particle ``indices[k]``: tables are copied, tiles shared."""
        self.table = np.ascontiguousarray(self.table[np.asarray(indices)])
        used = self.table[self.table >= 0]
        self.refcount = np.bincount(used, minlength=len(self.refcount)).astype(np.int32)
        free = np.flatnonzero(self.refcount == 0).astype(np.int32)[::-1]
        self.free_stack = np.ascontiguousarray(free)
        self.n_free = len(free)

    def dense(self, p: int) -> tuple[GridSpec, I32, F64, F64]:
        """Particle ``p``'s map as dense arrays: grid, hits (H, W), mean end point x, y (NaN where no hit)."""
        _n, th, tw = self.table.shape
        t = self.tile_cells
        spec = GridSpec(
            self.resolution_m,
            self.tx0 * t * self.resolution_m,
            self.ty0 * t * self.resolution_m,
            max(tw * t, 1),
            max(th * t, 1),
        )
        hits = np.zeros(spec.shape, np.int32)
        mx = np.full(spec.shape, np.nan)
        my = np.full(spec.shape, np.nan)
        size = t * t
        for ty, tx in zip(*np.nonzero(self.table[p] >= 0), strict=True):
            tid = int(self.table[p, ty, tx])
            block = (slice(ty * t, (ty + 1) * t), slice(tx * t, (tx + 1) * t))
            c = self.count[tid * size : (tid + 1) * size].reshape(t, t)
            hits[block] = c
            cols = np.arange(t) + (self.tx0 + tx) * t
            rows = np.arange(t) + (self.ty0 + ty) * t
            ox = self.mean_x[tid * size : (tid + 1) * size].reshape(t, t) + cols[None, :] * self.resolution_m
            oy = self.mean_y[tid * size : (tid + 1) * size].reshape(t, t) + rows[:, None] * self.resolution_m
            mx[block] = np.where(c > 0, ox, np.nan)
            my[block] = np.where(c > 0, oy, np.nan)
        return spec, hits, mx, my
