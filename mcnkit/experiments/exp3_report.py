"""Experiment 3's report: the Markdown (``exp3.md``: summary, every point, the paper's table, notes) and the
figures of each log (``exp3_<log>.png``: the windows completed; ``exp3_<log>_overview.png``: the final map and
the windows)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from mcnkit.experiments import paper
from mcnkit.experiments.common import MapCompletions
from mcnkit.experiments.rows import Exp3Row, Exp3Summary, LogInfo
from mcnkit.types import GridSpec, TernaryMap

if TYPE_CHECKING:
    from mcnkit.experiments.config import Exp3Config

__all__ = ["PointWindows", "markdown", "overview_figure", "windows_figure"]

F32 = NDArray[np.float32]


@dataclass(frozen=True)
class PointWindows:
    """One log at one point: the window, m_t and m_T on it."""

    point: float
    update: int
    """0-based filter update."""
    window: GridSpec
    partial: F32
    truth: F32


def windows_figure(path: Path, name: str, pts: list[PointWindows], comps: dict[str, MapCompletions],
                   n_updates: int) -> None:
    """One row per point: m_t, a U-net's two samples, mean and uncertainty, the other networks' means, m_T."""
    from matplotlib.figure import Figure

    from mcnkit.viz.plots import image_row

    labels = list(comps)
    unet = next((lab for lab in labels if "U-net" in lab), labels[0] if labels else None)
    cols = ["m_t"]
    if unet:
        cols += [f"{unet} s1", f"{unet} s2", f"{unet} mean", "uncertainty"]
    cols += [f"{lab} mean" for lab in labels if lab != unet] + ["m_T"]
    fig = Figure(figsize=(1.6 * len(cols), 1.75 * len(pts)))
    axes = fig.subplots(len(pts), len(cols), squeeze=False)
    for r, pw in enumerate(pts):
        panels: list[tuple[NDArray[np.floating], str]] = [(pw.partial, "gray_r")]
        if unet:
            c = comps[unet]
            ks = c.samples.shape[1]
            panels += [(c.samples[r, min(j, ks - 1)], "gray_r") for j in range(2)]
            panels += [(c.mean[r], "gray_r"), (c.uncertainty[r], "magma")]
        panels += [(comps[lab].mean[r], "gray_r") for lab in labels if lab != unet]
        panels.append((pw.truth, "gray_r"))
        image_row(axes[r], panels, cols if r == 0 else None)
        axes[r, 0].set_ylabel(f"{pw.point:.0%}\nupdate {pw.update + 1}/{n_updates}", fontsize=7)
    fig.suptitle(name, fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def overview_figure(path: Path, name: str, final: TernaryMap, pts: list[PointWindows],
                    trajectory: NDArray[np.float64]) -> None:
    """The final map with the best particle's path (``trajectory`` (N, 3)) and the windows of the points."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    s = final.spec
    assert s is not None
    extent = (s.origin_x_m, s.origin_x_m + s.width * s.resolution_m, s.origin_y_m,
              s.origin_y_m + s.height * s.resolution_m)
    fig = Figure(figsize=(7, 7))
    ax = fig.subplots()
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


def _point_row(r: Exp3Row) -> str:
    return (f"| {r.point:.0%} | {r.update} | {r.unknown_share:.3f} | {r.truth_unknown_share:.3f} | "
            f"{r.method} | {r.variant} | {r.precision:.4f} | {r.recall:.4f} | "
            f"{r.f_measure:.4f} | {r.f_known:.4f} | {r.miou_unknown:.4f} |")


def markdown(cfg: Exp3Config, rows: list[Exp3Row], summary: list[Exp3Summary], infos: list[LogInfo],
             total_s: float) -> str:
    """``exp3.md`` of a run with ``cfg``."""
    k = cfg.samples
    lines = [f"# Experiment 3: map completion on real-robot logs ({', '.join(i.log for i in infos)})", ""]
    lines += [f"## Summary: mean over the {len(cfg.points)} points (± 95 % CI), free space positive", "",
              "| log | method | variant | F (whole window) | F (cells m_T knows) | mIoU unknown |", "|---|---|---|---|---|---|"]
    lines += [f"| {s.log} | {s.method} | {s.variant} | {s.f_measure:.4f} ± {s.f_measure_ci95:.4f} | "
              f"{s.f_known:.4f} ± {s.f_known_ci95:.4f} | {s.miou_unknown:.4f} ± {s.miou_unknown_ci95:.4f} |"
              for s in summary]
    lines.append("")
    for info in infos:
        lines += [f"## {info.log}: {info.scans} scans, {info.updates} filter updates", "",
                  "| point | update | m_t unknown | m_T unknown | method | variant | Prec | Rec | F | F (m_T known) | "
                  "mIoU unknown |", "|---|---|---|---|---|---|---|---|---|---|---|"]
        lines += [_point_row(r) for r in rows if r.log == info.log and r.variant != "per sample"]
        lines += ["", f"Figures: `exp3_{info.log}.png`, `exp3_{info.log}_overview.png`.", ""]
    lines += ["## The paper's real-lab table (one lab room; free space positive; Acc / Prec / Rec / F)", "",
              "| method | Acc | Prec | Rec | F |", "|---|---|---|---|---|", *paper.markdown_rows(paper.EXP3), ""]
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
        "Timing: " + "; ".join(f"{i.log} {i.total_s:.0f} s ({i.slam_cpu_s:.0f} s SLAM CPU)" for i in infos)
        + f"; total {total_s:.0f} s, torch threads {cfg.threads}.",
    ]
    lines += ["## Protocol and notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(lines)
