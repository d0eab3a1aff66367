"""Column batching: many steps of one entity sent in one ``send_columns`` call (far cheaper than a ``log`` per
step), built from the rows the logger queued."""

from __future__ import annotations

from typing import Any

import numpy as np
import rerun as rr
from numpy.typing import NDArray

__all__ = ["entity_columns", "ternary_classes", "weight_colors"]


def ternary_classes(image: NDArray[np.float32]) -> NDArray[np.uint8]:
    return np.rint(np.asarray(image) * 2.0).astype(np.uint8)  # 0 / 0.5 / 1 -> 0 / 1 / 2


def weight_colors(w: NDArray[np.float64]) -> NDArray[np.uint8]:
    u = w / max(float(w.max()), 1e-12)
    return np.stack([40 + 215 * u, 90 + 60 * (1 - u), 255 * (1 - u)], axis=1).astype(np.uint8)



def entity_columns(kind: str, values: list[Any]) -> Any:
    """The ``send_columns`` columns of one queued entity: ``values`` holds one row per step."""
    n = len(values)
    if kind == "particles":  # (positions (N, 2), weights (N,)) per row; weights attached to every particle
        counts = [len(xy) for xy, _ in values]
        w_all = np.concatenate([w for _, w in values])
        w_rel = np.concatenate([w / max(float(w.max()), 1e-12) for _, w in values])
        return [*rr.Points2D.columns(positions=np.concatenate([xy for xy, _ in values]), radii=0.02 + 0.08 * w_rel,
                                     colors=weight_colors(w_rel)).partition(counts),
                *rr.AnyValues.columns(weight=w_all,
                                      particle_id=np.concatenate([np.arange(k) for k in counts])).partition(counts)]
    if kind == "arrow":  # a pose (3,) per row
        p = np.asarray(values)
        heading = 0.4 * np.stack([np.cos(p[:, 2]), np.sin(p[:, 2])], axis=1)
        return rr.Arrows2D.columns(origins=p[:, :2], vectors=heading).partition(np.ones(n, int))
    if kind == "hits":  # (M, 2) points per row
        return rr.Points2D.columns(positions=np.concatenate(values)).partition([len(h) for h in values])
    if kind == "point":  # one (2,) point per row
        return rr.Points2D.columns(positions=np.asarray(values))
    if kind == "segmentation":
        return rr.SegmentationImage.columns(buffer=np.stack(values).reshape(n, -1))
    if kind == "depth":
        return rr.DepthImage.columns(buffer=np.stack(values).reshape(n, -1))
    if kind == "place":  # window (origin x, origin y, cell size) per row
        v = np.asarray(values)
        return rr.Transform3D.columns(translation=np.c_[v[:, 0], v[:, 1], np.zeros(n)],
                                      scale=np.c_[v[:, 2], v[:, 2], np.ones(n)])
    if kind == "text":  # one filter-update message per row
        return rr.TextLog.columns(text=values, level=["INFO"] * n)
    return rr.Scalars.columns(scalars=np.asarray(values, np.float64))
