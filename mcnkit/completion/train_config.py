"""What a training run of a completion net depends on (:class:`TrainConfig`), apart from :mod:`mcnkit.completion.train`
so that the command line can generate ``mcnkit train``'s flags without importing torch; and the masked sampler's
default round schedule (:data:`SAMPLER_SCHEDULE`), which training and drawing share."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["SAMPLER_SCHEDULE", "TrainConfig"]

SAMPLER_SCHEDULE: tuple[float, ...] = (
    0.002, 0.00315, 0.00496, 0.00782, 0.01232, 0.0194, 0.03057, 0.04817, 0.0759, 0.1196, 0.1884, 0.3, 0.6, 1.0,
)  # fmt: skip
"""The share of m_t's unknown cells drawn by the end of each round of a masked sampler: twelve rounds growing
geometrically up to 0.3, while the drawn cells still decide rooms, walls and doors, then two large rounds for cells
that those decisions nearly determine.  Training reveals shares spread evenly over the rounds."""


@dataclass(frozen=True)
class TrainConfig:
    """Everything a training run depends on (written into every checkpoint)."""

    model: Literal["unet", "pix2pix", "sampler"] = "unet"
    """unet: the paper's U-net (L2 loss); pix2pix: the same generator with a patch discriminator; sampler: a masked
    sampler that draws whole maps round by round (cross-entropy on partly revealed maps)."""
    domain: str = "houseexpo"
    """houseexpo: the paper's pairs (one 180°, 2 m scan); houseexpo-explore: m_t after 1–12 scans of a 360°, 8 m
    lidar (what MCN-SLAM completes during a run); houseexpo-seen: those maps on the window an explorer completes
    (the seen part plus 2 m, not the plan's bounding box); houseexpo-seen-wide: the same with 4 more pairs of up
    to 48 scans from each plan wider than that window; procedural: HOME'S-style masks."""
    out_dir: str = "runs/unet"
    """Run directory (``best.*`` and ``last.*`` checkpoints)."""
    n_train: int = 5000
    """Training pairs."""
    n_val: int = 200
    """Validation pairs, scored after each epoch."""
    n_test: int = 1000
    """Test pairs built with the split (part of the pair cache's key)."""
    epochs: int = 10
    """Passes over the training pairs."""
    batch_size: int = 32
    """Pairs per optimiser step."""
    lr: float = 2e-3
    """Adam learning rate of the generator (warm-up, then cosine decay)."""
    lr_discriminator: float = 2e-4
    """pix2pix: Adam learning rate of the discriminator."""
    beta1: float = 0.5
    """Adam beta1 of the generator (pix2pix's 0.5)."""
    seed: int = 0
    """Seed of the pairs, the weights and the batches."""
    unknown_weight: float = 2.0
    """unet, pix2pix: L2 weight on the cells unknown in m_t (the cells a completion has to guess)."""
    recon_weight: float = 100.0
    """pix2pix: weight of the L2 term against the adversarial one."""
    gan_weight: float = 1.0
    """pix2pix: weight of the adversarial term."""
    augment: bool = True
    """Augment every pair by a random symmetry of the square."""
    augment_transpose: bool = True
    """Symmetries include transposes; off: flips only (HouseExpo plans are wider than tall once padded square)."""
    base_channels: int = 16
    """Channels of the U-net's first level."""
    max_channels: int = 128
    """Channels of the U-net's deeper levels at most (they double per level up to this)."""
    depth: int = 4
    """U-net levels; the map side must divide by 2^depth."""
    dropout: float = 0.2
    """unet, pix2pix: dropout probability in the innermost decoder levels, kept on when drawing samples."""
    dropout_levels: int = 2
    """unet, pix2pix: innermost decoder levels that carry dropout."""
    free_weight: float = 1.0
    """unet, pix2pix: L2 weight factor on cells whose target is free (class weighting)."""
    ema_decay: float = 0.0
    """Decay of an exponential moving average of the weights, which is validated and shipped (0: off)."""
    max_minutes: float | None = None
    """Stop after this wall time (ends the epoch; the learning rate then decays over the time budget)."""
    max_steps: int | None = None
    """Stop after this many optimiser steps."""
    init_from: str | None = None
    """Initialise the generator from this checkpoint."""
    resume: bool = False
    """Continue the run in ``out_dir`` from its ``last`` checkpoint."""
    device: str = "auto"
    """auto (CUDA when present), cpu or cuda."""
    threads: int = 2
    """Torch CPU threads."""
    progress: bool = True
    """Show a progress bar."""
    houseexpo: str | None = None
    """HouseExpo json.tar.gz (default: the installed one, then the shared data folder)."""
    cache_dir: str | None = None
    """Pair cache directory (default: <data>/cache/<domain>-<n_train>)."""
    schedule: tuple[float, ...] = SAMPLER_SCHEDULE
    """sampler: the share of the unknown cells drawn by the end of each round (increasing to 1.0); training
    reveals shares spread evenly over these rounds."""

    def __post_init__(self) -> None:
        if self.model not in ("unet", "pix2pix", "sampler"):
            raise ValueError(f"model must be unet, pix2pix or sampler, got {self.model!r}")
        if self.epochs < 1 or self.batch_size < 1 or self.n_train < 1:
            raise ValueError("epochs, batch size and n_train must be positive")
