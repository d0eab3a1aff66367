"""Experiment 3 (the paper's real-lab experiment) on the MIT CSAIL and Intel Research Lab logs.

The paper completed the map of one laboratory room; its data are not public.  Here the two classic real-robot
logs stand in, with the HouseExpo-trained networks (a domain shift the paper also met: its real-lab F was lower).

Protocol (also in ``exp3.md``):

1. Each CARMEN log is converted to a ROS1 bag in a temporary directory with mcnkit's writer and read back with
   :func:`mcnkit.io.open_log` (the path a user's bag takes; ``convert=False`` reads the log directly).
2. Grid FastSLAM (gmapping's defaults, ``particles`` particles) runs over it once; at every filter update the
   ancestry of the particle best at that update is kept, so its map at any update is rebuilt exactly afterwards
   (:func:`~mcnkit.experiments.common.map_at`) and the networks complete only at the chosen points: MCN-SLAM's
   completion at those updates, without completing at every update.
3. At each point (a fraction of the filter updates, default 10/25/50/75/90 %) the window is a ``window_m`` square
   centred on the robot (:func:`mcnkit.mcn.robot_window`; these buildings are far larger than one house; 16 m on
   64 cells is 0.25 m a cell, the scale of the HouseExpo training maps); m_t = the best particle's map there,
   m_T = the final best map pooled on the same window.
4. Rows: SLAM alone (m_t), (B) U-net and (A) pix2pix (ternary map of the mean of K samples, the mean score of the
   samples, the deterministic output), and the trivial fills.  Scores against m_T, free space positive: F over the
   whole window (m_T's unknown cells are negatives, the paper's protocol) and F on the cells m_T knows; mIoU over
   {free, occupied} on the cells unknown in m_t **and known in m_T** (in a building, what m_T never saw is not
   known to be wall).

Outputs in ``out_dir``: ``exp3.csv`` (one row per log × point × method × variant), ``exp3.md``,
``exp3_<log>.png`` (the windows at each point) and ``exp3_<log>_overview.png`` (the final map and the windows).
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from itertools import islice
from pathlib import Path
from typing import Any

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.experiments.common import (
    MapCompletions,
    complete_windows,
    fill_unknown,
    map_at,
    model_label,
    new_lineage,
    per_map_scores,
    run_slam,
    write_csv,
)
from mcnkit.experiments.options import Exp3Config, add_exp3_arguments, exp3_config_from_args
from mcnkit.grid import pool_to_window
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, Frame, GridSpec, TernaryMap

__all__ = ["CSV_COLUMNS", "Exp3Config", "add_exp3_arguments", "default_logs", "exp3_config_from_args",
           "run_exp3"]

F32 = NDArray[np.float32]

CSV_COLUMNS = ["log", "point", "update", "n_updates", "method", "variant", "accuracy", "precision", "recall",
               "f_measure", "f_known", "miou_unknown", "unknown_share", "truth_unknown_share"]
SUMMARY_METRICS = ("f_measure", "f_known", "miou_unknown")


def _reallab_dir() -> Path:
    env = os.environ.get("MCNKIT_SHARED_DATA")
    if env:
        return Path(env) / "reallab"
    return Path(__file__).resolve().parents[3] / "shared" / "data" / "reallab"


def default_logs(reallab: str | os.PathLike[str] | None = None) -> tuple[str, ...]:
    """The MIT CSAIL and Intel Research Lab logs (``$MCNKIT_SHARED_DATA/reallab`` or ``../shared/data/reallab``)."""
    root = Path(reallab) if reallab else _reallab_dir()
    return (str(root / "mit-csail" / "mit-csail.clf"), str(root / "intel" / "intel-corrected.log.gz"))


@dataclass
class PointWindows:
    """One log at one point: the window, m_t and m_T on it."""

    point: float
    update: int
    window: GridSpec
    partial: F32
    truth: F32


def _log_name(path: str) -> str:
    name = Path(path).name
    for suffix in (".gz", ".clf", ".log", ".bag", ".mcap"):
        name = name.removesuffix(suffix)
    return name


def _frames(cfg: Exp3Config, path: str, tmp: Path) -> Iterator[Frame]:
    """The log's frames, through a ROS1 bag written in ``tmp`` when ``cfg.convert``."""
    from mcnkit.io import LogContent, open_log, write_log

    with open_log(path) as log:
        frames = list(islice(log.frames(), cfg.max_scans))
        gt = log.ground_truth()
    if not cfg.convert:
        yield from frames
        return
    if gt is not None and cfg.max_scans is not None:
        gt = None  # a truncated log: leave the ground truth out rather than cut it
    bag = write_log(tmp / f"{_log_name(path)}.bag", LogContent(frames, ground_truth=gt), "ros1")
    with open_log(bag) as log:
        yield from log.frames()


def _scores(pred: F32, truth: F32, partial: F32) -> dict[str, float]:
    """F (whole window), F on the cells m_T knows, mIoU on cells unknown in m_t and known in m_T; one window
    (S, S) or a stack of samples (K, S, S)."""
    p = pred if pred.ndim == 3 else pred[None]
    t, m = truth[None], partial[None]
    known = truth != UNKNOWN
    whole = per_map_scores(p[None], t, m, "free", miou_mask=((m == UNKNOWN) & known[None]))
    masked = np.where(known, p, UNKNOWN)
    f_known = per_map_scores(masked[None], t, m, "free")["f_measure"]
    return {**{k: float(v[0]) for k, v in whole.items()}, "f_known": float(f_known[0])}


def _figure(path: Path, name: str, pts: list[PointWindows], comps: dict[str, MapCompletions], n_updates: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = list(comps)
    unet = next((lab for lab in labels if "U-net" in lab), labels[0] if labels else None)
    cols = ["m_t"]
    if unet:
        cols += [f"{unet} s1", f"{unet} s2", f"{unet} mean", "uncertainty"]
    cols += [f"{lab} mean" for lab in labels if lab != unet] + ["m_T"]
    fig, axes = plt.subplots(len(pts), len(cols), figsize=(1.6 * len(cols), 1.75 * len(pts)), squeeze=False)
    for r, pw in enumerate(pts):
        panels: list[tuple[NDArray[np.floating], str]] = [(pw.partial, "gray_r")]
        if unet:
            c = comps[unet]
            ks = c.samples.shape[1]
            panels += [(c.samples[r, min(j, ks - 1)], "gray_r") for j in range(2)]
            panels += [(c.mean[r], "gray_r"), (c.uncertainty[r], "magma")]
        panels += [(comps[lab].mean[r], "gray_r") for lab in labels if lab != unet]
        panels.append((pw.truth, "gray_r"))
        for c_idx, (img, cmap) in enumerate(panels):
            ax = axes[r, c_idx]
            ax.imshow(img, cmap=cmap, vmin=0.0, vmax=1.0, interpolation="nearest", origin="lower")
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(cols[c_idx], fontsize=7)
        axes[r, 0].set_ylabel(f"{pw.point:.0%}\nupdate {pw.update + 1}/{n_updates}", fontsize=7)
    fig.suptitle(name, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _overview(path: Path, name: str, final: TernaryMap, pts: list[PointWindows], trajectory: NDArray[np.float64]
              ) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    s = final.spec
    assert s is not None
    extent = (s.origin_x_m, s.origin_x_m + s.width * s.resolution_m, s.origin_y_m,
              s.origin_y_m + s.height * s.resolution_m)
    fig, ax = plt.subplots(figsize=(7, 7))
    ax.imshow(final.image, cmap="gray_r", vmin=0, vmax=1, origin="lower", extent=extent, interpolation="nearest")
    ax.plot(trajectory[:, 0], trajectory[:, 1], color="C2", lw=0.8, label="best particle (updates)")
    for pw in pts:
        w = pw.window
        ax.add_patch(Rectangle((w.origin_x_m, w.origin_y_m), w.width * w.resolution_m, w.height * w.resolution_m,
                               fill=False, color="C3", lw=1.2))
        ax.text(w.origin_x_m, w.origin_y_m + w.height * w.resolution_m, f"{pw.point:.0%}", color="C3", fontsize=8)
    ax.set_title(f"{name}: final map (m_T) and the completion windows")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _run_log(cfg: Exp3Config, path: str, nets: dict[str, Any], out: Path, index: int
             ) -> tuple[list[dict[str, Any]], dict[str, Any]]:
    from mcnkit.mcn import robot_window
    from mcnkit.slam import SlamConfig

    name = _log_name(path)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="mcnkit-exp3-") as tmp:
        run = run_slam(_frames(cfg, path, Path(tmp)), SlamConfig(n_particles=cfg.particles),
                       np.random.default_rng([cfg.seed, index]))
    t_slam = time.perf_counter() - t0
    final = map_at(run, -1)
    lm = new_lineage(run.slam)
    pts: list[PointWindows] = []
    for p in cfg.points:
        k = int(round(p * (run.n_updates - 1)))
        window = robot_window(run.best_poses[k][-1, :2], cfg.size, cfg.window_m)
        partial = pool_to_window(map_at(run, k, lm), window, outside=UNKNOWN).astype(np.float32)
        truth = pool_to_window(final, window, outside=UNKNOWN).astype(np.float32)
        pts.append(PointWindows(p, k, window, partial, truth))
    partial = np.stack([pw.partial for pw in pts])
    comps = {lab: complete_windows(net, partial, cfg.samples, torch.Generator().manual_seed(cfg.seed * 1000 + j))
             for j, (lab, net) in enumerate(nets.items())}
    rows: list[dict[str, Any]] = []
    for i, pw in enumerate(pts):
        preds: dict[tuple[str, str], F32] = {("(C) SLAM alone", "-"): pw.partial}
        for lab, c in comps.items():
            preds[(lab, f"mean of {cfg.samples}")] = c.mean[i]
            preds[(lab, "per sample")] = c.samples[i]
            preds[(lab, "dropout off")] = c.deterministic[i]
        preds[("unknown → all free", "-")] = fill_unknown(pw.partial, FREE)
        preds[("unknown → all occupied", "-")] = fill_unknown(pw.partial, OCCUPIED)
        for (method, variant), pred in preds.items():
            rows.append({"log": name, "point": pw.point, "update": pw.update + 1, "n_updates": run.n_updates,
                         "method": method, "variant": variant, **_scores(pred, pw.truth, pw.partial),
                         "unknown_share": float((pw.partial == UNKNOWN).mean()),
                         "truth_unknown_share": float((pw.truth == UNKNOWN).mean())})
    if nets:
        _figure(out / f"exp3_{name}.png", name, pts, comps, run.n_updates)
    best = run.best_poses[-1]
    _overview(out / f"exp3_{name}_overview.png", name, final, pts, best)
    info = {"log": name, "path": path, "scans": run.n_scans, "updates": run.n_updates, "slam_cpu_s": run.cpu_s,
            "read_and_slam_s": t_slam, "total_s": time.perf_counter() - t0}
    return rows, info


def _summary(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Per log (and over all logs) and method/variant: the mean of each metric over the points, with 95 % CIs."""
    from mcnkit.completion.scores import mean_ci95

    out = []
    logs = list(dict.fromkeys(r["log"] for r in rows))
    for log in [*logs, "all"]:
        rs = [r for r in rows if log in ("all", r["log"])]
        for key in dict.fromkeys((r["method"], r["variant"]) for r in rs):
            sel = [r for r in rs if (r["method"], r["variant"]) == key]
            row: dict[str, Any] = {"log": log, "method": key[0], "variant": key[1], "n": len(sel)}
            for m in SUMMARY_METRICS:
                row[m], row[f"{m}_ci95"] = mean_ci95(np.array([r[m] for r in sel], float))
            out.append(row)
    return out


def _markdown(cfg: Exp3Config, rows: list[dict[str, Any]], infos: list[dict[str, Any]], total_s: float) -> str:
    k = cfg.samples
    lines = [f"# Experiment 3: map completion on real-robot logs ({', '.join(i['log'] for i in infos)})", ""]
    summary = _summary(rows)
    lines += [f"## Summary: mean over the {len(cfg.points)} points (± 95 % CI), free space positive", "",
              "| log | method | variant | F (whole window) | F (cells m_T knows) | mIoU unknown |", "|---|---|---|---|---|---|"]
    for s in summary:
        lines.append(f"| {s['log']} | {s['method']} | {s['variant']} | {s['f_measure']:.4f} ± {s['f_measure_ci95']:.4f} | "
                     f"{s['f_known']:.4f} ± {s['f_known_ci95']:.4f} | {s['miou_unknown']:.4f} ± "
                     f"{s['miou_unknown_ci95']:.4f} |")
    lines.append("")
    for info in infos:
        rs = [r for r in rows if r["log"] == info["log"]]
        lines += [f"## {info['log']}: {info['scans']} scans, {info['updates']} filter updates", "",
                  "| point | update | m_t unknown | m_T unknown | method | variant | Prec | Rec | F | F (m_T known) | "
                  "mIoU unknown |", "|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in rs:
            if r["variant"] == "per sample":
                continue
            lines.append(f"| {r['point']:.0%} | {r['update']} | {r['unknown_share']:.3f} | {r['truth_unknown_share']:.3f} | "
                         f"{r['method']} | {r['variant']} | {r['precision']:.4f} | {r['recall']:.4f} | "
                         f"{r['f_measure']:.4f} | {r['f_known']:.4f} | {r['miou_unknown']:.4f} |")
        lines += ["", f"Figures: `exp3_{info['log']}.png`, `exp3_{info['log']}_overview.png`.", ""]
    lines += ["## The paper's real-lab table (one lab room; free space positive; Acc / Prec / Rec / F)", "",
              "| method | Acc | Prec | Rec | F |", "|---|---|---|---|---|",
              "| (A) pix2pix | 0.7021 | 0.7582 | 0.2507 | 0.3769 |", "| (B) U-net | 0.7002 | 0.5985 | 0.3119 | 0.4101 |",
              "| (C) Gmapping | 0.6711 | 0.9817 | 0.1056 | 0.1907 |", "| (D) baseline | 0.6802 | 0.7351 | 0.1945 | 0.3076 |", ""]
    notes = [
        ("Logs converted to a ROS1 bag in a temporary directory with mcnkit's writer and read back with open_log."
         if cfg.convert else "Logs read directly with open_log.")
        + (f" Only the first {cfg.max_scans} scans of each." if cfg.max_scans else ""),
        f"SLAM: FastSlam with gmapping's defaults, {cfg.particles} particles, seed {cfg.seed}; m_t at a point = the "
        "map of the particle best at that filter update (exact, rebuilt from its ancestry); m_T = the final best map.",
        f"Window: {cfg.window_m:g} m square centred on the robot at the point, {cfg.size}² cells "
        f"({cfg.window_m / cfg.size:.3f} m a cell); maps pooled with occupied > free > unknown.",
        f"Networks: {', '.join(cfg.models)} (load_model, trained on HouseExpo); K = {k} samples with dropout on, "
        f"seeded; 'mean of {k}' = ternary map of the mean output; 'per sample' = mean score of the samples; "
        "observed cells of m_t kept.",
        "F (whole window): every window cell, m_T's unknown cells are negatives (the paper's protocol). "
        "F (cells m_T knows): only cells m_T observed. mIoU over {free, occupied} on cells unknown in m_t and known "
        "in m_T. The summary's CIs are over the points (windows of one run: not independent).",
        "Timing: " + "; ".join(f"{i['log']} {i['total_s']:.0f} s ({i['slam_cpu_s']:.0f} s SLAM CPU)" for i in infos)
        + f"; total {total_s:.0f} s, torch threads {cfg.threads}.",
    ]
    lines += ["## Protocol and notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(lines)


def run_exp3(cfg: Exp3Config) -> str:
    """Runs Experiment 3 and writes its outputs; returns the Markdown report."""
    from tqdm import tqdm

    from mcnkit.mcn import load_model

    t0 = time.perf_counter()
    torch.set_num_threads(cfg.threads)
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    logs = cfg.logs or default_logs()
    for p in logs:
        if not Path(p).exists():
            raise FileNotFoundError(2, "robot log not found", p)
    nets = {model_label(m): load_model(m) for m in cfg.models}
    rows: list[dict[str, Any]] = []
    infos: list[dict[str, Any]] = []
    for i, path in enumerate(tqdm(logs, desc="exp3 logs", unit="log", disable=not cfg.progress)):
        r, info = _run_log(cfg, path, nets, out, i)
        rows += r
        infos.append(info)
    write_csv(out / "exp3.csv", rows, CSV_COLUMNS)
    md = _markdown(cfg, rows, infos, time.perf_counter() - t0)
    (out / "exp3.md").write_text(md)
    return md
