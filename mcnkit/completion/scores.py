"""Map-completion scores: the paper's per-cell binary classification, and mIoU on the cells unknown in m_t.

**Binary scores** (PAPER-NOTES.md, "Metric"): every cell of the predicted ternary map is classified against m_T,
positive = ``FREE`` (the paper's "room area", primary) or ``OCCUPIED``; a cell predicted unknown is a
negative.  Accuracy, precision, recall and F-measure per map; a map without predicted (or true) positives
has precision (recall) 0, and F = 0 when precision + recall = 0.  Reported as the per-map mean with a 95 %
normal-approximation confidence half-width (1.96 · sd / √n, sd with ddof = 1) and the pooled figure (counts
summed over all maps).

**mIoU on unknown cells**: over the cells that are unknown in m_t only, IoU of the free class and of the
occupied class (prediction vs m_T), averaged over the classes present (in the prediction or in m_T) in that
map; reported per-map mean (with CI) and pooled (IoU from summed intersections and unions).  A trivial fill
scores about half the share of its class there, so it cannot game this figure.

Example:
    >>> t = np.array([[[0.0, 1.0], [0.0, 0.0]]], np.float32)
    >>> score_maps(t, t, t, positive="free").f_measure
    1.0
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from mcnkit.types import FREE, OCCUPIED, UNKNOWN

__all__ = ["PositiveClass", "Scores", "f_per_map", "mean_ci95", "miou_unknown", "score_maps"]

PositiveClass = Literal["free", "occupied"]
F64 = NDArray[np.float64]
_VALUE = {"free": FREE, "occupied": OCCUPIED}


@dataclass(frozen=True)
class Scores:
    """Per-map means (with 95 % CI half-widths) and pooled figures for one method on one map set."""

    positive_class: str
    n_maps: int
    accuracy: float
    precision: float
    recall: float
    f_measure: float
    f_ci95: float
    miou_unknown: float
    miou_ci95: float
    pooled_accuracy: float
    pooled_precision: float
    pooled_recall: float
    pooled_f_measure: float
    pooled_miou_unknown: float

    def as_dict(self) -> dict[str, float | int | str]:
        """The scores as a flat dict (CSV row)."""
        return asdict(self)


def mean_ci95(values: NDArray[np.floating]) -> tuple[float, float]:
    """Mean and 95 % half-width (1.96 · sd / √n, ddof = 1; 0 for fewer than 2 values) ignoring NaN."""
    v = np.asarray(values, dtype=np.float64)
    v = v[~np.isnan(v)]
    if len(v) == 0:
        return float("nan"), float("nan")
    if len(v) < 2:
        return float(v.mean()), 0.0
    return float(v.mean()), float(1.96 * v.std(ddof=1) / np.sqrt(len(v)))


def _safe_div(a: NDArray[np.floating], b: NDArray[np.floating]) -> F64:
    a64, b64 = np.asarray(a, np.float64), np.asarray(b, np.float64)
    return np.divide(a64, b64, out=np.zeros_like(a64), where=b64 > 0)


def _f(p: NDArray[np.floating], r: NDArray[np.floating]) -> F64:
    return _safe_div(2 * np.asarray(p) * np.asarray(r), np.asarray(p) + np.asarray(r))


def miou_unknown(
    prediction: NDArray[np.floating], target: NDArray[np.floating], partial: NDArray[np.floating]
) -> tuple[F64, float]:
    """Per-map mIoU over {free, occupied} on cells unknown in ``partial`` (N,), and the pooled mIoU.

    Maps with no unknown cell get NaN (left out of means).
    """
    pred, tgt = np.asarray(prediction), np.asarray(target)
    unk = np.asarray(partial) == UNKNOWN
    ious, inter_tot, union_tot = [], [], []
    for v in (FREE, OCCUPIED):
        p, t = (pred == v) & unk, (tgt == v) & unk
        inter = (p & t).sum(axis=(-2, -1)).astype(np.float64)
        union = (p | t).sum(axis=(-2, -1)).astype(np.float64)
        ious.append(np.where(union > 0, inter / np.maximum(union, 1), np.nan))
        inter_tot.append(inter.sum())
        union_tot.append(union.sum())
    stacked = np.stack(ious)  # (2, N)
    present = ~np.isnan(stacked)
    per_map = np.where(present.any(axis=0), np.nansum(stacked, axis=0) / np.maximum(present.sum(axis=0), 1), np.nan)
    pooled = [i / u for i, u in zip(inter_tot, union_tot, strict=True) if u > 0]
    return per_map, float(np.mean(pooled)) if pooled else float("nan")


def _counts(pred: NDArray[np.floating], tgt: NDArray[np.floating], positive: PositiveClass) -> tuple[F64, F64, F64]:
    """Per map: true positives, false positives, false negatives of class ``positive``."""
    v = _VALUE[positive]
    p, t = pred == v, tgt == v
    def count(m: NDArray[np.bool_]) -> F64:
        return m.sum(axis=(-2, -1)).astype(np.float64)
    return count(p & t), count(p & ~t), count(~p & t)


def f_per_map(prediction: NDArray[np.floating], target: NDArray[np.floating], positive: PositiveClass = "free") -> F64:
    """The F-measure of each ternary map (N, H, W) against m_T (N,): what :func:`score_maps` averages."""
    tp, fp, fn = _counts(np.asarray(prediction), np.asarray(target), positive)
    return _f(_safe_div(tp, tp + fp), _safe_div(tp, tp + fn))


def score_maps(
    prediction: NDArray[np.floating],
    target: NDArray[np.floating],
    partial: NDArray[np.floating],
    positive: PositiveClass = "free",
) -> Scores:
    """Scores ternary predictions (N, H, W) against m_T (N, H, W); ``partial`` = m_t selects the mIoU cells."""
    pred = np.asarray(prediction)
    tgt = np.asarray(target)
    if pred.ndim == 2:
        pred, tgt, partial = pred[None], tgt[None], np.asarray(partial)[None]
    if pred.shape != tgt.shape or pred.shape != np.asarray(partial).shape:
        raise ValueError(f"shapes differ: prediction {pred.shape}, target {tgt.shape}, partial {np.shape(partial)}")
    tp, fp, fn = _counts(pred, tgt, positive)
    n_cells = pred.shape[-1] * pred.shape[-2]
    tn = n_cells - tp - fp - fn
    acc = (tp + tn) / n_cells
    prec, rec = _safe_div(tp, tp + fp), _safe_div(tp, tp + fn)
    f = _f(prec, rec)
    f_mean, f_ci = mean_ci95(f)
    per_map_iou, pooled_iou = miou_unknown(pred, tgt, partial)
    iou_mean, iou_ci = mean_ci95(per_map_iou)
    ptp, pfp, pfn = float(tp.sum()), float(fp.sum()), float(fn.sum())
    pp = ptp / (ptp + pfp) if ptp + pfp > 0 else 0.0
    pr = ptp / (ptp + pfn) if ptp + pfn > 0 else 0.0
    return Scores(
        positive_class=positive,
        n_maps=len(pred),
        accuracy=float(acc.mean()),
        precision=float(prec.mean()),
        recall=float(rec.mean()),
        f_measure=f_mean,
        f_ci95=f_ci,
        miou_unknown=iou_mean,
        miou_ci95=iou_ci,
        pooled_accuracy=float((tp + tn).sum() / (n_cells * len(pred))),
        pooled_precision=pp,
        pooled_recall=pr,
        pooled_f_measure=2 * pp * pr / (pp + pr) if pp + pr > 0 else 0.0,
        pooled_miou_unknown=pooled_iou,
    )
