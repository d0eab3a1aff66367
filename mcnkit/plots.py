"""Static matplotlib figures: what a notebook shows when no live viewer is around (CI, a PDF export)."""

from __future__ import annotations

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap
from numpy.typing import NDArray

from mcnkit.types import TernaryMap

__all__ = ["TERNARY_CMAP", "plot_slam_state", "plot_ternary"]

# free 0.0 -> light, unknown 0.5 -> grey, occupied 1.0 -> black (the viewer's AnnotationContext colours)
TERNARY_CMAP = ListedColormap([(235 / 255,) * 3, (128 / 255,) * 3, (20 / 255,) * 3])


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
