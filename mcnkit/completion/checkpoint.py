"""Checkpoints: ``NAME.safetensors`` (tensors only, no pickle) + ``NAME.json`` (architecture, configs, training info).

Tensor keys are ``generator.*`` (the U-net), ``discriminator.*`` (pix2pix only), and, for resumable
checkpoints, ``optim.<net>.<param index>.<state>`` plus ``rng.torch`` (the data generator's state).  The JSON
holds ``format`` = ``"mcnkit-completion"``, ``version``, ``arch`` (``unet`` | ``pix2pix``), ``generator`` and
``discriminator`` configs and a free ``info`` dict (epoch, metrics, command...).  Loading into a model of
another architecture or shape, or a checkpoint with a NaN or infinite value in any floating-point tensor (a run
that diverged, damaged bytes: such a network completes every map alike), raises :class:`CheckpointError` with a
one-line message naming the file.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch
from safetensors import SafetensorError
from safetensors.torch import load_file, save_file
from torch import nn

from mcnkit.completion.nets import (
    CompletionNet,
    DiscriminatorConfig,
    MaskedSampler,
    PatchDiscriminator,
    SamplerConfig,
    UNet,
    UNetConfig,
)
from mcnkit.completion.registry import CheckpointError

__all__ = [
    "FORMAT",
    "VERSION",
    "Checkpoint",
    "CheckpointError",
    "build_models",
    "checkpoint_paths",
    "load_checkpoint",
    "load_generator",
    "save_checkpoint",
]

FORMAT = "mcnkit-completion"
VERSION = 1
ARCHS = ("unet", "pix2pix", "sampler")


@dataclass
class Checkpoint:
    """Loaded checkpoint: architecture, configs, tensors and info."""

    arch: str
    generator_config: UNetConfig | SamplerConfig
    discriminator_config: DiscriminatorConfig | None
    tensors: dict[str, torch.Tensor]
    info: dict[str, Any] = field(default_factory=dict)

    def section(self, prefix: str) -> dict[str, torch.Tensor]:
        """The tensors under ``prefix.`` with the prefix stripped."""
        n = len(prefix) + 1
        return {k[n:]: v for k, v in self.tensors.items() if k.startswith(prefix + ".")}


def checkpoint_paths(path: str | os.PathLike[str]) -> tuple[Path, Path]:
    """``(NAME.safetensors, NAME.json)`` for ``NAME``, ``NAME.safetensors`` or ``NAME.json``."""
    p = Path(path)
    if p.suffix in (".safetensors", ".json"):
        p = p.with_suffix("")
    return p.with_name(p.name + ".safetensors"), p.with_name(p.name + ".json")


def save_checkpoint(
    path: str | os.PathLike[str],
    arch: str,
    generator: nn.Module,
    discriminator: nn.Module | None = None,
    info: dict[str, Any] | None = None,
    extra_tensors: dict[str, torch.Tensor] | None = None,
) -> Path:
    """Writes the two files atomically (temp + rename); returns the ``.safetensors`` path."""
    if arch not in ARCHS:
        raise ValueError(f"arch must be one of {ARCHS}, got {arch!r}")
    tensors = {f"generator.{k}": v.detach().cpu().contiguous() for k, v in generator.state_dict().items()}
    if discriminator is not None:
        tensors |= {f"discriminator.{k}": v.detach().cpu().contiguous() for k, v in discriminator.state_dict().items()}
    tensors |= {k: v.detach().cpu().contiguous() for k, v in (extra_tensors or {}).items()}
    gcfg = getattr(generator, "config", None)
    dcfg = getattr(discriminator, "config", None) if discriminator is not None else None
    meta = {
        "format": FORMAT,
        "version": VERSION,
        "arch": arch,
        "generator": gcfg.as_dict() if gcfg is not None else None,
        "discriminator": dcfg.as_dict() if dcfg is not None else None,
        "info": info or {},
    }
    st_path, js_path = checkpoint_paths(path)
    st_path.parent.mkdir(parents=True, exist_ok=True)
    tmp_st, tmp_js = st_path.with_suffix(".safetensors.partial"), js_path.with_suffix(".json.partial")
    save_file(tensors, str(tmp_st), metadata={"format": FORMAT, "arch": arch})
    tmp_js.write_text(json.dumps(meta, indent=2))
    os.chmod(tmp_st, 0o644)  # safetensors writes 0600; shipped weights must be readable by everyone
    tmp_st.replace(st_path)
    tmp_js.replace(js_path)
    return st_path


def load_checkpoint(path: str | os.PathLike[str], expect_arch: str | None = None) -> Checkpoint:
    """Reads a checkpoint; :class:`CheckpointError` when files are missing, unreadable, or not ``expect_arch``."""
    st_path, js_path = checkpoint_paths(path)
    for p in (st_path, js_path):
        if not p.is_file():
            raise CheckpointError(f"{p}: checkpoint file not found")
    try:
        meta = json.loads(js_path.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise CheckpointError(f"{js_path}: unreadable checkpoint config ({exc})") from exc
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        raise CheckpointError(f"{js_path}: not an mcnkit completion checkpoint (format {meta.get('format')!r})")
    arch = meta.get("arch")
    if arch not in ARCHS:
        raise CheckpointError(f"{js_path}: unknown architecture {arch!r}")
    if expect_arch is not None and arch != expect_arch:
        raise CheckpointError(f"{st_path}: checkpoint is a {arch} model, expected {expect_arch}")
    try:
        gcfg: UNetConfig | SamplerConfig = (
            SamplerConfig.from_dict(meta["generator"]) if arch == "sampler" else UNetConfig(**meta["generator"])
        )
        dcfg = DiscriminatorConfig(**meta["discriminator"]) if meta.get("discriminator") else None
    except (TypeError, ValueError, KeyError) as exc:
        raise CheckpointError(f"{js_path}: bad network config ({exc})") from exc
    try:
        tensors = load_file(str(st_path))
    except (SafetensorError, OSError) as exc:
        raise CheckpointError(f"{st_path}: unreadable safetensors ({exc})") from exc
    _check_finite(tensors, st_path)
    return Checkpoint(str(arch), gcfg, dcfg, tensors, dict(meta.get("info") or {}))


def _check_finite(tensors: dict[str, torch.Tensor], where: Path) -> None:
    bad = {k: int((~torch.isfinite(v)).sum()) for k, v in tensors.items() if v.is_floating_point() or v.is_complex()}
    bad = {k: n for k, n in bad.items() if n}
    if bad:
        first = sorted(bad)[0]
        raise CheckpointError(
            f"{where}: {sum(bad.values())} non-finite value(s) (NaN or infinite) in {len(bad)} tensor(s), e.g. "
            f"{first!r} ({bad[first]}): a diverged or damaged checkpoint"
        )


def _load_into(model: nn.Module, state: dict[str, torch.Tensor], where: Path, what: str) -> None:
    own = model.state_dict()
    missing = sorted(set(own) - set(state))
    extra = sorted(set(state) - set(own))
    if missing or extra:
        raise CheckpointError(
            f"{where}: {what} does not match this architecture ({len(missing)} missing, {len(extra)} unexpected "
            f"tensors, e.g. {(missing or extra)[0]!r})"
        )
    for k, v in own.items():
        if v.shape != state[k].shape:
            raise CheckpointError(
                f"{where}: {what} tensor {k!r} has shape {tuple(state[k].shape)}, model has {tuple(v.shape)}"
            )
    model.load_state_dict(state)


def build_models(
    ckpt: Checkpoint, path: str | os.PathLike[str] = ""
) -> tuple[CompletionNet, PatchDiscriminator | None]:
    """Builds the checkpoint's networks and loads their weights (shape-checked)."""
    where = checkpoint_paths(path)[0] if path else Path("<checkpoint>")
    cfg = ckpt.generator_config
    gen: CompletionNet = MaskedSampler(cfg) if isinstance(cfg, SamplerConfig) else UNet(cfg)
    _load_into(gen, ckpt.section("generator"), where, "generator")
    disc = None
    if ckpt.discriminator_config is not None and ckpt.section("discriminator"):
        disc = PatchDiscriminator(ckpt.discriminator_config)
        _load_into(disc, ckpt.section("discriminator"), where, "discriminator")
    return gen, disc


def load_generator(
    path: str | os.PathLike[str],
    expect_arch: str | None = None,
    expect_config: UNetConfig | SamplerConfig | None = None,
) -> tuple[CompletionNet, dict[str, Any]]:
    """The generator of a checkpoint in eval mode, and its info; refuses another arch or config."""
    ckpt = load_checkpoint(path, expect_arch)
    if expect_config is not None and ckpt.generator_config != expect_config:
        diffs = [
            f"{k}={v} (expected {getattr(expect_config, k)})"
            for k, v in ckpt.generator_config.as_dict().items()
            if getattr(expect_config, k) != v
        ]
        raise CheckpointError(f"{checkpoint_paths(path)[0]}: generator shape differs: {', '.join(diffs)}")
    gen, _ = build_models(ckpt, path)
    gen.eval()
    return gen, ckpt.info
