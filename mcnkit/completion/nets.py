"""Completion networks: a U-net generator and a PatchGAN discriminator, spectral normalization on every conv.

Generator (the paper's (B) "U-net", and the generator of (A) "pix2pix"): input ``(B, 2 + noise, H, W)`` =
(ternary image, unknown mask[, noise]); output ``(B, 2, H, W)`` = (image', mask') in [0, 1] (sigmoid).
``depth`` stride-2 4×4 convolutions go down, ``depth`` stride-2 4×4 transposed convolutions come back up,
each decoder level concatenating the encoder features of the same size (the pix2pix skip block).
``H`` and ``W`` must be divisible by ``2**depth``.  Every conv and transposed conv is spectrally normalized
(:func:`torch.nn.utils.parametrizations.spectral_norm`); the decoder's inner levels carry dropout that
:class:`UNet` can keep on at inference (``sample=True``) so that repeated calls draw different completions.

Discriminator (pix2pix): a PatchGAN on ``(m_t image, converted output)`` (2 channels); every conv spectrally
normalized, LeakyReLU(0.2), no batch norm; one logit per patch.  "Converted" is :func:`soft_convert`, the
differentiable form of the paper's output rule (unknown 0.5 where mask' is high, else image').

Example:
    >>> net = UNet(UNetConfig(base_channels=8, depth=3))
    >>> net(torch.zeros(1, 2, 64, 64)).shape
    torch.Size([1, 2, 64, 64])
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import torch
from torch import nn
from torch.nn import functional as F
from torch.nn.utils.parametrizations import spectral_norm

from mcnkit.completion.train_config import SAMPLER_SCHEDULE

__all__ = [
    "CompletionNet",
    "DiscriminatorConfig",
    "MaskedSampler",
    "PatchDiscriminator",
    "SamplerConfig",
    "UNet",
    "UNetConfig",
    "has_spectral_norm",
    "occupancy_output",
    "soft_convert",
    "spectral_layers",
]


@dataclass(frozen=True)
class UNetConfig:
    """U-net shape: ``base_channels`` at the first level, doubling per level up to ``max_channels``."""

    in_channels: int = 2
    out_channels: int = 2
    base_channels: int = 32
    max_channels: int = 256
    depth: int = 4
    dropout: float = 0.2
    dropout_levels: int = 2
    noise_channels: int = 0
    size: int = 64

    def __post_init__(self) -> None:
        if self.depth < 1 or self.base_channels < 1 or self.in_channels < 1 or self.out_channels < 1:
            raise ValueError(f"U-net sizes must be positive: {self}")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"dropout must be in [0, 1), got {self.dropout}")
        if self.size % (2**self.depth):
            raise ValueError(f"size {self.size} is not divisible by 2**depth = {2**self.depth}")

    def as_dict(self) -> dict[str, Any]:
        """The config as plain JSON-able values."""
        return asdict(self)


@dataclass(frozen=True)
class DiscriminatorConfig:
    """PatchGAN shape: ``n_layers`` stride-2 convs from ``base_channels``, then two stride-1 convs."""

    in_channels: int = 2
    base_channels: int = 32
    n_layers: int = 2
    max_channels: int = 256

    def as_dict(self) -> dict[str, Any]:
        """The config as plain JSON-able values."""
        return asdict(self)


def _sn_conv(c_in: int, c_out: int, stride: int = 2, kernel: int = 4) -> nn.Module:
    return spectral_norm(nn.Conv2d(c_in, c_out, kernel, stride, padding=1 if kernel == 4 else kernel // 2))


def _sn_deconv(c_in: int, c_out: int) -> nn.Module:
    return spectral_norm(nn.ConvTranspose2d(c_in, c_out, 4, 2, padding=1))


class UNet(nn.Module):
    """The U-net generator; ``forward(x, sample=False, generator=None)`` → (B, 2, H, W) in [0, 1]."""

    def __init__(self, config: UNetConfig | None = None) -> None:
        super().__init__()
        self.config = cfg = config or UNetConfig()
        chans = [min(cfg.base_channels * 2**i, cfg.max_channels) for i in range(cfg.depth)]
        self.down = nn.ModuleList()
        self.down_norm = nn.ModuleList()
        c_prev = cfg.in_channels + cfg.noise_channels
        for i, c in enumerate(chans):
            self.down.append(_sn_conv(c_prev, c))
            # no norm on the first level (pix2pix) nor on the 1×1..2×2 bottleneck
            self.down_norm.append(nn.BatchNorm2d(c) if 0 < i < cfg.depth - 1 else nn.Identity())
            c_prev = c
        self.up = nn.ModuleList()
        self.up_norm = nn.ModuleList()
        for i in reversed(range(cfg.depth)):
            c_in = chans[i] if i == cfg.depth - 1 else 2 * chans[i]
            c_out = chans[i - 1] if i > 0 else cfg.out_channels
            self.up.append(_sn_deconv(c_in, c_out))
            self.up_norm.append(nn.BatchNorm2d(c_out) if i > 0 else nn.Identity())

    def forward(self, x: torch.Tensor, sample: bool = False, generator: torch.Generator | None = None) -> torch.Tensor:
        """``x``: (B, in_channels, H, W); ``sample`` keeps dropout on (and draws the noise channels)."""
        cfg = self.config
        if cfg.noise_channels:
            b, _, h, w = x.shape
            noise = _drawn(torch.randn, (b, cfg.noise_channels, h, w), x, generator)
            if not (self.training or sample):
                noise = torch.zeros_like(noise)
            x = torch.cat([x, noise], dim=1)
        skips = []
        for i, (conv, norm) in enumerate(zip(self.down, self.down_norm, strict=True)):
            x = norm(conv(x if i == 0 else F.leaky_relu(x, 0.2)))
            skips.append(x)
        drop_on = self.training or sample
        for j, (deconv, norm) in enumerate(zip(self.up, self.up_norm, strict=True)):
            if j > 0:
                x = torch.cat([x, skips[cfg.depth - 1 - j]], dim=1)
            x = norm(deconv(F.relu(x)))
            if j < cfg.dropout_levels and j < cfg.depth - 1 and cfg.dropout > 0:
                x = _dropout(x, cfg.dropout, drop_on, generator)
        return torch.sigmoid(x)


def _dropout(x: torch.Tensor, p: float, active: bool, generator: torch.Generator | None) -> torch.Tensor:
    if not active:
        return x
    keep = _drawn(torch.rand, x.shape, x, generator) >= p
    return x * keep / (1.0 - p)


def _drawn(fn: Callable[..., torch.Tensor], shape: Sequence[int], x: torch.Tensor,
           generator: torch.Generator | None) -> torch.Tensor:
    """Random numbers of ``shape`` for ``x``: drawn on the generator's own device, then moved to ``x``'s, so a
    CPU generator serves a net on the GPU (and gives it the same draws as on the CPU)."""
    device = generator.device if generator is not None else x.device
    return fn(tuple(shape), generator=generator, device=device, dtype=x.dtype).to(x.device)


class PatchDiscriminator(nn.Module):
    """PatchGAN on (m_t image, converted output): (B, 2, H, W) → patch logits (B, 1, h, w)."""

    def __init__(self, config: DiscriminatorConfig | None = None) -> None:
        super().__init__()
        self.config = cfg = config or DiscriminatorConfig()
        layers: list[nn.Module] = []
        c_prev = cfg.in_channels
        for i in range(cfg.n_layers + 1):
            c = min(cfg.base_channels * 2**i, cfg.max_channels)
            layers += [_sn_conv(c_prev, c, stride=2 if i < cfg.n_layers else 1), nn.LeakyReLU(0.2)]
            c_prev = c
        layers.append(_sn_conv(c_prev, 1, stride=1))
        self.net = nn.Sequential(*layers)

    def forward(self, partial_image: torch.Tensor, converted: torch.Tensor) -> torch.Tensor:
        """``partial_image``, ``converted``: (B, 1, H, W) each."""
        return torch.as_tensor(self.net(torch.cat([partial_image, converted], dim=1)))


def soft_convert(output: torch.Tensor) -> torch.Tensor:
    """Differentiable output rule: (B, 2, H, W) → (B, 1, H, W) = mask'·0.5 + (1 − mask')·image'."""
    image, mask = output[:, :1], output[:, 1:2]
    return mask * 0.5 + (1.0 - mask) * image


def spectral_layers(model: nn.Module) -> list[nn.Module]:
    """The conv and transposed-conv layers of ``model`` (the ones that should be spectrally normalized)."""
    return [m for m in model.modules() if isinstance(m, nn.Conv2d | nn.ConvTranspose2d)]


def has_spectral_norm(layer: nn.Module) -> bool:
    """Whether ``layer``'s weight is parametrized by spectral normalization."""
    params = getattr(layer, "parametrizations", None)
    if params is None or "weight" not in params:
        return False
    return any(type(p).__name__ == "_SpectralNorm" for p in params["weight"])


@dataclass(frozen=True)
class SamplerConfig:
    """A masked sampler: its U-net (2 input channels (image, mask), 1 output channel p(occupied)) and how it draws.

    ``schedule`` is the share of m_t's unknown cells whose labels are drawn by the end of each round, increasing
    to 1.0: few cells first, while the net still decides the house's extent, most cells last, when the drawn
    cells around them have pinned walls and rooms down.  Rounds that start once ``late_from`` of the cells are
    drawn use p(occupied) sharpened by ``late_temperature`` (< 1): those cells are nearly determined by the
    drawn ones, and drawing a whole round of them independently would otherwise scatter specks and dot the walls.
    ``settle`` lists the shares of a few sweeps after the last round, each re-masking that share of the cells and
    setting them to their most likely label given all the others.  Last, up to ``reconnect`` times, the walls that
    cut a sample's free space into separate regions are masked and drawn again given everything else: a wall
    drawn cell by cell in one round loses its door about as often as it keeps it, while the net, seeing the whole
    wall open, puts the door back.
    """

    unet: UNetConfig = UNetConfig(
        out_channels=1, base_channels=4, max_channels=128, depth=6, dropout=0.0, dropout_levels=0
    )
    schedule: tuple[float, ...] = SAMPLER_SCHEDULE
    late_temperature: float = 0.5
    late_from: float = 0.3
    reconnect: int = 2
    settle: tuple[float, ...] = (0.5, 0.5)

    def __post_init__(self) -> None:
        if self.unet.in_channels != 2 or self.unet.out_channels != 1 or self.unet.noise_channels:
            raise ValueError(f"a sampler's U-net reads (image, mask) and writes p(occupied): {self.unet}")
        s = self.schedule
        if not s or s[-1] != 1.0 or any(b <= a for a, b in itertools.pairwise(s)) or s[0] <= 0.0:
            raise ValueError(f"schedule must increase from above 0 to exactly 1.0, got {s}")
        if not 0.0 < self.late_temperature <= 1.0 or not 0.0 <= self.late_from <= 1.0:
            raise ValueError(f"late_temperature must be in (0, 1] and late_from in [0, 1]: {self}")
        if self.reconnect < 0 or any(not 0.0 < v <= 1.0 for v in self.settle):
            raise ValueError(f"settle shares must be in (0, 1], got {self.settle}")

    def as_dict(self) -> dict[str, Any]:
        """The config as plain JSON-able values."""
        return {"unet": self.unet.as_dict(), "schedule": list(self.schedule),
                "late_temperature": self.late_temperature, "late_from": self.late_from, "reconnect": self.reconnect,
                "settle": list(self.settle)}

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> SamplerConfig:
        """The inverse of :meth:`as_dict` (drawing settings left out take their defaults)."""
        default = cls()
        return cls(UNetConfig(**d["unet"]), tuple(float(v) for v in d["schedule"]),
                   float(d.get("late_temperature", default.late_temperature)),
                   float(d.get("late_from", default.late_from)), int(d.get("reconnect", default.reconnect)),
                   tuple(float(v) for v in d.get("settle", default.settle)))


class MaskedSampler(nn.Module):
    """A generative completion net: a U-net that gives p(occupied) of every unknown cell given m_t *and* any
    labels already drawn, so that drawing a map a share of cells at a time (``mcnkit.completion.masked``) makes
    each draw condition on the earlier ones: walls continue, rooms close, and K draws are K different houses.

    ``forward(x)`` is the deterministic view every completion net offers, (B, 2, H, W) = (image', mask'):
    image' = p(occupied | m_t) on unknown cells and m_t on known ones, mask' = 0 (the sampler completes every cell).
    """

    def __init__(self, config: SamplerConfig | None = None) -> None:
        super().__init__()
        self.config = config or SamplerConfig()
        self.net = UNet(self.config.unet)

    def forward(self, x: torch.Tensor, sample: bool = False, generator: torch.Generator | None = None) -> torch.Tensor:
        """``x``: (B, 2, H, W) = (image, mask); ``sample`` and ``generator`` are accepted for the U-net's signature
        (one pass is deterministic: sampling is :func:`mcnkit.completion.masked.draw`)."""
        return occupancy_output(self.net(x), x)


def occupancy_output(p_occupied: torch.Tensor, x: torch.Tensor) -> torch.Tensor:
    """(B, 2, H, W) = (p(occupied) on x's unknown cells and x's image on its known ones, 0) from (B, 1, H, W)."""
    known = x[:, 1:2] < 0.5
    return torch.cat([torch.where(known, x[:, :1], p_occupied), torch.zeros_like(p_occupied)], dim=1)


CompletionNet = UNet | MaskedSampler
"""Any completion net: a deterministic U-net (dropout samples) or a masked sampler."""
