"""What Experiments 2 and 3 share: a SLAM run that remembers the best particle at every filter update, exact
maps of that particle at any update, completions of a batch of windows, per-map scores and their aggregate (a
:class:`~mcnkit.completion.scores.Scores`), and the trivial fills (which Experiment 1 uses too).

**The best particle's map at update k** (the paper's ``m_t = argmax_m p(m | x_{0:t}, z_{1:t})``): at every filter
update :func:`run_slam` stores the ancestry poses of the particle that was best *at that update*
(``FastSlam.update_poses(best)``, ``k + 1`` poses).  :func:`map_at` rebuilds its map exactly with a
:class:`~mcnkit.slam.lineage.LineageMap` (the update scans ray-cast from those poses, the rule of
``FastSlam.best_map``), so the map at any update is available after the run without keeping N maps per update.
"""

from __future__ import annotations

import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.app.drive import DriveStep, Outcome, drive
from mcnkit.completion.nets import CompletionNet
from mcnkit.completion.sample import complete, label_entropy, sample_completions
from mcnkit.completion.scores import PositiveClass, Scores, mean_ci95, score_maps
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.slam.lineage import LineageMap
from mcnkit.types import FREE, UNKNOWN, Frame, TernaryMap

__all__ = [
    "METRICS",
    "MapCompletions",
    "SlamRun",
    "aggregate",
    "complete_windows",
    "fill_unknown",
    "map_at",
    "model_label",
    "new_lineage",
    "per_map_scores",
    "run_slam",
]

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]

METRICS = ("accuracy", "precision", "recall", "f_measure", "miou_unknown")
"""Per-map scores of :func:`per_map_scores` (the mIoU is on the cells unknown in m_t)."""

_LABELS = {"pix2pix": "(A) pix2pix", "unet": "(B) U-net", "unet-explore": "(B') U-net, exploration-trained"}


def model_label(name: str) -> str:
    """The paper's row label of a shipped model name, else the checkpoint's file stem."""
    return _LABELS.get(name, Path(name).name.removesuffix(".safetensors"))


@dataclass
class SlamRun:
    """A finished FastSLAM run and, per filter update, the ancestry poses of the particle best at that update."""

    slam: FastSlam
    best_poses: list[F64] = field(default_factory=list)
    """``best_poses[k]`` (k + 1, 3): the corrected poses, at updates 0..k, of the particle best at update k."""
    n_scans: int = 0
    cpu_s: float = 0.0

    @property
    def n_updates(self) -> int:
        """T, the number of filter updates."""
        return len(self.best_poses)


class _BestAncestry:
    """The :func:`mcnkit.app.drive.drive` sink of :func:`run_slam`: at every filter update, the ancestry poses of the
    particle best at that update."""

    def __init__(self, run: SlamRun) -> None:
        self.run = run

    def on_step(self, step: DriveStep) -> None:
        self.run.n_scans += 1
        if step.slam.updated:
            self.run.best_poses.append(self.run.slam.update_poses(step.slam.best_index))

    def close(self, outcome: Outcome) -> None:
        self.run.cpu_s = outcome.cpu_s


def run_slam(frames: Iterable[Frame], config: SlamConfig, rng: np.random.Generator) -> SlamRun:
    """Runs FastSLAM over ``frames`` (through :func:`mcnkit.app.drive.drive`), remembering the best particle's
    ancestry at every filter update."""
    run = SlamRun(FastSlam(config, rng))
    drive(frames, run.slam, [_BestAncestry(run)])
    if not run.best_poses:
        raise ValueError("the log produced no filter update (no frames?)")
    return run


def new_lineage(slam: FastSlam) -> LineageMap:
    """An empty :class:`LineageMap` with the beam limits and threshold of ``slam`` (after its first frame)."""
    lidar = slam.lidar
    assert lidar is not None
    max_range, usable = slam.beam_limits()
    return LineageMap(slam.config.resolution_m, lidar.angles_rad, lidar.base_to_laser.as_array(),
                      max_range_m=max_range, usable_m=usable, occ_thresh=slam.config.map.occ_thresh)


def map_at(run: SlamRun, k: int, lineage: LineageMap | None = None) -> TernaryMap:
    """The full-resolution ternary map of the particle that was best at update ``k`` (0-based; −1: the last),
    cropped to the cells it has seen.  Pass a ``lineage`` to reuse (it is synced by differences)."""
    lm = lineage if lineage is not None else new_lineage(run.slam)
    lm.sync(run.best_poses[k], run.slam.update_ranges)
    return lm.ternary()


def fill_unknown(partial: NDArray[np.floating], value: float) -> F32:
    """m_t with every unknown cell set to ``value`` (the trivial-fill sanity rows)."""
    out = np.asarray(partial, np.float32).copy()
    out[out == UNKNOWN] = value
    return out


def _keep_observed(pred: NDArray[np.floating], partial: NDArray[np.floating]) -> F32:
    """The network fills the unknown only: cells observed in m_t keep their label (as :class:`McnSlam`)."""
    return np.where(partial == UNKNOWN, pred, partial).astype(np.float32)


@dataclass(frozen=True)
class MapCompletions:
    """One network's completions of B windows: ``samples`` (B, K, S, S), ``mean`` (B, S, S) = ternary of the mean
    output, ``deterministic`` (B, S, S) = dropout off, ``uncertainty`` (B, S, S); observed cells of m_t kept."""

    samples: F32
    mean: F32
    deterministic: F32
    uncertainty: F32


def complete_windows(net: CompletionNet, partial: F32, k: int, generator: torch.Generator) -> MapCompletions:
    """K sampled completions (dropout on, one batch), their mean, and the deterministic completion of each m_t."""
    s = sample_completions(net, partial, k, generator)
    samples = _keep_observed(s.samples, partial[:, None])
    return MapCompletions(samples, _keep_observed(s.mean, partial), _keep_observed(complete(net, partial), partial),
                          label_entropy(samples))


def per_map_scores(pred: NDArray[np.floating], truth: NDArray[np.floating], partial: NDArray[np.floating],
                   positive: PositiveClass = "free", miou_mask: NDArray[np.bool_] | None = None) -> dict[str, F64]:
    """Per-map scores (B,) of predictions (B, S, S) or sample stacks (B, K, S, S: each map's mean over its K
    samples) against m_T (B, S, S); free or occupied positive, as :func:`~mcnkit.completion.scores.score_maps`.

    ``miou_mask`` (B, S, S): the cells the mIoU looks at (default: those unknown in m_t).
    """
    pred = np.asarray(pred)
    if pred.ndim == 3:
        pred = pred[:, None]
    b, k = pred.shape[:2]
    tr = np.broadcast_to(np.asarray(truth)[:, None], pred.shape).reshape(b * k, *pred.shape[2:])
    mask = (np.asarray(partial) == UNKNOWN) if miou_mask is None else np.asarray(miou_mask, bool)
    pa = np.broadcast_to(np.where(mask, UNKNOWN, FREE).astype(np.float32)[:, None], pred.shape)
    pa = pa.reshape(b * k, *pred.shape[2:])
    flat = pred.reshape(b * k, *pred.shape[2:])
    out: dict[str, list[float]] = {m: [] for m in METRICS}
    for i in range(b * k):
        s = score_maps(flat[i : i + 1], tr[i : i + 1], pa[i : i + 1], positive)
        for m in METRICS:
            out[m].append(getattr(s, m))
    with warnings.catch_warnings():  # a map whose mIoU cells are empty in every sample stays NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        return {m: np.nanmean(np.asarray(v, np.float64).reshape(b, k), axis=1) if b else np.zeros(0)
                for m, v in out.items()}


def aggregate(pred: NDArray[np.floating], truth: NDArray[np.floating], partial: NDArray[np.floating],
              positive: PositiveClass, miou_mask: NDArray[np.bool_] | None = None) -> Scores:
    """Per-map mean, 95 % CI half-width (F and mIoU) and pooled figures (counts summed over maps and samples), as
    the :class:`~mcnkit.completion.scores.Scores` of the B maps."""
    per = per_map_scores(pred, truth, partial, positive, miou_mask)
    p = np.asarray(pred)
    if p.ndim == 3:
        p = p[:, None]
    b, k = p.shape[:2]
    flat = p.reshape(b * k, *p.shape[2:])
    tr = np.broadcast_to(np.asarray(truth)[:, None], p.shape).reshape(flat.shape)
    mask = (np.asarray(partial) == UNKNOWN) if miou_mask is None else np.asarray(miou_mask, bool)
    pa = np.broadcast_to(np.where(mask, UNKNOWN, FREE).astype(np.float32)[:, None], p.shape).reshape(flat.shape)
    pooled = score_maps(flat, tr, pa, positive)
    means = {m: mean_ci95(per[m]) for m in METRICS}
    return replace(pooled, n_maps=b, accuracy=means["accuracy"][0], precision=means["precision"][0],
                   recall=means["recall"][0], f_measure=means["f_measure"][0], f_ci95=means["f_measure"][1],
                   miou_unknown=means["miou_unknown"][0], miou_ci95=means["miou_unknown"][1])
