"""Training pairs (m_t, m_T) as 64×64 ternary maps, built once and cached.

HouseExpo pairs (the paper's protocol; ``max_scans > 1``: several scans, see :class:`PairConfig`): m_T = the plan rasterized at the Pseudo-SLAM resolution (free inside,
walls and exterior occupied), m_t = HouseExpo's Pseudo-SLAM map after its first iteration (one scan from a
random free start pose).  Both are padded to a square (m_T with occupied, m_t with unknown, centred) and
resized with :func:`mcnkit.grid.resize_ternary` (occupied > free > unknown).  Split: ``n_train`` + ``n_val`` plans
from the official train list and ``n_test`` from the official test list, each list shuffled with ``seed``;
plans that are absent or invalid are skipped (with reasons) and the next ones in the shuffled order taken.
Every pair draws its start pose from its own generator seeded by ``(seed, plan id)``, so a pair does not depend
on which other pairs were built.

Procedural pairs (the second domain): m_T = a procedural apartment, m_t = m_T with the HOME'S masking.

The cache is ``<dir>/houseexpo-pairs.npz`` (compressed) plus ``houseexpo-pairs.manifest.json`` holding the
source's sha256, the split files' sha256, the config and the seed; a call rebuilds only when one of those
changed or the cache is unreadable.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm import tqdm

from mcnkit.datasets.floorplans import (
    ApartmentConfig,
    apply_mask,
    generate_apartment,
    homes_mask,
    rasterize_apartment,
)
from mcnkit.datasets.houseexpo import FloorPlan, SkipLog, iter_plans, rasterize_plan, read_split, sha256_of
from mcnkit.datasets.pseudoslam import PseudoSlamConfig, PseudoSlamObservation, exploration, free_to_ternary
from mcnkit.grid import SEEN_WINDOW_M, pad_to_square, pool_to_window, resize_ternary, seen_window
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, GridSpec, TernaryMap

__all__ = [
    "CACHE_VERSION",
    "HOUSEEXPO_DOMAINS",
    "PairConfig",
    "PairSet",
    "PairSplits",
    "PairStats",
    "build_houseexpo_pairs",
    "domain_pair_config",
    "houseexpo_pair",
    "load_or_build_houseexpo_pairs",
    "pair_stats",
    "procedural_pairs",
]

F32 = NDArray[np.float32]
CACHE_VERSION = 1
_SPLITS = ("train", "val", "test")


@dataclass(frozen=True)
class PairConfig:
    """Split sizes, seed, map size and the Pseudo-SLAM settings of a pair build (defaults: the paper's).

    ``crop_to_plan``: after the scan (made on HouseExpo's bordered raster), crop both maps to the plan's bounding
    box before padding to a square, so the house fills the 64×64 frame (≈ 57 % free cells, the paper's ≈ 60 %).
    Without it the 35-pixel occupied border stays and only ≈ 30 % of the cells are free.
    """

    n_train: int = 5000
    n_val: int = 200
    n_test: int = 100
    seed: int = 0
    size: int = 64
    pseudoslam: PseudoSlamConfig = field(default_factory=PseudoSlamConfig)
    crop_to_plan: bool = True
    max_scans: int = 1
    """m_t = the union of ``n`` scans, ``n`` uniform in ``1..max_scans`` (:func:`~mcnkit.datasets.pseudoslam.exploration`);
    1 = the paper's first iteration."""
    seen_window: tuple[float, float, float] | None = None
    """``(margin_m, min_side_m, max_side_m)``: both maps on the window an explorer completes
    (:func:`mcnkit.grid.seen_window`: the part m_t has seen plus the margin, centred on the last scan's pose
    when wider than ``max_side_m``; m_T outside the plan occupied) instead of the plan's bounding box, so the net
    learns that the house may end anywhere in the frame or go on past it.  None: the paper's frame."""
    wide_pairs: tuple[int, int] | None = None
    """``(extra, max_scans)``, with ``seen_window`` only: each plan wider than the window's largest side less its two
    margins gives ``extra`` more pairs, each of ``1..max_scans`` scans.  Such plans are where an explorer's window
    is a square around the robot on a map seen farther than the window reaches, a map that pairs of a few scans
    seldom show (each extra pair counts towards the split's size).  None: one pair per plan."""


@dataclass(frozen=True)
class PairSet:
    """``partial`` = m_t and ``target`` = m_T, ternary float32 (N, size, size), with the source plan ids."""

    partial: F32
    target: F32
    ids: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.ids)

    @property
    def partial_mask(self) -> F32:
        """The unknown mask of m_t (1.0 unknown), (N, size, size)."""
        return (self.partial == UNKNOWN).astype(np.float32)

    @property
    def target_mask(self) -> F32:
        """The unknown mask of m_T (1.0 unknown), (N, size, size)."""
        return (self.target == UNKNOWN).astype(np.float32)


@dataclass(frozen=True)
class PairSplits:
    """Train/val/test pair sets plus the build manifest (source digest, config, counts, skips, timing)."""

    train: PairSet
    val: PairSet
    test: PairSet
    manifest: dict[str, Any]


@dataclass(frozen=True)
class PairStats:
    """Per-map means: share of free cells in m_T and share of those free cells already free in m_t."""

    n: int
    free_fraction: float
    observed_share: float
    pooled_observed_share: float


def pair_stats(pairs: PairSet) -> PairStats:
    """Free fraction of m_T and the share of it observed (free) in m_t; per-map means and pooled share."""
    free_t = pairs.target == FREE
    seen = (pairs.partial == FREE) & free_t
    n_free = free_t.sum(axis=(1, 2))
    share = seen.sum(axis=(1, 2)) / np.maximum(n_free, 1)
    return PairStats(
        len(pairs),
        float(free_t.mean(axis=(1, 2)).mean()) if len(pairs) else 0.0,
        float(share.mean()) if len(pairs) else 0.0,
        float(seen.sum() / max(int(n_free.sum()), 1)),
    )


HOUSEEXPO_DOMAINS: dict[str, dict[str, Any]] = {
    "houseexpo": {},  # the paper's pairs: one 180°, 2 m Pseudo-SLAM scan
    # m_t = 1..12 scans of a 360°, 8 m lidar (Experiment 2's robot)
    "houseexpo-explore": {"pseudoslam": PseudoSlamConfig(range_m=8.0, fov_deg=360.0), "max_scans": 12},
    # the same m_t, both maps on the window mcnkit explore completes
    "houseexpo-seen": {"pseudoslam": PseudoSlamConfig(range_m=8.0, fov_deg=360.0), "max_scans": 12,
                       "seen_window": SEEN_WINDOW_M},
    # the same, and 4 more pairs of up to 48 scans from each plan wider than the window: maps seen farther than
    # the window reaches, framed by the square around the robot (else under 1 % of the pairs)
    "houseexpo-seen-wide": {"pseudoslam": PseudoSlamConfig(range_m=8.0, fov_deg=360.0), "max_scans": 12,
                            "seen_window": SEEN_WINDOW_M, "wide_pairs": (4, 48)},
}
"""HouseExpo training domains by name: how each one's :class:`PairConfig` differs from the paper's."""


def domain_pair_config(domain: str, n_train: int, n_val: int = 200, n_test: int = 100, seed: int = 0) -> PairConfig:
    """The :class:`PairConfig` of the HouseExpo domain ``domain`` (a key of :data:`HOUSEEXPO_DOMAINS`)."""
    if domain not in HOUSEEXPO_DOMAINS:
        raise ValueError(f"unknown HouseExpo domain {domain!r} (choose from {', '.join(HOUSEEXPO_DOMAINS)})")
    return PairConfig(n_train=n_train, n_val=n_val, n_test=n_test, seed=seed, **HOUSEEXPO_DOMAINS[domain])


def _pair_rng(seed: int, key: str) -> np.random.Generator:
    return np.random.default_rng([seed, int.from_bytes(hashlib.sha256(key.encode()).digest()[:8], "little")])


def extra_pairs(plan: FloorPlan, config: PairConfig) -> int:
    """How many more pairs ``plan`` gives under ``config.wide_pairs``: its ``extra`` when the plan is wider than the
    seen window's largest side less its two margins (where a well-explored map is framed by a square around the
    robot), else 0."""
    if config.wide_pairs is None or config.seen_window is None:
        return 0
    x0, y0, x1, y1 = plan.bbox_m
    margin_m, _, max_side_m = config.seen_window
    return config.wide_pairs[0] if max(x1 - x0, y1 - y0) > max_side_m - 2 * margin_m else 0


def houseexpo_pair(plan: FloorPlan, config: PairConfig, extra: int = 0) -> tuple[F32, F32]:
    """(m_t, m_T) at ``config.size``² for one plan: rasterize, Pseudo-SLAM scan(s), pad square, resize.

    ``extra`` > 0 draws the plan's ``extra``-th additional pair of ``config.wide_pairs`` (its own random stream,
    up to that option's scan count)."""
    ps = config.pseudoslam
    free, _ = rasterize_plan(plan, 1.0 / ps.px_per_m, ps.border_px)
    rng = _pair_rng(config.seed, plan.id if extra == 0 else f"{plan.id}/{extra}")
    max_scans = config.max_scans if extra == 0 or config.wide_pairs is None else config.wide_pairs[1]
    # the paper's pairs draw no scan count (their draws, and so their caches, predate max_scans)
    n_scans = int(rng.integers(1, max_scans + 1)) if max_scans > 1 else 1
    obs = exploration(free, ps, n_scans, rng)
    observed, truth = obs.observed, obs.ground_truth
    if config.seen_window is not None:
        return _on_seen_window(obs, 1.0 / ps.px_per_m, config.size, config.seen_window)
    b = ps.border_px
    if config.crop_to_plan and b > 0 and min(free.shape) > 2 * b:
        observed, truth = observed[b:-b, b:-b], truth[b:-b, b:-b]
    m_t = resize_ternary(pad_to_square(observed, UNKNOWN), config.size)
    m_T = resize_ternary(pad_to_square(truth, OCCUPIED), config.size)
    return m_t, m_T


def _on_seen_window(obs: PseudoSlamObservation, res_m: float, size: int,
                    window: tuple[float, float, float]) -> tuple[F32, F32]:
    """(m_t, m_T) pooled onto :func:`~mcnkit.grid.seen_window` of m_t's seen cells (rows of the raster are y)."""
    spec = GridSpec(res_m, 0.0, 0.0, obs.observed.shape[1], obs.observed.shape[0])
    rows, cols = np.nonzero(obs.observed != UNKNOWN)
    bounds = (cols.min() * res_m, rows.min() * res_m, (cols.max() + 1) * res_m, (rows.max() + 1) * res_m)
    row, col, _ = obs.last_pose_px or obs.pose_px
    grid = seen_window(bounds, size, *window, min_resolution_m=res_m,
                       centre_xy_m=((col + 0.5) * res_m, (row + 0.5) * res_m))
    return (pool_to_window(TernaryMap(obs.observed, spec), grid, outside=UNKNOWN),
            pool_to_window(TernaryMap(obs.ground_truth, spec), grid, outside=OCCUPIED))


def _stack(items: list[tuple[str, F32, F32]], size: int) -> PairSet:
    if not items:
        empty = np.zeros((0, size, size), np.float32)
        return PairSet(empty, empty.copy(), ())
    return PairSet(
        np.stack([a for _, a, _ in items]), np.stack([b for _, _, b in items]), tuple(i for i, _, _ in items)
    )


def build_houseexpo_pairs(
    source: str | os.PathLike[str],
    train_ids: list[str],
    test_ids: list[str],
    config: PairConfig | None = None,
    progress: bool = True,
) -> PairSplits:
    """Builds the splits from the official id lists (see the module docstring); never stops on a bad plan."""
    cfg = config or PairConfig()
    t0 = time.perf_counter()
    rng = np.random.default_rng(cfg.seed)
    orders = {"train": rng.permutation(train_ids).tolist(), "test": rng.permutation(test_ids).tolist()}
    needs = {"train": cfg.n_train + cfg.n_val, "test": cfg.n_test}
    skips = SkipLog()
    built: dict[str, list[tuple[str, F32, F32]]] = {"train": [], "test": []}
    pos = {"train": 0, "test": 0}
    bar = tqdm(total=sum(needs.values()), desc="pairs", unit="pair", disable=not progress)
    while any(len(built[s]) < needs[s] and pos[s] < len(orders[s]) for s in built):
        # Read the next candidates of each list in one pass over the source (10 % + 50 spare for skips).
        want: dict[str, str] = {}
        for s in built:
            k = needs[s] - len(built[s])
            if k > 0:
                chunk = orders[s][pos[s] : pos[s] + int(k * 1.1) + 50]
                pos[s] += len(chunk)
                want.update(dict.fromkeys(chunk, s))
        plans: dict[str, FloorPlan] = {}
        for plan in iter_plans(source, want.keys(), skips):
            plans[plan.id] = plan
        for pid, s in want.items():  # keep the shuffled order
            if pid not in plans:
                continue
            for extra in range(extra_pairs(plans[pid], cfg) + 1):
                if len(built[s]) >= needs[s]:
                    break
                try:
                    m_t, m_T = houseexpo_pair(plans[pid], cfg, extra)
                except (ValueError, MemoryError) as exc:
                    skips.add(pid, f"build failed: {exc}")
                    break
                built[s].append((pid, m_t, m_T))
                bar.update(1)
    bar.close()
    train = _stack(built["train"][: cfg.n_train], cfg.size)
    val = _stack(built["train"][cfg.n_train :], cfg.size)
    test = _stack(built["test"], cfg.size)
    manifest = {
        "counts": {"train": len(train), "val": len(val), "test": len(test)},
        "skipped": skips.count,
        "skip_reasons": skips.summary(),
        "build_seconds": round(time.perf_counter() - t0, 2),
    }
    return PairSplits(train, val, test, manifest)


def _key(source: Path, train_list: Path, test_list: Path, cfg: PairConfig) -> dict[str, Any]:
    config = dataclasses.asdict(cfg)
    if cfg.max_scans == 1:
        del config["max_scans"]  # caches of the paper's pairs built before the option existed stay valid
    if cfg.seen_window is None:
        del config["seen_window"]  # likewise every cache built before this option
    if cfg.wide_pairs is None:
        del config["wide_pairs"]
    return {
        "version": CACHE_VERSION,
        "source_sha256": sha256_of(source),
        "train_list_sha256": sha256_of(train_list),
        "test_list_sha256": sha256_of(test_list),
        "seed": cfg.seed,
        "config": config,
    }


def _load_cache(npz_path: Path) -> dict[str, PairSet] | None:
    try:
        with np.load(npz_path, allow_pickle=False) as z:
            return {
                s: PairSet(z[f"{s}_partial"], z[f"{s}_target"], tuple(str(i) for i in z[f"{s}_ids"])) for s in _SPLITS
            }
    except (OSError, KeyError, ValueError, EOFError):
        return None


def load_or_build_houseexpo_pairs(
    source: str | os.PathLike[str],
    cache_dir: str | os.PathLike[str],
    config: PairConfig | None = None,
    train_list: str | os.PathLike[str] | None = None,
    test_list: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> tuple[PairSplits, bool]:
    """Returns the cached splits when the manifest matches, else builds and caches them; ``(splits, rebuilt)``.

    The split lists default to ``map_id_train.txt`` / ``map_id_test.txt`` next to ``source``.
    """
    cfg = config or PairConfig()
    src = Path(source)
    base = src.parent if not (src.is_dir() and src.name != "json") else src
    train_path = Path(train_list) if train_list is not None else base / "map_id_train.txt"
    test_path = Path(test_list) if test_list is not None else base / "map_id_test.txt"
    cache = Path(cache_dir)
    npz_path, man_path = cache / "houseexpo-pairs.npz", cache / "houseexpo-pairs.manifest.json"
    key = _key(src, train_path, test_path, cfg)
    if man_path.is_file() and npz_path.is_file():
        try:
            old = json.loads(man_path.read_text())
        except (OSError, json.JSONDecodeError):
            old = {}
        if old.get("key") == json.loads(json.dumps(key)):
            sets = _load_cache(npz_path)
            if sets is not None:
                return PairSplits(sets["train"], sets["val"], sets["test"], old), False
    splits = build_houseexpo_pairs(src, read_split(train_path), read_split(test_path), cfg, progress)
    cache.mkdir(parents=True, exist_ok=True)
    arrays: dict[str, Any] = {}
    for s in _SPLITS:
        ps: PairSet = getattr(splits, s)
        arrays[f"{s}_partial"], arrays[f"{s}_target"] = ps.partial, ps.target
        arrays[f"{s}_ids"] = np.asarray(ps.ids, dtype="U64")
    tmp = npz_path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp, **arrays)
    tmp.replace(npz_path)
    manifest = {"key": key, **splits.manifest}
    man_path.write_text(json.dumps(manifest, indent=2))
    return PairSplits(splits.train, splits.val, splits.test, manifest), True


def _procedural_set(seeds: range, seed: int, size: int, px_per_m: float, cfg: ApartmentConfig) -> PairSet:
    items = []
    for s in seeds:
        free, _ = rasterize_apartment(generate_apartment(s, cfg), 1.0 / px_per_m, border_cells=8)
        m_T = resize_ternary(pad_to_square(free_to_ternary(free), OCCUPIED), size)
        m_t = apply_mask(m_T, homes_mask(m_T.shape, _pair_rng(seed, f"procedural:{s}")))
        items.append((f"procedural:{s}", m_t, m_T))
    return _stack(items, size)


def procedural_pairs(
    n_train: int = 1000,
    n_val: int = 100,
    n_test: int = 100,
    seed: int = 0,
    size: int = 64,
    px_per_m: float = 16.0,
    config: ApartmentConfig | None = None,
) -> PairSplits:
    """Pairs from the procedural domain with HOME'S masking; apartments ``i``, ``10**6 + i``, ``2·10**6 + i``."""
    cfg = config or ApartmentConfig()
    t0 = time.perf_counter()
    sets = [
        _procedural_set(range(off, off + n), seed, size, px_per_m, cfg)
        for off, n in ((0, n_train), (1_000_000, n_val), (2_000_000, n_test))
    ]
    manifest = {
        "source": "procedural",
        "seed": seed,
        "counts": {"train": n_train, "val": n_val, "test": n_test},
        "build_seconds": round(time.perf_counter() - t0, 2),
    }
    return PairSplits(sets[0], sets[1], sets[2], manifest)
