"""Completion and real sampling: ``m_s ~ p_g(m | m_t)``.

:func:`complete` gives the deterministic completion (dropout off).  :func:`sample_completions` draws ``K``
completions per input in one batch of ``B·K`` with dropout kept on (and noise channels drawn, if the net has
any) from an injected :class:`torch.Generator`; it returns the ternary sample stack, the mean network output
and its ternary map, and a per-cell uncertainty = entropy of the K sampled labels (free / occupied / unknown)
divided by log 3 (0: all samples agree, 1: labels spread evenly).  :func:`diversity` is the mean over pairs of
samples of the share of cells on which they differ.

Example:
    >>> net = UNet(UNetConfig(base_channels=4, depth=2)).eval()
    >>> s = sample_completions(net, np.full((1, 64, 64), 0.5, np.float32), k=3, generator=torch.Generator().manual_seed(0))
    >>> s.samples.shape
    (1, 3, 64, 64)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.completion.nets import UNet
from mcnkit.grid import network_to_ternary, ternary_to_network
from mcnkit.types import FREE, OCCUPIED, UNKNOWN

__all__ = ["SampleSet", "complete", "diversity", "label_entropy", "sample_completions"]

F32 = NDArray[np.float32]


@dataclass(frozen=True)
class SampleSet:
    """``samples`` (B, K, H, W) ternary; ``mean_output`` (B, 2, H, W); ``mean`` (B, H, W) ternary of the mean
    output; ``uncertainty`` (B, H, W) in [0, 1]."""

    samples: F32
    mean_output: F32
    mean: F32
    uncertainty: F32

    @property
    def diversity(self) -> F32:
        """Per input, the mean share of cells on which two samples differ (B,)."""
        return diversity(self.samples)


def _as_input(partial: NDArray[np.floating] | torch.Tensor, device: torch.device) -> torch.Tensor:
    if isinstance(partial, torch.Tensor):
        x = partial
        if x.ndim == 3:
            x = torch.stack([x, (x == UNKNOWN).to(x.dtype)], dim=1)
    else:
        x = torch.from_numpy(ternary_to_network(np.asarray(partial, np.float32)))
    return x.to(device=device, dtype=torch.float32)


def _symmetric_output(net: UNet, x: torch.Tensor) -> torch.Tensor:
    """Mean of the outputs over the 8 symmetries of the square (each undone on its output); x square."""
    total = torch.zeros((x.shape[0], 2, *x.shape[2:]), dtype=x.dtype, device=x.device)
    for t in range(2):
        for k in range(4):
            xi = torch.rot90(x.transpose(-1, -2) if t else x, k, dims=(-2, -1))
            yi = torch.rot90(net(xi), -k, dims=(-2, -1))
            total += yi.transpose(-1, -2) if t else yi
    return total / 8.0


@torch.no_grad()
def complete(
    net: UNet,
    partial: NDArray[np.floating],
    device: torch.device | str = "cpu",
    batch_size: int = 256,
    symmetric: bool = False,
) -> F32:
    """Deterministic completions (N, H, W) ternary of m_t (N, H, W); the net is used in eval mode.

    ``symmetric``: average the output over the 8 symmetries of the square before conversion (8× the cost).
    """
    was_training = net.training
    net.eval()
    dev = torch.device(device)
    outs = []
    for i in range(0, len(partial), batch_size):
        x = _as_input(partial[i : i + batch_size], dev)
        outs.append((_symmetric_output(net, x) if symmetric else net(x)).cpu().numpy())
    net.train(was_training)
    if not outs:
        return np.zeros((0, *np.shape(partial)[1:]), np.float32)
    return network_to_ternary(np.concatenate(outs))


def label_entropy(samples: NDArray[np.floating]) -> F32:
    """Entropy of the labels along axis 1 of (B, K, H, W) ternary samples, divided by log 3 → (B, H, W)."""
    s = np.asarray(samples)
    k = s.shape[1]
    ent = np.zeros((s.shape[0], *s.shape[2:]), np.float64)
    for v in (FREE, UNKNOWN, OCCUPIED):
        p = (s == v).sum(axis=1) / k
        ent -= np.where(p > 0, p * np.log(np.maximum(p, 1e-12)), 0.0)
    return (ent / np.log(3.0)).astype(np.float32)


def diversity(samples: NDArray[np.floating]) -> F32:
    """Mean over the K(K−1)/2 pairs of samples of the share of cells on which they differ → (B,)."""
    s = np.asarray(samples)
    k = s.shape[1]
    if k < 2:
        return np.zeros(s.shape[0], np.float32)
    total = np.zeros(s.shape[0], np.float64)
    for i in range(k):
        for j in range(i + 1, k):
            total += (s[:, i] != s[:, j]).mean(axis=(-2, -1))
    return (total / (k * (k - 1) / 2)).astype(np.float32)


@torch.no_grad()
def sample_completions(
    net: UNet,
    partial: NDArray[np.floating] | torch.Tensor,
    k: int = 8,
    generator: torch.Generator | None = None,
    device: torch.device | str = "cpu",
) -> SampleSet:
    """K sampled completions of each m_t (B, H, W) [or network input (B, 2, H, W)], all in one batch."""
    if k < 1:
        raise ValueError(f"k must be at least 1, got {k}")
    was_training = net.training
    net.eval()  # batch norm uses its running statistics; dropout stays on through sample=True
    x = _as_input(partial, torch.device(device))
    b, c, h, w = x.shape
    xx = x.unsqueeze(1).expand(b, k, c, h, w).reshape(b * k, c, h, w)
    out = net(xx, sample=True, generator=generator).reshape(b, k, 2, h, w).cpu().numpy()
    net.train(was_training)
    samples = network_to_ternary(out)  # (B, K, H, W)
    mean_out = out.mean(axis=1)
    return SampleSet(samples, mean_out.astype(np.float32), network_to_ternary(mean_out), label_entropy(samples))
