"""Baseline (D): complete m_t with the training ground-truth map that best agrees with what m_t observed.

**Rule.**  For a query m_t, every training m_T is scored by its *precision on the observed cells*: the
number of cells observed in m_t (free or occupied) on which m_T carries the same label, divided by the number
of observed cells (the paper's "training map with the highest precision", read as agreement with the
observation).  The highest score wins (ties: the lowest training index).  The prediction is the retrieved
m_T with m_t's observed cells pasted over it (what was seen is kept).  Scores are one matrix product of
one-hot label images, so 1,000 queries against 16,000 maps take seconds.

Example:
    >>> bank = np.array([[[0.0, 1.0]], [[1.0, 1.0]]], np.float32)
    >>> retrieve(np.array([[[1.0, 0.5]]], np.float32), bank).index.tolist()
    [1]
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.types import FREE, OCCUPIED, UNKNOWN

__all__ = ["Retrieval", "retrieve"]

F32 = NDArray[np.float32]


@dataclass(frozen=True)
class Retrieval:
    """``index`` (N,) of the retrieved training maps, their ``score`` (N,), and ``prediction`` (N, H, W)."""

    index: NDArray[np.int64]
    score: F32
    prediction: F32


def _one_hot(maps: NDArray[np.floating]) -> torch.Tensor:
    m = torch.from_numpy(np.asarray(maps, np.float32)).flatten(1)
    return torch.cat([(m == FREE).float(), (m == OCCUPIED).float()], dim=1)  # (N, 2·H·W)


def retrieve(partial: NDArray[np.floating], bank: NDArray[np.floating], chunk: int = 256) -> Retrieval:
    """Retrieves, for each m_t in ``partial`` (N, H, W), the best map of ``bank`` (M, H, W) — see the rule above."""
    q = np.asarray(partial, np.float32)
    if q.ndim == 2:
        q = q[None]
    if len(bank) == 0:
        raise ValueError("retrieval needs a non-empty bank of training maps")
    bank_oh = _one_hot(bank)  # (M, 2HW)
    idx_all, score_all = [], []
    with torch.no_grad():
        for i in range(0, len(q), chunk):
            qo = _one_hot(q[i : i + chunk])  # (n, 2HW)
            n_obs = qo.sum(dim=1).clamp(min=1)
            agree = qo @ bank_oh.T  # (n, M): observed cells with the same label
            best = agree.argmax(dim=1)  # first maximum → lowest index on ties
            idx_all.append(best.numpy())
            score_all.append((agree.gather(1, best[:, None])[:, 0] / n_obs).numpy())
    index = np.concatenate(idx_all).astype(np.int64)
    pred = np.asarray(bank, np.float32)[index].copy()
    observed = q != UNKNOWN
    pred[observed] = q[observed]
    return Retrieval(index, np.concatenate(score_all).astype(np.float32), pred)
