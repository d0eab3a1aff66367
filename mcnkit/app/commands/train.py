"""``mcnkit train``: the argparse subparser for ``mcnkit/app/main.py``.

Each command is a function ``(argparse.Namespace) -> exit code``; bad input ends with one line on stderr and
exit code 2.  ``python -m mcnkit.app.commands.train train ...`` runs the same commands without the main CLI.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from mcnkit.app.exits import fail
from mcnkit.app.options import add_options, from_args
from mcnkit.completion.registry import DOMAINS

__all__ = ["add_train_parser", "cmd_train", "main"]


_FLAGS = {"out_dir": "--out", "ema_decay": "--ema", "cache_dir": "--cache", "augment": "--no-augment",
          "augment_transpose": "--flips-only", "progress": "--no-progress"}
"""TrainConfig fields whose flag is not their name (the last three turn the field off)."""

_HELP = {
    "model": "unet: the generator alone (L2 loss); pix2pix: the same generator with a patch discriminator; sampler: "
             "a masked sampler that draws whole maps round by round",
    "domain": "houseexpo: the paper's pairs (one 180°, 2 m scan); houseexpo-explore: m_t after 1-12 scans of a "
              "360°, 8 m lidar (what MCN-SLAM completes during a run); procedural: HOME'S-style masks",
    "out_dir": "run directory (best.* and last.* checkpoints)",
    "n_train": "training pairs", "n_val": "validation pairs, scored after each epoch",
    "n_test": "test pairs built with the split (part of the cache key)",
    "epochs": "passes over the training pairs", "batch_size": "pairs per optimiser step",
    "lr": "Adam learning rate of the generator",
    "lr_discriminator": "pix2pix: Adam learning rate of the discriminator",
    "beta1": "Adam beta1 of the generator (pix2pix: 0.5)",
    "seed": "seed of the pairs, the weights and the batches",
    "unknown_weight": "L2 weight on cells unknown in m_t", "recon_weight": "pix2pix: weight of the L2 term",
    "gan_weight": "pix2pix: weight of the adversarial term", "augment": "no flips / rot90",
    "augment_transpose": "augment by flips only, no transposes (HouseExpo)",
    "base_channels": "channels of the first U-net level", "max_channels": "channels of the deeper levels at most",
    "depth": "U-net levels; the map side must divide by 2^depth",
    "dropout": "dropout probability, kept on when sampling completions",
    "dropout_levels": "innermost decoder levels that carry dropout",
    "free_weight": "L2 weight factor on cells whose target is free",
    "ema_decay": "EMA decay of the generator weights (0: off), e.g. 0.999",
    "max_minutes": "stop after this wall time (ends the epoch)", "max_steps": "stop after this many optimiser steps",
    "init_from": "initialise the generator from this checkpoint", "resume": "continue from OUT/last",
    "device": "auto (CUDA when present), cpu, cuda", "threads": "torch CPU threads",
    "houseexpo": "HouseExpo json.tar.gz (default: installed, then ../shared/data)",
    "cache_dir": "pair cache directory (default: <data>/cache/houseexpo-N)", "progress": "no progress bar",
}
"""Help of the TrainConfig fields that carry no docstring, and of the renamed flags that turn a field off."""


def cmd_train(args: argparse.Namespace) -> int:
    """``mcnkit train --model unet|pix2pix --out DIR ...`` (torchrun-aware)."""
    from mcnkit.completion.checkpoint import CheckpointError
    from mcnkit.completion.train import TrainConfig, distributed_train

    try:
        res = distributed_train(from_args(TrainConfig, args, flags=_FLAGS))
    except (CheckpointError, ValueError) as err:
        return fail("train", err)
    except (FileNotFoundError, PermissionError) as err:
        return fail("train", f"{err.filename}: {err.strerror}")
    if res.best_path is not None:
        print(
            f"best: {res.best_path} val F {res.best_val_f:.4f} mIoU {res.best_val_miou:.4f} "
            f"epochs {res.epochs_done} wall {res.wall_time_s:.0f} s"
        )
    return 0


def add_train_parser(subparsers: argparse._SubParsersAction) -> None:
    """Adds ``train``: a flag for every :class:`~mcnkit.completion.train.TrainConfig` field."""
    from mcnkit.completion.train import TrainConfig

    p = subparsers.add_parser("train", help="train a map completion network (U-net or pix2pix)")
    add_options(p, TrainConfig, flags=_FLAGS, choices={"domain": DOMAINS}, required=("out_dir",), help=_HELP)
    p.set_defaults(func=cmd_train)


def main(argv: Sequence[str] | None = None) -> int:
    """Runs ``train`` standalone (``python -m mcnkit.app.commands.train``)."""
    parser = argparse.ArgumentParser(prog="mcnkit")
    sub = parser.add_subparsers(dest="command", required=True)
    add_train_parser(sub)
    args = parser.parse_args(argv)
    return int(args.func(args))


if __name__ == "__main__":
    sys.exit(main())
