"""Pairs for training and evaluation, as tensors: loading a domain, encoding, dihedral augmentation.

Domains: ``houseexpo`` (the cached Pseudo-SLAM pairs of :mod:`mcnkit.datasets.pairs`, default cache
``<data>/cache/houseexpo-<n_train>``), ``houseexpo-explore`` (the same plans, m_t after 1–12 scans of a 360° 8 m
lidar from poses a robot could have reached: the maps MCN-SLAM completes during a run), ``houseexpo-seen`` (those
maps on the window an explorer completes, the seen part plus 2 m, where the plan's bounding box is unknown),
``houseexpo-seen-wide`` (the same, with more pairs from plans wider than that window, seen far enough to be framed
around the robot) and ``procedural`` (procedural apartments with HOME'S masking, built in memory); each HouseExpo
domain's :class:`~mcnkit.datasets.PairConfig` is in :data:`mcnkit.datasets.pairs.HOUSEEXPO_DOMAINS`.
Augmentation draws one of the 8 symmetries of the square per pair (flip left-right, flip up-down, transpose; or
flips only), the same for m_t and m_T, from an injected :class:`torch.Generator`.
"""

from __future__ import annotations

import os
from pathlib import Path

import torch

from mcnkit.completion.registry import DOMAINS
from mcnkit.datasets import PairSet, PairSplits, load_or_build_houseexpo_pairs, procedural_pairs
from mcnkit.datasets.houseexpo import default_data_dir, houseexpo_source
from mcnkit.datasets.pairs import HOUSEEXPO_DOMAINS, domain_pair_config
from mcnkit.grid import ternary_to_network

__all__ = ["DOMAINS", "augment_dihedral", "encode", "load_domain_pairs"]

if DOMAINS != (*HOUSEEXPO_DOMAINS, "procedural"):  # the names the command line offers are the ones built here
    raise ImportError(f"mcnkit.completion.registry.DOMAINS {DOMAINS} differs from the domains of {__name__}")


def load_domain_pairs(
    domain: str,
    n_train: int,
    n_val: int = 200,
    n_test: int = 100,
    seed: int = 0,
    houseexpo: str | os.PathLike[str] | None = None,
    cache_dir: str | os.PathLike[str] | None = None,
    progress: bool = True,
) -> PairSplits:
    """Train/val/test pairs of ``domain``; HouseExpo from ``houseexpo`` (default: installed, then ../shared/data)."""
    if domain == "procedural":
        return procedural_pairs(n_train, n_val, n_test, seed=seed)
    if domain not in HOUSEEXPO_DOMAINS:
        raise ValueError(f"unknown domain {domain!r} (choose from {', '.join(DOMAINS)})")
    source = houseexpo_source(houseexpo or None)
    if source is None or not source.exists():
        raise FileNotFoundError(2, "HouseExpo not found (install it or pass --houseexpo)", str(source or "houseexpo"))
    cache = Path(cache_dir) if cache_dir else default_data_dir() / "cache" / f"{domain}-{n_train}"
    cfg = domain_pair_config(domain, n_train, n_val, n_test, seed)
    splits, _ = load_or_build_houseexpo_pairs(source, cache, cfg, progress=progress)
    return splits


def encode(pairs: PairSet) -> tuple[torch.Tensor, torch.Tensor]:
    """(network input from m_t, network target from m_T), each (N, 2, H, W) float32."""
    return torch.from_numpy(ternary_to_network(pairs.partial)), torch.from_numpy(ternary_to_network(pairs.target))


def augment_dihedral(
    x: torch.Tensor, y: torch.Tensor, generator: torch.Generator | None = None, transpose: bool = True
) -> tuple[torch.Tensor, torch.Tensor]:
    """The same random symmetry of the square for each (x[i], y[i]); (B, C, H, W) with H = W.

    ``transpose=False``: flips only (the 4 symmetries that keep rows rows).  HouseExpo maps are not
    transpose-symmetric — padded to a square, the exterior lies mostly above and below the plan — and a net
    trained with transposes loses that cue (a net trained without them scores F 0.77 → 0.72 on transposed val).
    """
    b = x.shape[0]
    flips = torch.rand((3, b), generator=generator) < 0.5  # (lr, ud, transpose) per pair
    if not transpose:
        flips[2] = False
    for k, op in enumerate((lambda t: t.flip(-1), lambda t: t.flip(-2), lambda t: t.transpose(-1, -2))):
        sel = flips[k].to(x.device).view(b, 1, 1, 1)
        x, y = torch.where(sel, op(x), x), torch.where(sel, op(y), y)
    return x, y
