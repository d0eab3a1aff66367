"""Experiment 2 (the paper's Table 2): MCN-SLAM on simulated HouseExpo houses, at the first iteration and at T−5.

Protocol (written to ``exp2.md`` too):

1. **Houses**: the first ``n_maps`` HouseExpo test plans in the seeded shuffle of the official test list that
   Experiment 1 uses (the same pair cache: its first maps are Exp 1's first test maps); a plan the simulated robot
   cannot drive in is skipped and the next one taken.  The paper draws 10 at random; 50 give confidence intervals.
2. **Robot**: :func:`mcnkit.sim.simulate` explores the whole house (360° lidar, ``lidar_range_m``, drifting
   odometry; seed ``seed``).  The run is written as a ROS1 bag and read back with :func:`mcnkit.io.open_log`, so
   the SLAM sees what a real log reader delivers (``log_format=""`` feeds the frames directly).
3. **SLAM**: grid FastSLAM (gmapping's defaults, ``particles`` particles).  At every filter update the ancestry of
   the particle best *at that update* is kept; its map at update k is rebuilt exactly after the run
   (:func:`~mcnkit.experiments.common.map_at`).  Iteration i (1-based, as the paper) is the map after the i-th
   filter update: iteration 1 is the first scan, before the robot moves; T is the last update, and the paper's
   "T−5" is iteration T−5 (five updates before the last).
4. **Ground truth** m_T: the best particle's map after the whole run (the paper: the Gmapping map with sufficient
   observation).  **Window**: the paper frames the whole house, so every map of a house is pooled on the same
   window, m_T's known extent padded square on ``size``² cells (:func:`mcnkit.mcn.map_window`; thin walls survive
   the pooling).  m_T's unknown cells there (outside the outer walls) count as occupied, the convention of the
   training maps and of Exp 1 (the F-measure, free space positive, does not depend on it).
5. **Rows**: (A) pix2pix and (B) U-net (the shipped weights, :func:`mcnkit.mcn.load_model`), and (B') the U-net
   trained on exploration maps (``unet-explore``: m_t after 1–12 scans of this robot's 360°, 8 m lidar, not the
   paper's single 180°, 2 m scan; :mod:`mcnkit.completion.data`): the ternary map of the
   mean output of K samples (dropout on; what :class:`mcnkit.mcn.McnSlam` returns as ``mean``), the mean score of
   the K samples, and the deterministic completion (dropout off); (C) SLAM alone (m_t as is); (D) retrieval of the
   HouseExpo training map that best agrees with m_t's observed cells; and the sanity rows "unknown → all free" and
   "unknown → all occupied".  Completions keep m_t's observed cells.
6. **Scores**: per-cell binary classification against m_T, free space positive (the paper's reading) and occupied
   positive; mIoU over {free, occupied} on the cells unknown in m_t; per-map means with 95 % CIs and pooled.

Outputs in ``out_dir``: ``exp2.csv`` (one row per iteration × method × variant × positive class),
``exp2_per_map.csv``, ``exp2_curve.csv`` (F and mIoU along the run), ``exp2.md``, ``exp2_examples.png``,
``exp2_curve.png``; ``runs/`` (or ``runs_dir``) caches each house's SLAM result, keyed by everything that shapes
it.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.completion.nets import UNet
from mcnkit.experiments.common import (
    MapCompletions,
    aggregate,
    complete_windows,
    fill_unknown,
    map_at,
    model_label,
    new_lineage,
    per_map_scores,
    run_slam,
    write_csv,
)
from mcnkit.experiments.options import Exp2Config, add_exp2_arguments, exp2_config_from_args
from mcnkit.grid import pool_to_window
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, GridSpec

__all__ = ["CSV_COLUMNS", "PAPER", "Exp2Config", "add_exp2_arguments", "exp2_config_from_args", "run_exp2"]

F32 = NDArray[np.float32]

CSV_COLUMNS = [
    "iteration", "method", "variant", "n_maps", "positive_class", "accuracy", "precision", "recall", "f_measure",
    "f_ci95", "miou_unknown", "miou_ci95", "pooled_accuracy", "pooled_precision", "pooled_recall",
    "pooled_f_measure", "pooled_miou_unknown", "miou_unknown_inside", "miou_inside_ci95", "exterior_predicted_free",
    "unknown_share",
]  # fmt: skip
PER_MAP_COLUMNS = ["map", "iteration", "update", "n_updates", "method", "variant", "accuracy", "precision", "recall",
                   "f_measure", "miou_unknown", "miou_unknown_inside", "exterior_predicted_free", "unknown_share"]
CURVE_COLUMNS = ["fraction", "method", "n_maps", "f_measure", "f_ci95", "miou_unknown", "miou_ci95", "unknown_share"]
ITERATIONS = ("1", "T-5")
UNET_ROWS = ("(B) U-net", "(B') U-net, exploration-trained")
"""U-net rows the targets are checked on: the paper's (trained on first-iteration maps) and the one trained on the
maps of a robot part-way through exploring (``unet-explore``)."""
PAPER = """| (A) pix2pix | 1 | 0.7864 | 0.4486 | 0.7072 | 0.4858 |
| (B) U-net | 1 | 0.8028 | 0.4686 | 0.7561 | 0.5275 |
| (C) Gmapping | 1 | 0.8314 | 0.6836 | 0.0994 | 0.1671 |
| (D) baseline | 1 | 0.8429 | 0.7765 | 0.3371 | 0.4062 |
| (A) pix2pix | T−5 | 0.8715 | 0.6608 | 0.6962 | 0.6546 |
| (B) U-net | T−5 | 0.8718 | 0.6306 | 0.7063 | 0.6429 |"""
CURVE_FRACTIONS = tuple(round(0.1 * i, 1) for i in range(11))
_CACHE_VERSION = 2


@dataclass
class HouseRun:
    """One house: its window and m_T on it, and m_t pooled on it at the evaluated updates."""

    name: str
    window: GridSpec
    truth: F32
    exterior: NDArray[np.bool_]
    """Window cells m_T never observed (outside the outer walls, the padding), counted occupied in ``truth``."""
    updates: list[int]
    """0-based filter-update indices of ``partials``."""
    partials: F32
    """(len(updates), S, S) pooled m_t."""
    n_updates: int
    n_scans: int
    sim_s: float
    slam_cpu_s: float
    truth_unknown_share: float
    """Share of window cells unknown in m_T before they are counted occupied."""


def _updates_of_interest(t: int, late: int) -> list[int]:
    """0-based update indices: iteration 1, iteration T − late, and the curve's fractions of the run."""
    ks = {0, max(0, t - 1 - late)} | {int(round(f * (t - 1))) for f in CURVE_FRACTIONS}
    return sorted(ks)


def _cache_key(cfg: Exp2Config, name: str) -> str:
    keep = {k: v for k, v in asdict(cfg).items()
            if k in ("seed", "particles", "size", "lidar_range_m", "lidar_fov_deg", "lidar_beams", "max_duration_s",
                     "log_format", "late")}
    return json.dumps({"version": _CACHE_VERSION, "map": name, **keep}, sort_keys=True)


def _run_house(cfg: Exp2Config, name: str, index: int, runs_dir: Path) -> HouseRun:
    """Simulates the robot in one house, runs SLAM, pools m_T and m_t on the house's window (cached)."""
    from mcnkit.sim import LidarConfig, SimConfig, plan_raster, simulate, write_sim_log
    from mcnkit.slam import SlamConfig

    key = _cache_key(cfg, name)
    path = runs_dir / f"{hashlib.sha256(key.encode()).hexdigest()[:16]}.npz"
    if cfg.reuse_runs and path.is_file():
        with np.load(path, allow_pickle=False) as z:
            if str(z["key"]) == key:
                w = z["window"]
                return HouseRun(name, GridSpec(float(w[0]), float(w[1]), float(w[2]), int(w[3]), int(w[4])),
                                z["truth"], z["exterior"], [int(k) for k in z["updates"]], z["partials"], int(z["n_updates"]),
                                int(z["n_scans"]), float(z["sim_s"]), float(z["slam_cpu_s"]),
                                float(z["truth_unknown_share"]))
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
    window = _house_window((s.origin_x_m, s.origin_y_m, s.origin_x_m + s.width * s.resolution_m,
                            s.origin_y_m + s.height * s.resolution_m), cfg.size, s.resolution_m)
    truth_raw = pool_to_window(final, window, outside=UNKNOWN)
    truth = np.where(truth_raw == UNKNOWN, OCCUPIED, truth_raw).astype(np.float32)
    updates = _updates_of_interest(run.n_updates, cfg.late)
    lm = new_lineage(run.slam)
    partials = np.stack([pool_to_window(map_at(run, k, lm), window, outside=UNKNOWN) for k in updates])
    house = HouseRun(name, window, truth, truth_raw == UNKNOWN, updates, partials.astype(np.float32), run.n_updates, run.n_scans, sim_s,
                     run.cpu_s, float((truth_raw == UNKNOWN).mean()))
    runs_dir.mkdir(parents=True, exist_ok=True)
    w = window
    tmp_path = path.with_suffix(".tmp.npz")
    np.savez_compressed(tmp_path, key=np.asarray(key), window=np.array([w.resolution_m, w.origin_x_m, w.origin_y_m,
                        w.width, w.height], np.float64), truth=truth, exterior=house.exterior, updates=np.asarray(updates, np.int64),
                        partials=house.partials, n_updates=run.n_updates, n_scans=run.n_scans, sim_s=sim_s,
                        slam_cpu_s=run.cpu_s, truth_unknown_share=house.truth_unknown_share)
    tmp_path.replace(path)
    return house


def _house_window(bounds: tuple[float, float, float, float], size: int, resolution_m: float) -> GridSpec:
    from mcnkit.mcn import map_window

    return map_window(bounds, size, 0.0, resolution_m)


def _houses_and_bank(cfg: Exp2Config) -> tuple[list[str], F32 | None, list[str]]:
    """Candidate plan names (in order), the retrieval bank (training m_T, or None) and notes."""
    from mcnkit.completion.data import load_domain_pairs

    notes: list[str] = []
    try:
        he = load_domain_pairs("houseexpo", cfg.n_train, 200, cfg.n_test_pool, cfg.seed, cfg.houseexpo,
                               cfg.cache_dir, progress=False)
    except FileNotFoundError:
        if not cfg.maps:
            raise
        notes.append("HouseExpo not found: no retrieval bank, row (D) left out.")
        return list(cfg.maps), None, notes
    names = list(cfg.maps) if cfg.maps else [f"houseexpo:{i}" for i in he.test.ids]
    return names, he.train.target, notes


def _exterior_free(pred: F32, partial: F32, exterior: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Per map, the share of the cells unknown in m_t and outside the house (m_T never saw them) predicted free
    (averaged over the samples of a (B, K, S, S) stack)."""
    p = pred if pred.ndim == 4 else pred[:, None]
    cells = (partial == UNKNOWN) & exterior
    n = cells.sum(axis=(-2, -1))
    hit = ((p == FREE) & cells[:, None]).sum(axis=(-2, -1)).mean(axis=1)
    return np.where(n > 0, hit / np.maximum(n, 1), np.nan)


def _method_rows(iteration: str, method: str, variant: str, pred: F32, truth: F32, partial: F32,
                 exterior: NDArray[np.bool_], unknown_share: float) -> list[dict[str, Any]]:
    from mcnkit.completion.scores import mean_ci95

    inside = aggregate(pred, truth, partial, "free", miou_mask=(partial == UNKNOWN) & ~exterior)
    ext = _exterior_free(pred, partial, exterior)
    rows = []
    for positive in ("free", "occupied"):
        r = aggregate(pred, truth, partial, positive)
        rows.append({"iteration": iteration, "method": method, "variant": variant, **r,
                     "miou_unknown_inside": inside["miou_unknown"], "miou_inside_ci95": inside["miou_ci95"],
                     "exterior_predicted_free": mean_ci95(ext)[0], "unknown_share": unknown_share})
    return rows


def _predictions(partial: F32, nets: dict[str, UNet], bank: F32 | None, k: int, seed: int, tag: int
                 ) -> tuple[dict[tuple[str, str], F32], dict[str, MapCompletions]]:
    """Every method's prediction for a stack of m_t: {(method, variant): (B, S, S) or (B, K, S, S)}."""
    from mcnkit.completion.retrieval import retrieve

    preds: dict[tuple[str, str], F32] = {}
    comps: dict[str, MapCompletions] = {}
    for j, (label, net) in enumerate(nets.items()):
        c = complete_windows(net, partial, k, torch.Generator().manual_seed(seed * 1000 + tag * 10 + j))
        comps[label] = c
        preds[(label, f"mean of {k}")] = c.mean
        preds[(label, "per sample")] = c.samples
        preds[(label, "dropout off")] = c.deterministic
    preds[("(C) SLAM alone", "-")] = partial
    if bank is not None:
        preds[("(D) retrieval", "-")] = retrieve(partial, bank).prediction
    preds[("unknown → all free", "-")] = fill_unknown(partial, FREE)
    preds[("unknown → all occupied", "-")] = fill_unknown(partial, OCCUPIED)
    return preds, comps


def _figure(path: Path, houses: list[HouseRun], late_idx: list[int], comps: dict[str, dict[str, MapCompletions]],
            n: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = min(n, len(houses))
    labels = list(comps["1"])
    unet = next((lab for lab in labels if "U-net" in lab), labels[0] if labels else None)
    k_show = 3
    cols = ["m_t"]
    if unet:
        cols += [f"{unet} s{j + 1}" for j in range(k_show)] + [f"{unet} mean", "uncertainty"]
    cols += [f"{lab} mean" for lab in labels if lab != unet] + ["m_T"]
    fig, axes = plt.subplots(2 * n, len(cols), figsize=(1.55 * len(cols), 1.7 * 2 * n), squeeze=False)
    for i in range(n):
        for j, it in enumerate(ITERATIONS):
            r = 2 * i + j
            h = houses[i]
            partial = h.partials[0] if it == "1" else h.partials[late_idx[i]]
            panels: list[tuple[NDArray[np.floating], str]] = [(partial, "gray_r")]
            if unet:
                c = comps[it][unet]
                panels += [(c.samples[i, s], "gray_r") for s in range(min(k_show, c.samples.shape[1]))]
                panels += [(np.full_like(partial, UNKNOWN), "gray_r")] * (k_show - min(k_show, c.samples.shape[1]))
                panels += [(c.mean[i], "gray_r"), (c.uncertainty[i], "magma")]
            panels += [(comps[it][lab].mean[i], "gray_r") for lab in labels if lab != unet]
            panels.append((h.truth, "gray_r"))
            for c_idx, (img, cmap) in enumerate(panels):
                ax = axes[r, c_idx]
                ax.imshow(img, cmap=cmap, vmin=0.0, vmax=1.0, interpolation="nearest", origin="lower")
                ax.set_xticks([])
                ax.set_yticks([])
                if r == 0:
                    ax.set_title(cols[c_idx], fontsize=7)
            upd = 1 if it == "1" else h.updates[late_idx[i]] + 1
            axes[r, 0].set_ylabel(f"{h.name.split(':')[-1][:6]}\niter {upd}/{h.n_updates}", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _curve(houses: list[HouseRun], nets: dict[str, UNet], k: int, seed: int) -> list[dict[str, Any]]:
    """F (free positive) and mIoU along the run at fractions 0, 0.1, …, 1 of the filter updates (the all-occupied
    fill has the F of SLAM alone)."""
    rows: list[dict[str, Any]] = []
    for fi, f in enumerate(CURVE_FRACTIONS):
        idx = [h.updates.index(int(round(f * (h.n_updates - 1)))) for h in houses]
        partial = np.stack([h.partials[i] for h, i in zip(houses, idx, strict=True)])
        truth = np.stack([h.truth for h in houses])
        preds: dict[str, F32] = {"(C) SLAM alone": partial, "unknown → all free": fill_unknown(partial, FREE),
                                 "unknown → all occupied": fill_unknown(partial, OCCUPIED)}
        for j, (label, net) in enumerate(nets.items()):
            g = torch.Generator().manual_seed(seed * 1000 + 500 + fi * 10 + j)
            preds[label] = complete_windows(net, partial, k, g).mean
        share = float((partial == UNKNOWN).mean())
        for method, pred in preds.items():
            r = aggregate(pred, truth, partial, "free")
            rows.append({"fraction": f, "method": method, "n_maps": len(houses), "f_measure": r["f_measure"],
                         "f_ci95": r["f_ci95"], "miou_unknown": r["miou_unknown"], "miou_ci95": r["miou_ci95"],
                         "unknown_share": share})
    return rows


def _curve_figure(path: Path, rows: list[dict[str, Any]]) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    methods = list(dict.fromkeys(r["method"] for r in rows))
    for m in methods:
        rs = [r for r in rows if r["method"] == m]
        x = [r["fraction"] for r in rs]
        for ax, key, ci in ((axes[0], "f_measure", "f_ci95"), (axes[1], "miou_unknown", "miou_ci95")):
            y = np.array([r[key] for r in rs], float)
            e = np.array([r[ci] for r in rs], float)
            fill = m.startswith("unknown")
            ax.plot(x, y, marker="" if fill else "o", ms=3, ls="--" if fill else "-", label=m)
            ax.fill_between(x, y - e, y + e, alpha=0.0 if fill else 0.15)
    axes[0].set_ylabel("F (free space positive)")
    axes[1].set_ylabel("mIoU on cells unknown in m_t")
    for ax in axes:
        ax.set_xlabel("fraction of the run's filter updates")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _fmt_row(r: dict[str, Any]) -> str:
    return (f"| {r['method']} | {r['variant']} | {r['n_maps']} | {r['accuracy']:.4f} | {r['precision']:.4f} | "
            f"{r['recall']:.4f} | {r['f_measure']:.4f} ± {r['f_ci95']:.4f} | {r['miou_unknown']:.4f} ± "
            f"{r['miou_ci95']:.4f} | {r['pooled_f_measure']:.4f} | {r['pooled_miou_unknown']:.4f} | "
            f"{r['miou_unknown_inside']:.4f} ± {r['miou_inside_ci95']:.4f} | {r['exterior_predicted_free']:.3f} |")


def _targets(rows: list[dict[str, Any]], k: int) -> list[tuple[str, bool, str]]:
    """The issue's must-show checks on the U-net row (mean of K samples), free space positive."""
    def get(it: str, method: str, variant: str) -> dict[str, Any] | None:
        return next((r for r in rows if r["iteration"] == it and r["method"] == method and r["variant"] == variant
                     and r["positive_class"] == "free"), None)

    out: list[tuple[str, bool, str]] = []
    c1 = get("1", "(C) SLAM alone", "-")
    for method in UNET_ROWS:
        u1, ul = get("1", method, f"mean of {k}"), get("T-5", method, f"mean of {k}")
        if u1 is None or ul is None or c1 is None:
            continue
        name = method.split(") ", 1)[-1]
        out.append((f"{name} F at iteration 1 ≥ 0.53 (paper 0.5275)", u1["f_measure"] >= 0.53,
                    f"{u1['f_measure']:.4f}"))
        ratio = u1["f_measure"] / c1["f_measure"] if c1["f_measure"] > 0 else float("inf")
        out.append((f"{name} F at iteration 1 ≥ 1.3 × SLAM alone", ratio >= 1.3,
                    f"{u1['f_measure']:.4f} / {c1['f_measure']:.4f} = {ratio:.2f}×"))
        out.append((f"{name} F at T−5 ≥ 0.64 (paper 0.6429)", ul["f_measure"] >= 0.64, f"{ul['f_measure']:.4f}"))
        for it, u in (("1", u1), ("T-5", ul)):
            fills = [f for f in (get(it, m, "-") for m in ("unknown → all free", "unknown → all occupied")) if f]
            best_in = max((f["miou_unknown_inside"] for f in fills), default=float("nan"))
            out.append((f"{name} mIoU on the unknown cells m_T knows (as in Exp 3) above both trivial fills, "
                        f"iteration {it}", bool(u["miou_unknown_inside"] > best_in),
                        f"{u['miou_unknown_inside']:.4f} vs {best_in:.4f}"))
            best = max((f["miou_unknown"] for f in fills), default=float("nan"))
            out.append((f"same, with the cells m_T never saw counted occupied, iteration {it}",
                        bool(u["miou_unknown"] > best), f"{u['miou_unknown']:.4f} vs {best:.4f}"))
    return out


def _diagnosis(rows: list[dict[str, Any]], houses: list[HouseRun], cfg: Exp2Config) -> list[str]:
    """Where the cells to complete are (inside the house or outside its outer walls) and what the nets put there."""
    k = cfg.samples
    lines = ["## Where the unknown cells are", "",
             "'Inside' = cells m_T observed (rooms and walls); 'exterior' = window cells m_T never observed (outside "
             "the outer walls and the square padding), counted occupied. 'mIoU inside' is the mIoU on the cells "
             "unknown in m_t that m_T observed; 'exterior → free' the share of the unknown exterior cells a method "
             "fills with free space.", "",
             "| iteration | unknown cells of m_t that are exterior | method | mIoU unknown | mIoU inside | "
             "exterior → free |", "|---|---|---|---|---|---|"]
    late = [h.updates.index(max(0, h.n_updates - 1 - cfg.late)) for h in houses]
    summary: list[str] = []
    for it in ITERATIONS:
        parts = np.stack([h.partials[0] if it == "1" else h.partials[i] for h, i in zip(houses, late, strict=True)])
        ext = np.stack([h.exterior for h in houses])
        unk = parts == UNKNOWN
        share = float((unk & ext).sum() / max(int(unk.sum()), 1))
        for r in rows:
            if r["iteration"] == it and r["positive_class"] == "free" and r["variant"] in ("-", f"mean of {k}"):
                lines.append(f"| {it} | {share:.3f} | {r['method']} | {r['miou_unknown']:.4f} | "
                             f"{r['miou_unknown_inside']:.4f} | {r['exterior_predicted_free']:.3f} |")
        sel = {r["method"]: r for r in rows if r["iteration"] == it and r["positive_class"] == "free"
               and r["variant"] in ("-", f"mean of {k}")}
        fills = [sel[m] for m in ("unknown → all free", "unknown → all occupied") if m in sel]
        for method in UNET_ROWS:
            u = sel.get(method)
            if u is None or not fills:
                continue
            best_in = max(f["miou_unknown_inside"] for f in fills)
            summary.append(f"- At iteration {it}, {share:.0%} of the cells to complete lie outside the house; "
                           f"{method} fills {u['exterior_predicted_free']:.0%} of them with free space. Inside the "
                           f"house its mIoU is {u['miou_unknown_inside']:.3f} against {best_in:.3f} for the better "
                           "trivial fill there.")
    return [*lines, "", *summary, ""] if summary else [*lines, ""]


def _markdown(cfg: Exp2Config, rows: list[dict[str, Any]], houses: list[HouseRun], notes: list[str],
              curve: list[dict[str, Any]]) -> str:
    k = cfg.samples
    lines = [f"# Experiment 2: MCN-SLAM in simulation ({len(houses)} HouseExpo test houses)", ""]
    targets = _targets(rows, k)
    if targets:
        lines += ["## Targets (free space positive; U-net = ternary map of the mean of "
                  f"{k} samples)", "", "| check | met | value |", "|---|---|---|"]
        lines += [f"| {t} | {'yes' if ok else '**no**'} | {v} |" for t, ok, v in targets] + [""]
    lines += _diagnosis(rows, houses, cfg)
    for it in ITERATIONS:
        share = next((r["unknown_share"] for r in rows if r["iteration"] == it), float("nan"))
        title = "iteration 1 (the first scan, before the robot moves)" if it == "1" else f"iteration T−{cfg.late}"
        for positive in ("free", "occupied"):
            lines += [f"## {title}, positive class: {positive}"
                      + (" (the paper's reading)" if positive == "free" else ""), "",
                      f"Share of window cells unknown in m_t: {share:.3f}.", "",
                      "| method | variant | n | Acc | Prec | Rec | F (±95 %) | mIoU unknown (±95 %) | pooled F | "
                      "pooled mIoU | mIoU unknown inside (±95 %) | exterior → free |",
                      "|---|---|---|---|---|---|---|---|---|---|---|---|"]
            lines += [_fmt_row(r) for r in rows if r["iteration"] == it and r["positive_class"] == positive]
            lines.append("")
    lines += ["## The paper's Table 2 (free space positive; Acc / Prec / Rec / F)", "",
              "| method | iteration | Acc | Prec | Rec | F |", "|---|---|---|---|---|---|", PAPER, ""]
    if curve:
        lines += ["## Along the run (free space positive, mean of K for the networks)", "",
                  "| fraction of updates | " + " | ".join(dict.fromkeys(r["method"] for r in curve)) + " |",
                  "|---|" + "---|" * len(dict.fromkeys(r["method"] for r in curve))]
        for f in CURVE_FRACTIONS:
            rs = [r for r in curve if r["fraction"] == f]
            lines.append(f"| {f:.1f} | " + " | ".join(f"F {r['f_measure']:.3f} / mIoU {r['miou_unknown']:.3f}"
                                                     for r in rs) + " |")
        lines.append("")
    lines += ["## Houses", "", "| house | scans | filter updates T | T−5 update | m_T unknown share | sim s | SLAM CPU s |",
              "|---|---|---|---|---|---|---|"]
    for h in houses:
        lines.append(f"| {h.name} | {h.n_scans} | {h.n_updates} | {max(1, h.n_updates - cfg.late)} | "
                     f"{h.truth_unknown_share:.3f} | {h.sim_s:.1f} | {h.slam_cpu_s:.1f} |")
    lines += ["", "## Protocol and notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(lines)


def run_exp2(cfg: Exp2Config) -> str:
    """Runs Experiment 2 and writes its outputs; returns the Markdown report."""
    from tqdm import tqdm

    from mcnkit.mcn import load_model

    t0 = time.perf_counter()
    torch.set_num_threads(cfg.threads)
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names, bank, notes = _houses_and_bank(cfg)
    nets = {model_label(m): load_model(m) for m in cfg.models}
    houses: list[HouseRun] = []
    skipped: list[str] = []
    bar = tqdm(total=cfg.n_maps, desc="exp2 houses", unit="house", disable=not cfg.progress)
    for i, name in enumerate(names):
        if len(houses) == cfg.n_maps:
            break
        try:
            houses.append(_run_house(cfg, name, i, Path(cfg.runs_dir) if cfg.runs_dir else out / "runs"))
            bar.update(1)
        except ValueError as err:  # a plan without room for the robot, an unreadable plan
            skipped.append(f"{name} ({err})")
    bar.close()
    if not houses:
        raise ValueError("no house could be simulated")
    truth = np.stack([h.truth for h in houses])
    exterior = np.stack([h.exterior for h in houses])
    late_idx = [h.updates.index(max(0, h.n_updates - 1 - cfg.late)) for h in houses]
    stacks = {"1": np.stack([h.partials[0] for h in houses]),
              "T-5": np.stack([h.partials[i] for h, i in zip(houses, late_idx, strict=True)])}
    rows: list[dict[str, Any]] = []
    per_map: list[dict[str, Any]] = []
    comps: dict[str, dict[str, MapCompletions]] = {}
    for tag, (it, partial) in enumerate(stacks.items()):
        preds, comps[it] = _predictions(partial, nets, bank, cfg.samples, cfg.seed, tag)
        share = float((partial == UNKNOWN).mean())
        for (method, variant), pred in preds.items():
            rows += _method_rows(it, method, variant, pred, truth, partial, exterior, share)
            pm = per_map_scores(pred, truth, partial, "free")
            pm_in = per_map_scores(pred, truth, partial, "free", miou_mask=(partial == UNKNOWN) & ~exterior)
            ext = _exterior_free(pred, partial, exterior)
            for b, h in enumerate(houses):
                upd = 0 if it == "1" else h.updates[late_idx[b]]
                per_map.append({"map": h.name, "iteration": it, "update": upd + 1, "n_updates": h.n_updates,
                                "method": method, "variant": variant, **{m: float(v[b]) for m, v in pm.items()},
                                "miou_unknown_inside": float(pm_in["miou_unknown"][b]),
                                "exterior_predicted_free": float(ext[b]),
                                "unknown_share": float((partial[b] == UNKNOWN).mean())})
    write_csv(out / "exp2.csv", rows, CSV_COLUMNS)
    write_csv(out / "exp2_per_map.csv", per_map, PER_MAP_COLUMNS)
    curve = _curve(houses, nets, cfg.samples, cfg.seed) if cfg.curve else []
    if curve:
        write_csv(out / "exp2_curve.csv", curve, CURVE_COLUMNS)
        _curve_figure(out / "exp2_curve.png", curve)
    if cfg.n_examples > 0 and nets:
        _figure(out / "exp2_examples.png", houses, late_idx, comps, cfg.n_examples)
    notes = [
        "Houses: " + (f"the given plans ({len(cfg.maps)})" if cfg.maps else
                      f"the first {len(houses)} usable HouseExpo test plans of the seeded shuffle (seed {cfg.seed}) "
                      "of the official test list, the order of Experiment 1's test maps")
        + (f"; skipped: {'; '.join(skipped)}" if skipped else "") + ".",
        f"Robot: mcnkit.sim, {cfg.lidar_beams} beams over {cfg.lidar_fov_deg:g}°, range {cfg.lidar_range_m:g} m, "
        f"drifting odometry, whole-house exploration (≤ {cfg.max_duration_s:g} s), sim seed {cfg.seed}; "
        + (f"written as a {cfg.log_format} and read back with open_log." if cfg.log_format else
           "frames fed directly (no log written)."),
        f"SLAM: FastSlam with gmapping's defaults, {cfg.particles} particles; m_t at iteration i = the map of the "
        "particle best at the i-th filter update (exact, rebuilt from its ancestry); m_T = the best map after the "
        "last update.",
        f"Window: m_T's known extent padded square on {cfg.size}² cells (map_window); m_T's unknown cells counted "
        "occupied (exterior, as in the training maps); every map pooled with occupied > free > unknown. The "
        "simulated odometry starts at the true pose, so the SLAM maps lie in the plan's frame and the windows have "
        "the training maps' orientation (rows = y, columns = x).",
        f"Networks: {', '.join(f'{lab} = {m}' for lab, m in zip(nets, cfg.models, strict=True))} "
        f"(load_model); K = {cfg.samples} samples with dropout on, seeded; 'mean of {cfg.samples}' is the ternary "
        "map of the mean output, 'per sample' the mean score of the samples, 'dropout off' the deterministic "
        "output; observed cells of m_t are kept in every completion.",
        "(D) retrieval: the HouseExpo training m_T with the highest agreement on m_t's observed cells, m_t pasted "
        f"over it (bank: {0 if bank is None else len(bank)} maps of the Exp 1 pair split).",
        "Scores: free space positive (the paper's reading) and occupied positive; a cell predicted unknown is a "
        "negative; mIoU over {free, occupied} on the cells unknown in m_t; per-map mean ± 95 % CI "
        "(1.96 sd/√n) and pooled over maps.",
        *notes, *cfg.extra_notes,
        f"Wall time {time.perf_counter() - t0:.0f} s ({sum(h.sim_s for h in houses):.0f} s simulation, "
        f"{sum(h.slam_cpu_s for h in houses):.0f} s SLAM CPU; cached runs count their first time); "
        f"torch threads {cfg.threads}.",
    ]
    md = _markdown(cfg, rows, houses, notes, curve)
    (out / "exp2.md").write_text(md)
    return md
