"""K sampled completions of the robot's map at a planning step, on a window chosen for a house not yet seen whole.

The completion nets were trained with the whole house filling the 64 × 64 window (its bounding box padded
square).  While exploring, the house's extent is unknown: the window is the SLAM map's seen bounds plus
``window_margin_m`` (room for what lies past the frontiers), at least ``window_min_m`` wide, padded square
(:func:`choose_window`; ``benchmarks/bench_explore.py --study`` measures margins on training houses); a building
wider than ``window_max_m`` is completed on a window of that side around the robot.  The
best particle's map is pooled onto it (occupied > free > unknown) and the net draws K completions; the cells the
map knows keep their label in every sample.

Example:
    >>> pred = predict(net, lineage, GainConfig(samples=8), torch.Generator().manual_seed(0))  # doctest: +SKIP
    >>> pred.samples.shape                                                                     # doctest: +SKIP
    (8, 64, 64)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.completion.nets import CompletionNet
from mcnkit.completion.sample import sample_completions
from mcnkit.explore.config import GainConfig
from mcnkit.grid import seen_window
from mcnkit.slam.lineage import LineageMap
from mcnkit.types import OCCUPIED, UNKNOWN, GridSpec

__all__ = ["Prediction", "choose_window", "complete_on", "predict"]

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Prediction:
    """K completions of the map on one window."""

    window: GridSpec
    partial: F32
    """(S, S) the SLAM map pooled on the window (the network's input), ternary."""
    samples: F32
    """(K, S, S) sampled completions, ternary; cells known in ``partial`` keep their label."""

    @property
    def p_occupied(self) -> F32:
        """(S, S) share of the samples that say occupied."""
        return np.asarray((self.samples == OCCUPIED).mean(axis=0), np.float32)

    @property
    def disagreement(self) -> F32:
        """(S, S) 4·p·(1 − p) of :attr:`p_occupied`: 0 where the samples agree, 1 where they split evenly."""
        p = self.p_occupied
        return np.asarray(4.0 * p * (1.0 - p), np.float32)


def choose_window(bounds_m: tuple[float, float, float, float], config: GainConfig, size: int,
                  min_resolution_m: float, robot_xy_m: F64 | None = None) -> GridSpec:
    """The seen bounds ``(x0, y0, x1, y1)`` plus ``window_margin_m``, at least ``window_min_m`` wide, padded square
    on ``size``² cells (never finer than ``min_resolution_m``); wider than ``window_max_m``: a square of that side
    centred on ``robot_xy_m`` (on the bounds' centre without it)."""
    return seen_window(bounds_m, size, config.window_margin_m, config.window_min_m, config.window_max_m,
                       min_resolution_m, None if robot_xy_m is None else (float(robot_xy_m[0]), float(robot_xy_m[1])))


def complete_on(net: CompletionNet, partial: F32, k: int, generator: torch.Generator) -> tuple[F32, F32]:
    """K completions (K, S, S) of one pooled map ``partial`` (S, S) and their mean completion (S, S, the ternary
    map of the mean network output), the known cells of ``partial`` kept in both."""
    s = sample_completions(net, partial[None], k, generator)
    keep = partial == UNKNOWN
    return (np.where(keep[None], s.samples[0], partial[None]).astype(np.float32),
            np.where(keep, s.mean[0], partial).astype(np.float32))


def predict(net: CompletionNet, lineage: LineageMap, config: GainConfig, generator: torch.Generator,
            robot_xy_m: F64 | None = None, size: int = 64) -> Prediction:
    """K completions of the map held by ``lineage`` on the window of :func:`choose_window`."""
    window = choose_window(lineage.seen_bounds_m(), config, size, lineage.resolution_m, robot_xy_m)
    partial = lineage.pooled(window).astype(np.float32)
    return Prediction(window, partial, complete_on(net, partial, config.samples, generator)[0])
