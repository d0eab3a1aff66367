"""Experiment 2's houses: simulate the robot in one house, run SLAM, pool m_T and m_t on the house's window —
and the cache of that result (:meth:`HouseRun.save` / :meth:`HouseRun.load`, one ``.npz`` a house).

The cache file holds every field of :class:`HouseRun` under its own name, the format version and the key of the
settings that shaped the run (:func:`cache_key`); :meth:`HouseRun.load` refuses, with a :class:`RunCacheError`
naming the file, a file of another version (stale), of other settings, or one that is not such a cache or whose
arrays do not fit together (foreign or damaged).
"""

from __future__ import annotations

import hashlib
import json
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mcnkit.experiments.common import map_at, new_lineage, run_slam
from mcnkit.experiments.config import Exp2Config
from mcnkit.grid import pool_to_window
from mcnkit.types import OCCUPIED, UNKNOWN, GridSpec

__all__ = ["CACHE_VERSION", "CURVE_FRACTIONS", "HouseRun", "RunCacheError", "cache_key", "cache_path", "run_house"]

F32 = NDArray[np.float32]

CACHE_VERSION = 3
"""Version of the cache file (3: every field named, with the version and the settings key)."""
CURVE_FRACTIONS = tuple(round(0.1 * i, 1) for i in range(11))
"""Fractions of the run's filter updates at which Experiment 2 also scores (``exp2_curve.*``)."""
_KEY_FIELDS = ("seed", "particles", "size", "lidar_range_m", "lidar_fov_deg", "lidar_beams", "max_duration_s",
               "log_format", "late")
"""The :class:`Exp2Config` fields that shape a house's run (its cache key)."""


class RunCacheError(Exception):
    """A cached house run that cannot be used: another version, other settings, or not such a file."""


@dataclass(frozen=True)
class HouseRun:
    """One house: its window and m_T on it, and m_t pooled on it at the evaluated updates."""

    name: str
    window: GridSpec
    truth: F32
    """(S, S) m_T on the window, its unknown cells counted occupied."""
    exterior: NDArray[np.bool_]
    """(S, S) window cells m_T never observed (outside the outer walls, the padding), counted occupied in
    ``truth``."""
    updates: tuple[int, ...]
    """0-based filter-update indices of ``partials``."""
    partials: F32
    """(len(updates), S, S) pooled m_t."""
    n_updates: int
    n_scans: int
    sim_s: float
    slam_cpu_s: float
    truth_unknown_share: float
    """Share of window cells unknown in m_T before they are counted occupied."""

    def partial_at(self, update: int) -> F32:
        """m_t (S, S) at the 0-based filter update ``update`` (one of :attr:`updates`)."""
        return self.partials[self.updates.index(update)]

    def late_update(self, late: int) -> int:
        """The 0-based filter update of iteration T − ``late``."""
        return max(0, self.n_updates - 1 - late)

    def save(self, path: Path, key: str) -> None:
        """Writes the run to ``path`` (atomically) with the cache version and the settings ``key``."""
        w = self.window
        tmp = path.with_suffix(".tmp.npz")
        np.savez_compressed(
            tmp, version=np.int64(CACHE_VERSION), key=np.asarray(key), name=np.asarray(self.name),
            window_resolution_m=np.float64(w.resolution_m), window_origin_x_m=np.float64(w.origin_x_m),
            window_origin_y_m=np.float64(w.origin_y_m), window_width=np.int64(w.width),
            window_height=np.int64(w.height), truth=self.truth, exterior=self.exterior,
            updates=np.asarray(self.updates, np.int64), partials=self.partials, n_updates=np.int64(self.n_updates),
            n_scans=np.int64(self.n_scans), sim_s=np.float64(self.sim_s), slam_cpu_s=np.float64(self.slam_cpu_s),
            truth_unknown_share=np.float64(self.truth_unknown_share))
        tmp.replace(path)

    @classmethod
    def load(cls, path: Path, key: str) -> HouseRun:
        """Reads a run written by :meth:`save` with the same settings ``key``; raises :class:`RunCacheError`."""
        try:
            with np.load(path, allow_pickle=False) as z:
                fields = {k: z[k] for k in z.files}
        except (OSError, ValueError) as err:
            raise RunCacheError(f"{path}: not a cached house run ({err})") from err
        missing = sorted({"version", "key", *_ARRAYS} - fields.keys())
        if missing:
            raise RunCacheError(f"{path}: not a cached house run of Experiment 2 (no {', '.join(missing)})")
        version = int(fields["version"])
        if version != CACHE_VERSION:
            raise RunCacheError(f"{path}: a stale cache (version {version}; this mcnkit reads version "
                                f"{CACHE_VERSION}): delete it, or run without reusing runs")
        if str(fields["key"]) != key:
            raise RunCacheError(f"{path}: cached with other settings ({fields['key']}, expected {key})")
        run = cls(
            name=str(fields["name"]),
            window=GridSpec(float(fields["window_resolution_m"]), float(fields["window_origin_x_m"]),
                            float(fields["window_origin_y_m"]), int(fields["window_width"]),
                            int(fields["window_height"])),
            truth=fields["truth"], exterior=fields["exterior"],
            updates=tuple(int(k) for k in fields["updates"]), partials=fields["partials"],
            n_updates=int(fields["n_updates"]), n_scans=int(fields["n_scans"]), sim_s=float(fields["sim_s"]),
            slam_cpu_s=float(fields["slam_cpu_s"]), truth_unknown_share=float(fields["truth_unknown_share"]))
        problem = run._shape_problem()
        if problem:
            raise RunCacheError(f"{path}: a damaged cached house run ({problem})")
        return run

    def _shape_problem(self) -> str | None:
        """What does not fit together in the arrays, or None."""
        s = (self.window.height, self.window.width)
        if self.truth.shape != s or self.truth.dtype != np.float32:
            return f"m_T is {self.truth.dtype} {self.truth.shape}, the window {s}"
        if self.exterior.shape != s or self.exterior.dtype != np.bool_:
            return f"the exterior mask is {self.exterior.dtype} {self.exterior.shape}, the window {s}"
        if self.partials.shape != (len(self.updates), *s) or self.partials.dtype != np.float32:
            return f"m_t is {self.partials.dtype} {self.partials.shape}, expected ({len(self.updates)}, {s[0]}, {s[1]})"
        if not all(0 <= k < self.n_updates for k in self.updates):
            return f"updates {self.updates} outside 0..{self.n_updates - 1}"
        return None


_ARRAYS = ("name", "window_resolution_m", "window_origin_x_m", "window_origin_y_m", "window_width", "window_height",
           "truth", "exterior", "updates", "partials", "n_updates", "n_scans", "sim_s", "slam_cpu_s",
           "truth_unknown_share")
"""The named arrays of a cache file besides its version and key."""


def cache_key(cfg: Exp2Config, name: str) -> str:
    """The settings that shape house ``name``'s run, as JSON (with the cache version)."""
    keep = {k: v for k, v in asdict(cfg).items() if k in _KEY_FIELDS}
    return json.dumps({"version": CACHE_VERSION, "map": name, **keep}, sort_keys=True)


def cache_path(runs_dir: Path, key: str) -> Path:
    """Where the run of ``key`` is cached in ``runs_dir``."""
    return runs_dir / f"{hashlib.sha256(key.encode()).hexdigest()[:16]}.npz"


def _updates_of_interest(t: int, late: int) -> tuple[int, ...]:
    """0-based update indices: iteration 1, iteration T − late, and the curve's fractions of the run."""
    ks = {0, max(0, t - 1 - late)} | {int(round(f * (t - 1))) for f in CURVE_FRACTIONS}
    return tuple(sorted(ks))


def run_house(cfg: Exp2Config, name: str, index: int, runs_dir: Path) -> HouseRun:
    """Simulates the robot in one house, runs SLAM, pools m_T and m_t on the house's window; reuses and writes
    the cache in ``runs_dir`` (``cfg.reuse_runs``)."""
    from mcnkit.mcn import map_window
    from mcnkit.sim import LidarConfig, SimConfig, plan_raster, simulate, write_sim_log
    from mcnkit.slam import SlamConfig

    key = cache_key(cfg, name)
    path = cache_path(runs_dir, key)
    if cfg.reuse_runs and path.is_file():
        return HouseRun.load(path, key)
    t0 = time.perf_counter()
    raster = plan_raster(name, houseexpo_source=cfg.houseexpo)
    lidar = LidarConfig(n_beams=cfg.lidar_beams, fov_deg=cfg.lidar_fov_deg, range_max_m=cfg.lidar_range_m)
    sim = simulate(raster, SimConfig(max_duration_s=cfg.max_duration_s, lidar=lidar), seed=cfg.seed)
    sim_s = time.perf_counter() - t0
    slam_cfg = SlamConfig(n_particles=cfg.particles)
    rng = np.random.default_rng([cfg.seed, index])
    if cfg.log_format:
        from mcnkit.io import open_log

        with tempfile.TemporaryDirectory(prefix="mcnkit-exp2-") as tmp:
            log_path = write_sim_log(sim, Path(tmp) / f"run.{cfg.log_format}")
            with open_log(log_path) as log:
                run = run_slam(log.frames(), slam_cfg, rng)
    else:
        run = run_slam(sim.frames, slam_cfg, rng)
    final = map_at(run, -1)
    assert final.spec is not None
    s = final.spec
    bounds = (s.origin_x_m, s.origin_y_m, s.origin_x_m + s.width * s.resolution_m,
              s.origin_y_m + s.height * s.resolution_m)
    window = map_window(bounds, cfg.size, 0.0, s.resolution_m)
    truth_raw = pool_to_window(final, window, outside=UNKNOWN)
    updates = _updates_of_interest(run.n_updates, cfg.late)
    lm = new_lineage(run.slam)
    partials = np.stack([pool_to_window(map_at(run, k, lm), window, outside=UNKNOWN) for k in updates])
    house = HouseRun(name, window, np.where(truth_raw == UNKNOWN, OCCUPIED, truth_raw).astype(np.float32),
                     truth_raw == UNKNOWN, updates, partials.astype(np.float32), run.n_updates, run.n_scans, sim_s,
                     run.cpu_s, float((truth_raw == UNKNOWN).mean()))
    runs_dir.mkdir(parents=True, exist_ok=True)
    house.save(path, key)
    return house
