"""Static matplotlib figures: what a notebook shows when no live viewer is around (CI, a PDF export)."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from numpy.typing import NDArray

from mcnkit.types import TernaryMap

if TYPE_CHECKING:
    from mcnkit.mcn import Completion

__all__ = ["TERNARY_CMAP", "completion_figure", "image_row", "plot_slam_state", "plot_ternary"]

# free 0.0 -> light, unknown 0.5 -> grey, occupied 1.0 -> black (the viewer's AnnotationContext colours)
TERNARY_CMAP = ListedColormap([(235 / 255,) * 3, (128 / 255,) * 3, (20 / 255,) * 3])


def image_row(axes: Sequence[Axes], panels: Sequence[tuple[NDArray[np.floating], str]],
              titles: Sequence[str] | None = None) -> None:
    """One row of a figure grid: each (image in [0, 1], colormap) drawn on its axes without ticks, ``titles`` above
    (for the grid's first row)."""
    for i, (image, cmap) in enumerate(panels):
        ax = axes[i]
        ax.imshow(image, cmap=cmap, vmin=0.0, vmax=1.0, interpolation="nearest", origin="lower")
        ax.set_xticks([])
        ax.set_yticks([])
        if titles is not None:
            ax.set_title(titles[i], fontsize=7)


def plot_ternary(ax: Axes, ternary: TernaryMap, title: str = "") -> None:
    """Draws a ternary map in metres (row 0 at the bottom, as in the map frame)."""
    img = np.rint(np.asarray(ternary.image) * 2.0)
    if ternary.spec is None:
        ax.imshow(img, cmap=TERNARY_CMAP, vmin=0, vmax=2, origin="lower", interpolation="nearest")
    else:
        s = ternary.spec
        extent = (s.origin_x_m, s.origin_x_m + s.width * s.resolution_m,
                  s.origin_y_m, s.origin_y_m + s.height * s.resolution_m)
        ax.imshow(img, cmap=TERNARY_CMAP, vmin=0, vmax=2, origin="lower", extent=extent, interpolation="nearest")
    ax.set_aspect("equal")
    if title:
        ax.set_title(title)


def plot_slam_state(
    ax: Axes, ternary: TernaryMap | None, poses: NDArray[np.float64], weights: NDArray[np.float64],
    trajectory_xy: NDArray[np.float64] | None = None, odom_xy: NDArray[np.float64] | None = None, title: str = "",
) -> None:
    """Best map, particles (size and colour by weight), best trajectory (green) and raw odometry (grey)."""
    if ternary is not None:
        plot_ternary(ax, ternary)
    if odom_xy is not None and len(odom_xy):
        ax.plot(odom_xy[:, 0], odom_xy[:, 1], color="0.55", lw=1, label="odometry")
    if trajectory_xy is not None and len(trajectory_xy):
        ax.plot(trajectory_xy[:, 0], trajectory_xy[:, 1], color="tab:green", lw=1.5, label="SLAM")
    w = weights / max(float(weights.max()), 1e-12)
    ax.scatter(poses[:, 0], poses[:, 1], s=4 + 30 * w, c=w, cmap="plasma", vmin=0, vmax=1, zorder=3)
    ax.set_aspect("equal")
    if title:
        ax.set_title(title)


def completion_figure(completion: Completion, ranks: int | None = None, truth: TernaryMap | None = None) -> Figure:
    """One row per particle rank: its m_t, its K sampled completions, their uncertainty (and the ground truth
    on the same window when given, first row only)."""
    r_n = completion.samples.shape[0] if ranks is None else min(ranks, completion.samples.shape[0])
    k_n = completion.samples.shape[1]
    cols = k_n + 2 + (truth is not None)
    fig = Figure(figsize=(2.2 * cols, 2.3 * r_n), layout="constrained")
    axes = np.atleast_2d(fig.subplots(r_n, cols, squeeze=False))
    for r in range(r_n):
        plot_ternary(axes[r, 0], completion.partial_map(r), f"rank {r}: m_t")
        for k in range(k_n):
            plot_ternary(axes[r, 1 + k], completion.sample_map(r, k), f"sample {k}")
        w = completion.windows[r]
        extent = (w.origin_x_m, w.origin_x_m + w.width * w.resolution_m,
                  w.origin_y_m, w.origin_y_m + w.height * w.resolution_m)
        axes[r, k_n + 1].imshow(completion.uncertainty[r], origin="lower", cmap="magma", vmin=0, vmax=1,
                                extent=extent, interpolation="nearest")
        axes[r, k_n + 1].set_title("uncertainty")
        if truth is not None:
            if r == 0:
                plot_ternary(axes[r, -1], truth, "ground truth")
            else:
                axes[r, -1].axis("off")
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    return fig
