"""Particle weights and resampling as pure functions (weights in, indices out).

* :func:`normalize_log_weights`: gmapping's flattened normalisation
  ``w_i ∝ exp(gain · (logw_i - max logw))`` with ``gain = 1 / (ogain · N)``;
* :func:`effective_sample_size`: ``Neff = 1 / Σ w_i²`` of normalised weights;
* :func:`low_variance_resample`: systematic resampling with one uniform draw.

Example:
    >>> w = normalize_log_weights(np.array([0.0, 0.0]), gain=1.0)
    >>> w.tolist(), float(effective_sample_size(w))
    ([0.5, 0.5], 2.0)
    >>> low_variance_resample(np.array([0.5, 0.0, 0.5]), u=0.5).tolist()
    [0, 2, 2]
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["effective_sample_size", "low_variance_resample", "normalize_log_weights"]


def normalize_log_weights(log_weights: NDArray[np.floating], gain: float = 1.0) -> NDArray[np.float64]:
    """Normalised weights (N,) from log-weights (N,), flattened by ``gain`` (1.0: plain softmax)."""
    lw = np.asarray(log_weights, dtype=np.float64)
    if lw.ndim != 1 or len(lw) == 0:
        raise ValueError(f"need a non-empty 1-D array of log-weights, got shape {lw.shape}")
    w = np.exp(gain * (lw - lw.max()))
    return np.asarray(w / w.sum())


def effective_sample_size(weights: NDArray[np.floating]) -> float:
    """``1 / Σ w²`` of normalised weights: N for uniform weights, 1 when one particle has all the weight."""
    w = np.asarray(weights, dtype=np.float64)
    return float(1.0 / np.sum(w * w))


def low_variance_resample(weights: NDArray[np.floating], u: float) -> NDArray[np.int64]:
    """Systematic resampling: N indices drawn with one offset ``u`` in [0, 1).

    The N pointers ``(u + k) / N`` (k = 0..N-1) are located in the cumulative weights; particle ``i`` is
    copied once for every pointer that falls in its slice.  Weights need not be normalised.
    """
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 1 or len(w) == 0 or (w < 0).any() or not w.sum() > 0:
        raise ValueError("weights must be a non-empty 1-D array of non-negative numbers with a positive sum")
    if not 0.0 <= u < 1.0:
        raise ValueError(f"u must be in [0, 1), got {u}")
    n = len(w)
    cumulative = np.cumsum(w / w.sum())
    cumulative[-1] = 1.0  # guard against rounding
    pointers = (u + np.arange(n)) / n
    return np.searchsorted(cumulative, pointers, side="right").astype(np.int64)
