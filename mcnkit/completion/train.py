"""Training of the completion networks: ``unet`` (L2) and ``pix2pix`` (hinge cGAN + L2), single process or DDP.

* Loss (U-net, the paper's): L2 between the output (image', mask') and the encoding of m_T, per cell weighted
  ``unknown_weight`` where m_t is unknown and 1 elsewhere (normalized to mean 1).  pix2pix adds the generator's
  hinge loss from the PatchGAN on (m_t image, :func:`soft_convert` (output)), ``gan_weight`` against
  ``recon_weight`` × the same L2; the discriminator takes the hinge loss with m_T as the real image.
* Learning rate: warm-up, then cosine decay over the planned steps; with ``max_minutes`` the decay follows
  whichever runs out first, steps or time (a run cut by time is then not bit-reproducible on another machine).
* Each epoch shuffles with a generator seeded by ``(seed, epoch)``; dropout and augmentation draw from a
  generator seeded by ``(seed, epoch, rank)``: a run is reproducible and a resumed run continues it.
* ``free_weight``: the L2 weight of cells whose target is free is multiplied by it (class weighting).
* ``ema_decay`` > 0: a Polyak (exponential moving) average of the generator's weights and batch-norm statistics
  is kept; it is the network validated and saved as ``best`` (the raw weights keep training).
* Every epoch: validation (deterministic output, free class): F-measure and mIoU on unknown cells;
  ``OUT/last`` (resumable: optimizer states, EMA) and ``OUT/best`` (best ``(F + mIoU) / 2``) checkpoints.
* Under ``torchrun`` (``WORLD_SIZE`` > 1) the networks are wrapped in DistributedDataParallel (gloo on CPU,
  nccl on CUDA); each rank takes every ``world``-th pair of the epoch's order; rank 0 validates and saves.
"""

from __future__ import annotations

import copy
import math
import os
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.distributed as dist
from torch import nn
from torch.nn.parallel import DistributedDataParallel
from tqdm import tqdm

from mcnkit.completion.checkpoint import Checkpoint, build_models, load_checkpoint, save_checkpoint
from mcnkit.completion.data import augment_dihedral, encode, load_domain_pairs
from mcnkit.completion.masked import masked_bce, reveal_for_training
from mcnkit.completion.nets import (
    CompletionNet,
    DiscriminatorConfig,
    MaskedSampler,
    PatchDiscriminator,
    SamplerConfig,
    UNet,
    UNetConfig,
    soft_convert,
)
from mcnkit.completion.sample import complete
from mcnkit.completion.scores import score_maps
from mcnkit.completion.train_config import TrainConfig
from mcnkit.datasets import PairSplits
from mcnkit.threads import torch_threads

__all__ = ["TrainConfig", "TrainResult", "ema_update", "select_device", "train", "weighted_l2"]


@dataclass(frozen=True)
class TrainResult:
    """Outcome of a run: checkpoints, epochs done, best validation scores, wall time."""

    best_path: Path | None
    last_path: Path | None
    epochs_done: int
    best_val_f: float
    best_val_miou: float
    wall_time_s: float
    history: list[dict[str, float]]


def select_device(name: str = "auto") -> torch.device:
    """``auto`` → CUDA when present (the local rank's GPU under torchrun), else CPU."""
    if name == "auto":
        name = "cuda" if torch.cuda.is_available() else "cpu"
    if name == "cuda":
        return torch.device("cuda", int(os.environ.get("LOCAL_RANK", "0")))
    return torch.device(name)


def weighted_l2(
    output: torch.Tensor,
    target: torch.Tensor,
    unknown: torch.Tensor,
    unknown_weight: float,
    free_weight: float = 1.0,
) -> torch.Tensor:
    """Mean over cells and channels of w·(output − target)², w = ``unknown_weight`` on unknown cells, 1 elsewhere,
    times ``free_weight`` on cells whose target is free (image < 0.25); normalized to mean 1.

    A class weight moves the L2 optimum: with w_f on free and w_o on occupied targets the output image' crosses
    0.5 where p(free) = w_o / (w_f + w_o), so ``free_weight`` > 1 makes the fixed 0.5 rule predict free sooner.
    """
    w = 1.0 + (unknown_weight - 1.0) * unknown  # (B, 1, H, W)
    if free_weight != 1.0:
        w = w * (1.0 + (free_weight - 1.0) * (target[:, :1] < 0.25).to(w.dtype))
    w = w / w.mean()
    return ((output - target) ** 2 * w).mean()


@torch.no_grad()
def ema_update(ema: nn.Module, model: nn.Module, decay: float) -> None:
    """Polyak average: ema ← decay·ema + (1 − decay)·model over every float parameter and buffer (batch-norm
    statistics included); spectral-norm power-iteration vectors (``_u``, ``_v``) are re-normalized to unit length."""
    src = model.state_dict()
    for k, v in ema.state_dict().items():
        if not v.dtype.is_floating_point:
            v.copy_(src[k])
            continue
        v.lerp_(src[k], 1.0 - decay)
        if k.endswith("._u") or k.endswith("._v"):
            v.div_(v.norm().clamp_min(1e-12))


def _optim_tensors(opt: torch.optim.Optimizer, prefix: str) -> dict[str, torch.Tensor]:
    out = {}
    for idx, st in opt.state_dict()["state"].items():
        for name, v in st.items():
            out[f"optim.{prefix}.{idx}.{name}"] = torch.as_tensor(v).detach().clone()
    return out


def _load_optim(opt: torch.optim.Optimizer, ckpt: Checkpoint, prefix: str) -> None:
    sd = opt.state_dict()
    state: dict[int, dict[str, torch.Tensor]] = {}
    for key, v in ckpt.section(f"optim.{prefix}").items():
        idx, name = key.split(".", 1)
        state.setdefault(int(idx), {})[name] = v
    sd["state"] = state
    opt.load_state_dict(sd)


def _dist_info() -> tuple[int, int]:
    if dist.is_available() and dist.is_initialized():
        return dist.get_rank(), dist.get_world_size()
    return 0, 1


def _validate(gen: CompletionNet, splits: PairSplits, device: torch.device) -> dict[str, float]:
    pred = complete(gen, splits.val.partial, device=device)
    s = score_maps(pred, splits.val.target, splits.val.partial, "free")
    rec = {"val_f": s.f_measure, "val_miou": s.miou_unknown, "val_acc": s.accuracy}
    if isinstance(gen, MaskedSampler):
        rec["val_nll"] = _sampler_nll(gen, splits, device)
    return rec


@torch.no_grad()
def _sampler_nll(gen: MaskedSampler, splits: PairSplits, device: torch.device) -> float:
    """Mean cross-entropy of the sampler's p(occupied) on validation maps partly revealed (the same reveals every
    epoch), the figure it is trained and selected on."""
    x, y = encode(splits.val)
    x_in, cells = reveal_for_training(x, y, gen.config.schedule, torch.Generator().manual_seed(12345))
    total, n = 0.0, 0.0
    for i in range(0, len(x_in), 256):
        xi, ci = x_in[i : i + 256].to(device), cells[i : i + 256].to(device)
        w = float(ci.sum())
        total += float(masked_bce(gen(xi)[:, :1], y[i : i + 256, :1].to(device), ci)) * w
        n += w
    return total / max(n, 1.0)


def _score(rec: dict[str, float]) -> float:
    """What picks the best checkpoint: a sampler's validation cross-entropy (lower is better), else the mean of
    the deterministic completion's F and mIoU."""
    return -rec["val_nll"] if "val_nll" in rec else (rec["val_f"] + rec["val_miou"]) / 2


def _lr_factor(step: int, total: int, time_fraction: float = 0.0) -> float:
    """Linear warm-up, then cosine to 5 % over the steps — or over the time budget when that runs out first."""
    warm = min(200, max(total // 20, 1))
    if step < warm:
        return (step + 1) / warm
    progress = max((step - warm) / max(total - warm, 1), time_fraction)
    return 0.05 + 0.95 * 0.5 * (1 + math.cos(math.pi * min(progress, 1.0)))


def _build(cfg: TrainConfig, size: int) -> tuple[CompletionNet, PatchDiscriminator | None]:
    if cfg.model == "sampler":
        ucfg = UNetConfig(out_channels=1, base_channels=cfg.base_channels, max_channels=cfg.max_channels,
                          depth=cfg.depth, dropout=0.0, dropout_levels=0, size=size)
        sampler = MaskedSampler(SamplerConfig(ucfg, cfg.schedule))
        if cfg.init_from:
            sampler.load_state_dict(build_models(load_checkpoint(cfg.init_from), cfg.init_from)[0].state_dict())
        return sampler, None
    gcfg = UNetConfig(
        base_channels=cfg.base_channels,
        max_channels=cfg.max_channels,
        depth=cfg.depth,
        dropout=cfg.dropout,
        dropout_levels=cfg.dropout_levels,
        size=size,
    )
    gen = UNet(gcfg)
    disc = PatchDiscriminator(DiscriminatorConfig()) if cfg.model == "pix2pix" else None
    if cfg.init_from:
        src = load_checkpoint(cfg.init_from)
        gen.load_state_dict(build_models(src, cfg.init_from)[0].state_dict())
    return gen, disc


def train(cfg: TrainConfig, splits: PairSplits | None = None) -> TrainResult:
    """Trains per ``cfg`` (loading the pairs unless ``splits`` is given); see the module docstring."""
    with torch_threads(cfg.threads):
        return _train(cfg, splits)


def _train(cfg: TrainConfig, splits: PairSplits | None = None) -> TrainResult:
    t_start = time.perf_counter()
    rank, world = _dist_info()
    device = select_device(cfg.device)
    if splits is None:
        splits = load_domain_pairs(
            cfg.domain,
            cfg.n_train,
            cfg.n_val,
            cfg.n_test,
            cfg.seed,
            cfg.houseexpo,
            cfg.cache_dir,
            cfg.progress and rank == 0,
        )
    out = Path(cfg.out_dir)
    size = splits.train.partial.shape[-1]
    torch.manual_seed(cfg.seed)
    gen, disc = _build(cfg, size)
    gen.to(device)
    if disc is not None:
        disc.to(device)
    ema: CompletionNet | None = None
    if cfg.ema_decay > 0:
        ema = copy.deepcopy(gen).eval()
        for p in ema.parameters():
            p.requires_grad_(False)
    opt_g = torch.optim.Adam(gen.parameters(), lr=cfg.lr, betas=(cfg.beta1, 0.999))
    opt_d = torch.optim.Adam(disc.parameters(), lr=cfg.lr_discriminator, betas=(0.0, 0.9)) if disc is not None else None
    start_epoch, best, history, wall_before = 0, -1.0, [], 0.0
    best_f = best_miou = float("nan")
    if cfg.resume and (out / "last.json").is_file():
        ck = load_checkpoint(out / "last", cfg.model)
        g2, d2 = build_models(ck, out / "last")
        gen.load_state_dict(g2.state_dict())
        if disc is not None and d2 is not None:
            disc.load_state_dict(d2.state_dict())
        if ema is not None:
            ema_state = ck.section("ema.generator")
            ema.load_state_dict(ema_state if ema_state else gen.state_dict())
        _load_optim(opt_g, ck, "g")
        if opt_d is not None:
            _load_optim(opt_d, ck, "d")
        start_epoch = int(ck.info["epoch"]) + 1
        best, history = float(ck.info["best_score"]), list(ck.info.get("history", []))
        best_f, best_miou = float(ck.info.get("best_val_f", "nan")), float(ck.info.get("best_val_miou", "nan"))
        wall_before = float(ck.info.get("wall_time_s", 0.0))
    g_model: nn.Module = gen
    d_model: nn.Module | None = disc
    if world > 1:
        g_model = DistributedDataParallel(gen, device_ids=[device.index] if device.type == "cuda" else None)
        if disc is not None:
            d_model = DistributedDataParallel(disc, device_ids=[device.index] if device.type == "cuda" else None)
    x_all, y_all = encode(splits.train)
    n = len(x_all)
    steps_per_epoch = math.ceil(len(range(rank, n, world)) / cfg.batch_size)
    total_steps = steps_per_epoch * cfg.epochs
    step, stop, epoch = start_epoch * steps_per_epoch, False, start_epoch - 1
    last_path: Path | None = None
    for epoch in range(start_epoch, cfg.epochs):
        gen.train()
        order = torch.randperm(n, generator=torch.Generator().manual_seed(cfg.seed * 100_003 + epoch))[rank::world]
        rng = torch.Generator().manual_seed(int(np.random.SeedSequence([cfg.seed, epoch, rank]).generate_state(1)[0]))
        torch.manual_seed(int(rng.initial_seed()))
        bar = tqdm(
            range(steps_per_epoch), desc=f"epoch {epoch + 1}/{cfg.epochs}", disable=not (cfg.progress and rank == 0)
        )
        losses = []
        for i in bar:
            idx = order[i * cfg.batch_size : (i + 1) * cfg.batch_size]
            x, y = x_all[idx], y_all[idx]
            if cfg.augment:
                x, y = augment_dihedral(x, y, rng, cfg.augment_transpose)
            x, y = x.to(device), y.to(device)
            elapsed_min = (time.perf_counter() - t_start) / 60
            time_fraction = elapsed_min / cfg.max_minutes if cfg.max_minutes else 0.0
            for group in opt_g.param_groups:
                group["lr"] = cfg.lr * _lr_factor(step, total_steps, time_fraction)
            if cfg.model == "sampler":
                x_in, cells = reveal_for_training(x, y, cfg.schedule, rng)
                loss = masked_bce(g_model(x_in)[:, :1], y[:, :1], cells)
            else:
                unknown = x[:, 1:2]
                fake = g_model(x)
                loss = (
                    cfg.recon_weight * weighted_l2(fake, y, unknown, cfg.unknown_weight, cfg.free_weight)
                    if disc
                    else weighted_l2(fake, y, unknown, cfg.unknown_weight, cfg.free_weight)
                )
                if d_model is not None and opt_d is not None:
                    real_logits = d_model(x[:, :1], y[:, :1])
                    fake_logits = d_model(x[:, :1], soft_convert(fake.detach()))
                    loss_d = torch.relu(1 - real_logits).mean() + torch.relu(1 + fake_logits).mean()
                    opt_d.zero_grad(set_to_none=True)
                    loss_d.backward()
                    opt_d.step()
                    loss = loss - cfg.gan_weight * d_model(x[:, :1], soft_convert(fake)).mean()
            opt_g.zero_grad(set_to_none=True)
            loss.backward()
            opt_g.step()
            if ema is not None:
                # short warm-up of the average: decay ramps to ema_decay over the first steps
                ema_update(ema, gen, min(cfg.ema_decay, (1.0 + step) / (10.0 + step)))
            losses.append(float(loss.detach()))
            step += 1
            if i % 20 == 0:
                bar.set_postfix(loss=f"{np.mean(losses[-20:]):.4f}")
            over_time = cfg.max_minutes is not None and elapsed_min > cfg.max_minutes
            if over_time or (cfg.max_steps is not None and step >= cfg.max_steps):
                stop = True
                break
        bar.close()
        if rank == 0:
            gen.eval()
            shipped = ema if ema is not None else gen  # validated and saved as "best"
            rec: dict[str, float] = {
                "epoch": epoch,
                "train_loss": float(np.mean(losses)),
                **_validate(shipped, splits, device),
            }
            rec["wall_time_s"] = wall_before + time.perf_counter() - t_start
            history.append(rec)
            score = _score(rec)
            if cfg.progress:
                tqdm.write(
                    f"epoch {epoch + 1}: loss {rec['train_loss']:.4f} val F {rec['val_f']:.4f} "
                    f"mIoU {rec['val_miou']:.4f} ({rec['wall_time_s']:.0f} s)"
                )
            info: dict[str, Any] = {
                "epoch": epoch,
                "train_config": asdict(cfg),
                "history": history,
                "n_train_pairs": n,
                "wall_time_s": rec["wall_time_s"],
                "steps": step,
            }
            if score > best:
                best, best_f, best_miou = score, rec["val_f"], rec["val_miou"]
                save_checkpoint(
                    out / "best", cfg.model, shipped, disc, {**info, "val_f": best_f, "val_miou": best_miou}
                )
            extra = _optim_tensors(opt_g, "g") | (_optim_tensors(opt_d, "d") if opt_d is not None else {})
            if ema is not None:
                extra |= {f"ema.generator.{k}": v.detach().clone() for k, v in ema.state_dict().items()}
            info |= {"best_score": best, "best_val_f": best_f, "best_val_miou": best_miou}
            last_path = save_checkpoint(out / "last", cfg.model, gen, disc, info, extra)
        if world > 1:
            dist.barrier()
        if stop:
            break
    best_path = out / "best.safetensors" if rank == 0 and (out / "best.safetensors").is_file() else None
    return TrainResult(
        best_path, last_path, epoch + 1, best_f, best_miou, wall_before + time.perf_counter() - t_start, history
    )


def distributed_train(cfg: TrainConfig, splits: PairSplits | None = None) -> TrainResult:
    """:func:`train` inside a process group when launched by torchrun (``WORLD_SIZE`` > 1), else plain."""
    if int(os.environ.get("WORLD_SIZE", "1")) <= 1 or dist.is_initialized():
        return train(cfg, splits)
    backend = "nccl" if select_device(cfg.device).type == "cuda" else "gloo"
    dist.init_process_group(backend)
    try:
        return train(replace(cfg, progress=cfg.progress and dist.get_rank() == 0), splits)
    finally:
        dist.destroy_process_group()
