"""Static matplotlib figures: what a notebook shows when no live viewer is around (CI, a PDF export)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from numpy.typing import NDArray

from mcnkit.types import TernaryMap

if TYPE_CHECKING:
    from mcnkit.explore.planners import Decision
    from mcnkit.explore.predict import Prediction
    from mcnkit.mcn import Completion

__all__ = ["TERNARY_CMAP", "completion_figure", "consistency_figure", "coverage_figure", "image_row", "plot_decision",
           "plot_prediction", "plot_slam_state", "plot_ternary"]

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


def consistency_figure(
    names: Sequence[str], poses: Sequence[NDArray[np.float64]], returns_base: Sequence[NDArray[np.float64]],
    pairs: Mapping[str, NDArray[np.int64]], errors_m: Mapping[str, Sequence[NDArray[np.float64]]],
    max_error_m: float = 0.1,
) -> Figure:
    """Where trajectories disagree with their log's scans (``mcnkit eval consistency --plot``): one panel per
    trajectory, its scans drawn at its poses (grey), and each relation the scans measured drawn at its poses,
    coloured by the trajectory's translation error on it (``pairs[kind]`` (K, 2) scan indices, ``errors_m[kind][t]``
    (K,) per trajectory ``t``): sequential ones as dots at the first scan, revisits as lines between the two scans."""
    from matplotlib.collections import LineCollection

    fig = Figure(figsize=(6.0 * len(names), 6.5), layout="constrained")
    axes = fig.subplots(1, len(names), squeeze=False)[0]
    mappable = None
    for t, (ax, name, p) in enumerate(zip(axes, names, poses, strict=True)):
        step = max(1, len(p) // 400)  # at most ~400 scans drawn: the walls, not every return
        for k in range(0, len(p), step):
            c, s_ = np.cos(p[k, 2]), np.sin(p[k, 2])
            r = returns_base[k]
            ax.plot(p[k, 0] + c * r[:, 0] - s_ * r[:, 1], p[k, 1] + s_ * r[:, 0] + c * r[:, 1], ",", color="0.6")
        ax.plot(p[:, 0], p[:, 1], color="0.3", lw=0.6)
        title = [name]
        for kind, pair in pairs.items():
            err = np.asarray(errors_m[kind][t])
            if not len(err):
                continue
            if kind == "revisits":
                segments = np.stack([p[pair[:, 0], :2], p[pair[:, 1], :2]], axis=1)
                lines = LineCollection(list(segments), cmap="inferno_r", linewidths=2.0, zorder=3)
                lines.set_array(err)
                lines.set_clim(0.0, max_error_m)
                ax.add_collection(lines)
            else:
                mappable = ax.scatter(p[pair[:, 0], 0], p[pair[:, 0], 1], c=err, s=6, cmap="inferno_r", vmin=0.0,
                                      vmax=max_error_m, zorder=4)
            title.append(f"{kind} {float(np.mean(err)):.3f} m")
        ax.set_aspect("equal")
        ax.set_title("\n".join(title), fontsize=9)
    if mappable is not None:
        fig.colorbar(mappable, ax=list(axes), shrink=0.8, label="translation error on the relation (m)")
    return fig


def plot_decision(ax: Axes, decision: Decision, trajectory_xy: NDArray[np.float64] | None = None,
                  title: str = "") -> None:
    """One planning step: the map planned on, the frontier cells coloured by their segment's score (yellow best),
    the viewpoints (size by gain), the chosen goal (magenta star) and its path, the trajectory so far (blue)."""
    d = decision
    plot_ternary(ax, TernaryMap(d.map_image, d.frontiers.grid))
    f, p = d.frontiers, d.points
    if f.n_segments and len(p):
        seg_score = np.full(f.n_segments, np.nan)
        seg_score[p.segment] = d.score
        xy = f.xy_m()
        rank = np.argsort(np.argsort(d.score)) / max(len(p) - 1, 1)
        seg_rank = np.full(f.n_segments, np.nan)
        seg_rank[p.segment] = rank
        ax.scatter(xy[:, 0], xy[:, 1], s=2, c=seg_rank[f.segment], cmap="viridis", vmin=0, vmax=1, zorder=3)
        gain = d.gain / max(float(d.gain.max()), 1e-9) if d.gain.any() else np.full(len(p), 0.3)
        ax.scatter(p.xy_m[:, 0], p.xy_m[:, 1], s=15 + 120 * gain, c=rank, cmap="viridis", vmin=0, vmax=1,
                   edgecolors="k", linewidths=0.5, zorder=4)
    if trajectory_xy is not None and len(trajectory_xy):
        ax.plot(trajectory_xy[:, 0], trajectory_xy[:, 1], color="tab:blue", lw=1.2, zorder=2)
    goal = d.goal_xy_m
    if goal is not None and d.path_m is not None:
        ax.plot(d.path_m[:, 0], d.path_m[:, 1], color="m", lw=1.5, zorder=5)
        ax.scatter([goal[0]], [goal[1]], marker="*", s=180, color="m", edgecolors="k", zorder=6)
    ax.set_xticks([])
    ax.set_yticks([])
    if title:
        ax.set_title(title, fontsize=9)


def plot_prediction(axes: Sequence[Axes], prediction: Prediction, goal_xy: NDArray[np.float64] | None = None) -> None:
    """The completions' window: the SLAM map on it, the samples' disagreement, then as many samples as there are
    axes left (the goal marked on each)."""
    w = prediction.window
    extent = (w.origin_x_m, w.origin_x_m + w.width * w.resolution_m, w.origin_y_m, w.origin_y_m + w.height * w.resolution_m)
    plot_ternary(axes[0], TernaryMap(prediction.partial, w), "m_t on the window")
    axes[1].imshow(prediction.disagreement, origin="lower", cmap="magma", vmin=0, vmax=1, extent=extent,
                   interpolation="nearest")
    axes[1].set_title("disagreement 4p(1-p)")
    for k, ax in enumerate(axes[2:]):
        if k < len(prediction.samples):
            plot_ternary(ax, TernaryMap(prediction.samples[k], w), f"sample {k}")
        else:
            ax.axis("off")
    for ax in axes:
        if goal_xy is not None:
            ax.scatter([goal_xy[0]], [goal_xy[1]], marker="*", s=90, color="m", edgecolors="k", zorder=5)
        ax.set_xticks([])
        ax.set_yticks([])


def coverage_figure(curves: Mapping[str, tuple[NDArray[np.float64], NDArray[np.float64]]], level: float = 0.9) -> Figure:
    """Coverage of the reachable free space against the path driven, one line per run (name -> (path, coverage))."""
    fig = Figure(figsize=(6.0, 3.6), layout="constrained")
    ax = fig.subplots()
    for name, (path, cov) in curves.items():
        reached = np.flatnonzero(cov >= level)
        label = name if not len(reached) else f"{name}: {level:.0%} at {path[reached[0]]:.1f} m"
        ax.plot(path, cov, label=label)
    ax.axhline(level, color="0.6", lw=0.8, ls=":")
    ax.set(xlabel="path driven [m]", ylabel="coverage", ylim=(0, 1.02))
    ax.legend(loc="lower right")
    return fig
