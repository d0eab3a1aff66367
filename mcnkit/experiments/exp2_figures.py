"""Experiment 2's figures: example completions (``exp2_examples.png``) and the scores along the run
(``exp2_curve.png``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mcnkit.experiments.common import MapCompletions
from mcnkit.experiments.houses import HouseRun
from mcnkit.experiments.rows import FILLS, ITERATIONS, CurveRow
from mcnkit.types import UNKNOWN

__all__ = ["curve_figure", "example_figure"]

_K_SHOW = 3
"""Samples of the U-net shown per example."""


def example_figure(path: Path, houses: list[HouseRun], late_updates: list[int],
                   comps: dict[str, dict[str, MapCompletions]], n: int) -> None:
    """Two rows for each of the first ``n`` houses (iteration 1, then the late update ``late_updates[i]``): m_t,
    a U-net's samples, mean and uncertainty, the other networks' means, m_T.  ``comps``: per iteration, per
    network label, the completions of every house."""
    from matplotlib.figure import Figure

    from mcnkit.viz.plots import image_row

    n = min(n, len(houses))
    labels = list(comps[ITERATIONS[0]])
    unet = next((lab for lab in labels if "U-net" in lab), labels[0] if labels else None)
    cols = ["m_t"]
    if unet:
        cols += [f"{unet} s{j + 1}" for j in range(_K_SHOW)] + [f"{unet} mean", "uncertainty"]
    cols += [f"{lab} mean" for lab in labels if lab != unet] + ["m_T"]
    fig = Figure(figsize=(1.55 * len(cols), 1.7 * 2 * n))
    axes = fig.subplots(2 * n, len(cols), squeeze=False)
    for i in range(n):
        h = houses[i]
        for j, it in enumerate(ITERATIONS):
            r = 2 * i + j
            update = 0 if it == ITERATIONS[0] else late_updates[i]
            partial = h.partial_at(update)
            panels: list[tuple[NDArray[np.floating], str]] = [(partial, "gray_r")]
            if unet:
                c = comps[it][unet]
                shown = min(_K_SHOW, c.samples.shape[1])
                panels += [(c.samples[i, s], "gray_r") for s in range(shown)]
                panels += [(np.full_like(partial, UNKNOWN), "gray_r")] * (_K_SHOW - shown)
                panels += [(c.mean[i], "gray_r"), (c.uncertainty[i], "magma")]
            panels += [(comps[it][lab].mean[i], "gray_r") for lab in labels if lab != unet]
            panels.append((h.truth, "gray_r"))
            image_row(axes[r], panels, cols if r == 0 else None)
            axes[r, 0].set_ylabel(f"{h.name.split(':')[-1][:6]}\niter {update + 1}/{h.n_updates}", fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def curve_figure(path: Path, rows: list[CurveRow]) -> None:
    """F and mIoU (± 95 % CI) against the fraction of the run's filter updates, one line per method."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(11, 4))
    axes = fig.subplots(1, 2)
    for m in dict.fromkeys(r.method for r in rows):
        rs = [r for r in rows if r.method == m]
        x = [r.fraction for r in rs]
        fill = m in FILLS
        for ax, y, e in ((axes[0], [r.f_measure for r in rs], [r.f_ci95 for r in rs]),
                         (axes[1], [r.miou_unknown for r in rs], [r.miou_ci95 for r in rs])):
            yv, ev = np.array(y, float), np.array(e, float)
            ax.plot(x, yv, marker="" if fill else "o", ms=3, ls="--" if fill else "-", label=m)
            ax.fill_between(x, yv - ev, yv + ev, alpha=0.0 if fill else 0.15)
    axes[0].set_ylabel("F (free space positive)")
    axes[1].set_ylabel("mIoU on cells unknown in m_t")
    for ax in axes:
        ax.set_xlabel("fraction of the run's filter updates")
        ax.set_ylim(0, 1)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
