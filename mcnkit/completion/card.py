"""Shipping a trained run: copy its best checkpoint into ``mcnkit/weights`` (no optimizer state) with a model card.

The card (``NAME.md``) records the data, split, seed, epochs, wall time, the validation history and the test
metrics measured here, and the exact command that reproduces the run.

    python -m mcnkit.completion.card RUN_DIR NAME --command "mcnkit train ..." [--weights-dir DIR]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np
import torch

from mcnkit.completion.calibration import score_samples
from mcnkit.completion.checkpoint import (
    CheckpointError,
    build_models,
    checkpoint_paths,
    load_checkpoint,
    save_checkpoint,
)
from mcnkit.completion.data import load_domain_pairs
from mcnkit.completion.nets import SamplerConfig
from mcnkit.completion.registry import default_weights_dir
from mcnkit.completion.sample import complete, sample_completions
from mcnkit.completion.scores import Scores, score_maps
from mcnkit.datasets import PairSet

__all__ = ["ship"]


def _subset(p: PairSet, n: int) -> PairSet:
    return PairSet(p.partial[:n], p.target[:n], p.ids[:n])


def _line(name: str, s: Scores) -> str:
    return (
        f"| {name} | {s.n_maps} | {s.accuracy:.4f} | {s.precision:.4f} | {s.recall:.4f} | "
        f"{s.f_measure:.4f} ± {s.f_ci95:.4f} | {s.miou_unknown:.4f} ± {s.miou_ci95:.4f} |"
    )


def _init_time(tc: dict[str, Any], own_s: float) -> str:
    """The wall time of the run this one was initialised from, and the sum (to the shipped checkpoint)."""
    if not tc.get("init_from"):
        return ""
    try:
        init_s = float(load_checkpoint(tc["init_from"]).info["wall_time_s"])
    except (CheckpointError, KeyError, TypeError, ValueError):
        return " — plus the run it was initialised from"
    total = init_s + own_s
    return (
        f" — plus the run it was initialised from (its best checkpoint after {init_s:.0f} s): "
        f"{total:.0f} s ({total / 60:.1f} min) from scratch to this checkpoint"
    )


def _augment(tc: dict[str, Any]) -> str:
    if not tc["augment"]:
        return "none"
    if tc.get("augment_transpose", True):
        return "the 8 symmetries of the square (flips and transposes)"
    return "flips (left-right, up-down; no transposes)"


def _pair_build(manifest: dict[str, Any]) -> str:
    secs = manifest.get("build_seconds")
    if not secs:
        return ""
    return (f"\n- Pairs: built once and cached in {float(secs):.0f} s ({float(secs) / 60:.1f} min), before the run and "
            "not in its wall time.")


def ship(run_dir: str | Path, name: str, command: str, weights_dir: str | Path | None = None,
         conditions: str = "2 CPU cores") -> Path:
    """Copies ``RUN_DIR/best`` to ``WEIGHTS/NAME`` and writes ``WEIGHTS/NAME.md``; returns the card path."""
    src = Path(run_dir) / "best"
    ck = load_checkpoint(src)
    gen, disc = build_models(ck, src)
    gen.eval()
    info: dict[str, Any] = dict(ck.info)
    tc = info["train_config"]
    wdir = Path(weights_dir) if weights_dir else default_weights_dir()
    splits = load_domain_pairs(tc["domain"], tc["n_train"], tc["n_val"], tc["n_test"], tc["seed"], progress=False)
    tests = {"val": splits.val}
    if tc["domain"] == "houseexpo":
        tests |= {"test (100, paper protocol)": _subset(splits.test, 100), f"test ({len(splits.test)})": splits.test}
    else:
        tests |= {f"test ({len(splits.test)})": splits.test}
    rows, metrics = [], {}
    for label, ps in tests.items():
        pred = complete(gen, ps.partial)
        for positive in ("free", "occupied"):
            s = score_maps(pred, ps.target, ps.partial, positive)
            rows.append(_line(f"{label}, {positive}", s))
            metrics[f"{label}, {positive}"] = s.as_dict()
    few = _subset(splits.test, 100)
    samp = sample_completions(gen, few.partial, 8, torch.Generator().manual_seed(0))
    div = float(np.mean(samp.diversity))
    sampled = score_samples(samp.samples, few.partial, few.target)
    info |= {"test_metrics": metrics, "sample_diversity_k8": div, "sample_scores_k8": sampled.as_dict(),
             "reproduce": command, "source_run": str(run_dir)}
    last_json = Path(run_dir) / "last.json"
    last_info = json.loads(last_json.read_text())["info"] if last_json.is_file() else info
    total_s = float(last_info["wall_time_s"])
    info |= {"run_wall_time_s": total_s, "history": last_info.get("history", info.get("history", []))}
    save_checkpoint(wdir / name, ck.arch, gen, disc, info)
    is_sampler = isinstance(ck.generator_config, SamplerConfig)
    nll = (lambda h: f" {h.get('val_nll', float('nan')):.4f} |") if is_sampler else (lambda h: "")
    hist = "\n".join(
        f"| {int(h['epoch']) + 1} | {h['train_loss']:.4f} | {h['val_f']:.4f} | {h['val_miou']:.4f} |{nll(h)} "
        f"{h['wall_time_s']:.0f} |"
        for h in info.get("history", [])
    )
    selection = "the lowest validation cross-entropy" if is_sampler else "the best (F + mIoU) / 2"
    head = "| epoch | train loss | val F (free) | val mIoU unknown |" + (" val cross-entropy |" if is_sampler else "")
    head += " wall s |\n|---|---|---|---|" + ("---|" if is_sampler else "") + "---|"
    arch_line = (
        "masked sampler `SamplerConfig("
        + ", ".join(f"{k}={v}" for k, v in ck.generator_config.as_dict().items() if k != "unet")
        + f")` around the U-net `UNetConfig({', '.join(f'{k}={v}' for k, v in ck.generator_config.unet.as_dict().items())})`"
        if isinstance(ck.generator_config, SamplerConfig)
        else f"generator `UNetConfig({', '.join(f'{k}={v}' for k, v in ck.generator_config.as_dict().items())})`"
    )
    size_mb = checkpoint_paths(wdir / name)[0].stat().st_size / 1e6
    card = f"""# {name}: {ck.arch} map completion network trained on {tc["domain"]}

- Architecture: `{ck.arch}`; {arch_line},
  spectral normalization on every conv; {sum(p.numel() for p in gen.parameters()):,} generator parameters; file {size_mb:.1f} MB.
- Data: {tc["domain"]} pairs (m_t, m_T), 64×64; split {info.get("n_train_pairs")} train / {len(splits.val)} val / {len(splits.test)} test
  (`n_train={tc["n_train"]}, n_val={tc["n_val"]}, n_test={tc["n_test"]}`, seed {tc["seed"]}); augmentation: {_augment(tc)}.
- Training: seed {tc["seed"]}, {int(info["epoch"]) + 1} epochs (best checkpoint; {info.get("steps")} steps of batch {tc["batch_size"]}),
  lr {tc["lr"]} (Adam beta1 {tc.get("beta1", 0.5)}), unknown-cell weight {tc["unknown_weight"]}, free-target weight
  {tc.get("free_weight", 1.0)}, EMA of the weights: {tc.get("ema_decay", 0.0) or "off"} (the EMA is what is validated and shipped){", recon weight " + str(tc["recon_weight"]) + ", GAN weight " + str(tc["gan_weight"]) if ck.arch == "pix2pix" else ""},
  time budget {tc["max_minutes"]} min, initialised from: {tc["init_from"] or "scratch"}.
- Wall time (data loading + training + per-epoch validation, {conditions}): best checkpoint
  reached after {info["wall_time_s"]:.0f} s ({info["wall_time_s"] / 60:.1f} min), whole run {total_s:.0f} s ({total_s / 60:.1f} min){_init_time(tc, float(info["wall_time_s"]))}.
- Samples (K = 8, 100 test maps, on the cells unknown in m_t): {div:.4f} of the cells differ between two samples;
  {sampled.summary()}.{_pair_build(splits.manifest)}

## Reproduce

With ``--max-minutes`` the learning-rate decay follows the time budget whenever time runs out faster than steps,
so under another CPU load the run is close to, not bit-identical with, this one (same data, seed and order).

```
{command}
python -m mcnkit.completion.card RUN_DIR {name} --command "<the command above>"
```

## Validation per epoch (whole run; the shipped checkpoint is {selection})

{head}
{hist}

## Metrics (deterministic completion; per-map mean ± 95 % CI)

| set, positive class | n | Acc | Prec | Rec | F | mIoU unknown |
|---|---|---|---|---|---|---|
{chr(10).join(rows)}
"""
    path = wdir / f"{name}.md"
    path.write_text(card)
    (wdir / f"{name}.metrics.json").write_text(json.dumps(metrics, indent=2))
    return path


def main() -> int:
    """Command-line entry point."""
    ap = argparse.ArgumentParser(description="copy a run's best checkpoint into the package with a model card")
    ap.add_argument("run_dir")
    ap.add_argument("name")
    ap.add_argument("--command", required=True, help="the command that reproduces the run")
    ap.add_argument("--weights-dir", default=None)
    ap.add_argument("--conditions", default="2 CPU cores", help="the machine the run had, for the card's wall time")
    args = ap.parse_args()
    print(ship(args.run_dir, args.name, args.command, args.weights_dir, args.conditions))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
