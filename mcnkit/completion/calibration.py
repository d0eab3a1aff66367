"""How good a sampler is: do its K samples differ where the map is truly uncertain, and only there?

All figures are on the cells **unknown in m_t** (the cells a completion has to guess), pooled over maps:

- ``error``: the share of (sample, cell) pairs where a sample differs from m_T (ternary labels);
- ``spread``: the share of (pair of samples, cell) where two samples differ.  A calibrated sampler's samples
  disagree with one another as often as with the truth: ``spread / error`` ≈ 1; a sampler of near copies has a
  ratio near 0;
- ``ece``: expected calibration error of the per-cell free probability estimated from the K samples (the share
  of samples that say free) against "m_T is free", over ``bins`` equal-width bins (weights = cell counts);
  ``reliability`` holds the diagram (per bin: mean predicted probability, observed frequency, cell count);
- ``best_of_k_ratio``: per map the error of the sample nearest m_T, summed, over the mean single-sample error
  summed (1: every sample equally good; small: one of the K is much closer to the truth than the average);
- ``f_single`` / ``f_majority`` / ``f_best_of_k``: the paper's free-space F-measure (whole map, per-map mean,
  :func:`mcnkit.completion.scores.score_maps`) of one sample (mean over the K), of the per-cell majority label of
  the K samples, and per map of the sample with the highest F (an oracle choosing among the K);
- ``known_kept``: the share of (sample, cell known in m_t) pairs where the sample keeps m_t's label;
- ``one_region`` / ``roughness`` / ``roughness_ratio``: whether each sample is shaped like a house
  (:mod:`mcnkit.completion.structure`): the share of samples whose free space is one region, their mean
  roughness, and that over the true maps' mean roughness (1: as rough as real houses).

``first`` = k' scores the per-sample figures (error, spread, best-of-K, F of one and of the best, structure) on
the first k' samples only and the per-cell frequencies (ECE, majority) on all K: more samples estimate a
probability better, while best-of-K depends on K itself.

Example:
    >>> s = np.zeros((1, 2, 2, 2), np.float32); s[0, 1, 0, 0] = 1.0       # two samples differing in one cell
    >>> m_t = np.full((1, 2, 2), 0.5, np.float32); m_T = np.zeros((1, 2, 2), np.float32)
    >>> r = score_samples(s, m_t, m_T); (r.error, r.spread)
    (0.125, 0.25)
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mcnkit.completion.scores import f_per_map, score_maps
from mcnkit.completion.structure import free_regions, roughness
from mcnkit.types import FREE, OCCUPIED, UNKNOWN

__all__ = ["SampleScores", "majority_labels", "score_samples"]

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class SampleScores:
    """A sampler's figures on one set of pairs (see the module docstring); ``reliability`` rows are
    (mean predicted free probability, observed free frequency, cells) per bin, NaN for empty bins."""

    n_maps: int
    k: int
    error: float
    spread: float
    spread_over_error: float
    ece: float
    best_of_k_error: float
    best_of_k_ratio: float
    f_single: float
    f_majority: float
    f_best_of_k: float
    reliability: F64
    known_kept: float = float("nan")
    one_region: float = float("nan")
    roughness: float = float("nan")
    roughness_ratio: float = float("nan")
    k_frequencies: int = 0
    """Samples behind ECE and the majority (0: the same K as the other figures)."""

    def summary(self) -> str:
        """The figures on one line (what the sampling benchmarks print)."""
        return (f"error {self.error:.3f} spread {self.spread:.3f} ratio {self.spread_over_error:.2f} ECE {self.ece:.3f} "
                f"best/single {self.best_of_k_ratio:.2f} F one {self.f_single:.3f} majority {self.f_majority:.3f} "
                f"best {self.f_best_of_k:.3f} kept {self.known_kept:.4f} one region {self.one_region:.2f} "
                f"roughness/truth {self.roughness_ratio:.2f}")

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict (the reliability diagram as nested lists, NaN as None)."""
        d = asdict(self)
        d["reliability"] = [[None if np.isnan(v) else float(v) for v in row] for row in self.reliability]
        return d


def majority_labels(samples: NDArray[np.floating]) -> NDArray[np.float32]:
    """Per cell the most frequent label of (N, K, H, W) ternary samples → (N, H, W) (ties: free, unknown,
    occupied in that order)."""
    s = np.asarray(samples)
    labels = np.array([FREE, UNKNOWN, OCCUPIED], np.float32)
    counts = np.stack([(s == v).sum(axis=1) for v in labels])
    return labels[counts.argmax(axis=0)]


def _reliability(p: F64, y: NDArray[np.bool_], bins: int) -> tuple[F64, float]:
    index = np.minimum((p * bins).astype(np.int64), bins - 1)
    n = np.bincount(index, minlength=bins).astype(np.float64)
    sum_p = np.bincount(index, weights=p, minlength=bins)
    sum_y = np.bincount(index, weights=y.astype(np.float64), minlength=bins)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean_p, freq = sum_p / n, sum_y / n
    table = np.stack([mean_p, freq, n], axis=1)
    filled = n > 0
    ece = float((np.abs(mean_p - freq)[filled] * n[filled]).sum() / max(n.sum(), 1.0))
    return table, ece


def score_samples(
    samples: NDArray[np.floating],
    partial: NDArray[np.floating],
    target: NDArray[np.floating],
    bins: int = 10,
    first: int | None = None,
) -> SampleScores:
    """Scores (N, K, H, W) ternary samples of m_t (N, H, W) against m_T (N, H, W) (``first``: see the module)."""
    every, m_t, m_T = np.asarray(samples), np.asarray(partial), np.asarray(target)
    if every.ndim != 4 or every.shape[0] != m_t.shape[0] or every.shape[2:] != m_t.shape[1:] or m_t.shape != m_T.shape:
        raise ValueError(f"shapes do not fit: samples {every.shape}, partial {m_t.shape}, target {m_T.shape}")
    s = every[:, :first] if first else every
    n, k = s.shape[:2]
    unk = m_t == UNKNOWN                                                     # (N, H, W)
    n_unk = float(unk.sum())
    if n_unk == 0:
        raise ValueError("no cell is unknown in m_t: nothing to score")
    wrong = ((s != m_T[:, None]) & unk[:, None]).sum(axis=(2, 3)).astype(np.float64)   # (N, K)
    error = float(wrong.sum() / (k * n_unk))
    pairs = [(a, b) for a in range(k) for b in range(a + 1, k)]
    spread = float(sum(((s[:, a] != s[:, b]) & unk).sum() for a, b in pairs) / (len(pairs) * n_unk)) if pairs else 0.0
    best = float(wrong.min(axis=1).sum() / n_unk)
    p_free = (every == FREE).mean(axis=1)[unk].astype(np.float64)
    table, ece = _reliability(p_free, (m_T == FREE)[unk], bins)
    f_per_sample = np.stack([f_per_map(s[:, j], m_T) for j in range(k)], axis=1)   # (N, K)
    known = np.broadcast_to(~unk[:, None], s.shape)
    rough, rough_truth = float(np.nanmean(roughness(s))), float(np.nanmean(roughness(m_T)))
    return SampleScores(
        n_maps=n, k=k, error=error, spread=spread, spread_over_error=spread / error if error > 0 else float("nan"),
        ece=ece, best_of_k_error=best, best_of_k_ratio=best / error if error > 0 else float("nan"),
        f_single=float(f_per_sample.mean()), f_majority=score_maps(majority_labels(every), m_T, m_t).f_measure,
        f_best_of_k=float(f_per_sample.max(axis=1).mean()), reliability=table,
        known_kept=float((s == m_t[:, None])[known].mean()) if known.any() else float("nan"),
        one_region=float((free_regions(s) == 1).mean()), roughness=rough, roughness_ratio=rough / rough_truth,
        k_frequencies=every.shape[1] if first else 0,
    )

