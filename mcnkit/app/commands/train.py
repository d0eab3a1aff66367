"""``mcnkit train``: the argparse subparser for ``mcnkit/app/main.py``.

Each command is a function ``(argparse.Namespace) -> exit code``; bad input ends with one line on stderr and
exit code 2.  ``python -m mcnkit.app.commands.train train ...`` runs the same commands without the main CLI.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from mcnkit.app.exits import fail
from mcnkit.completion.registry import DOMAINS

__all__ = ["add_train_parser", "cmd_train", "main"]


def cmd_train(args: argparse.Namespace) -> int:
    """``mcnkit train --model unet|pix2pix --out DIR ...`` (torchrun-aware)."""
    from mcnkit.completion.checkpoint import CheckpointError
    from mcnkit.completion.train import TrainConfig, distributed_train

    try:
        cfg = TrainConfig(
            model=args.model,
            domain=args.domain,
            out_dir=args.out,
            n_train=args.n_train,
            n_val=args.n_val,
            n_test=args.n_test,
            epochs=args.epochs,
            batch_size=args.batch_size,
            lr=args.lr,
            lr_discriminator=args.lr_discriminator,
            beta1=args.beta1,
            seed=args.seed,
            unknown_weight=args.unknown_weight,
            recon_weight=args.recon_weight,
            gan_weight=args.gan_weight,
            augment=not args.no_augment,
            augment_transpose=not args.flips_only,
            base_channels=args.base_channels,
            max_channels=args.max_channels,
            depth=args.depth,
            dropout=args.dropout,
            dropout_levels=args.dropout_levels,
            free_weight=args.free_weight,
            ema_decay=args.ema,
            max_minutes=args.max_minutes,
            max_steps=args.max_steps,
            init_from=args.init_from,
            resume=args.resume,
            device=args.device,
            threads=args.threads,
            progress=not args.no_progress,
            houseexpo=args.houseexpo,
            cache_dir=args.cache,
        )
        res = distributed_train(cfg)
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
    """Adds ``train``."""
    p = subparsers.add_parser("train", help="train a map completion network (U-net or pix2pix)")
    p.add_argument("--model", choices=["unet", "pix2pix"], default="unet",
                   help="unet: the generator alone (L2 loss); pix2pix: the same generator with a patch "
                        "discriminator (default unet)")
    p.add_argument("--domain", choices=DOMAINS, default="houseexpo",
                   help="houseexpo: the paper's pairs (one 180°, 2 m scan); houseexpo-explore: m_t after 1-12 scans "
                        "of a 360°, 8 m lidar (what MCN-SLAM completes during a run); procedural: HOME'S-style masks")
    p.add_argument("--out", required=True, help="run directory (best.* and last.* checkpoints)")
    p.add_argument("--n-train", type=int, default=5000, help="training pairs (default 5000)")
    p.add_argument("--n-val", type=int, default=200, help="validation pairs, scored after each epoch (default 200)")
    p.add_argument("--n-test", type=int, default=1000, help="test pairs built with the split (part of the cache key; default 1000)")
    p.add_argument("--epochs", type=int, default=10, help="passes over the training pairs (default 10)")
    p.add_argument("--batch-size", type=int, default=32, help="pairs per optimiser step (default 32)")
    p.add_argument("--lr", type=float, default=2e-3, help="Adam learning rate of the generator (default 2e-3)")
    p.add_argument("--lr-discriminator", type=float, default=2e-4,
                   help="pix2pix: Adam learning rate of the discriminator (default 2e-4)")
    p.add_argument("--beta1", type=float, default=0.5, help="Adam beta1 of the generator (pix2pix: 0.5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the pairs, the weights and the batches (default 0)")
    p.add_argument("--unknown-weight", type=float, default=2.0, help="L2 weight on cells unknown in m_t")
    p.add_argument("--recon-weight", type=float, default=100.0, help="pix2pix: weight of the L2 term")
    p.add_argument("--gan-weight", type=float, default=1.0, help="pix2pix: weight of the adversarial term")
    p.add_argument("--no-augment", action="store_true", help="no flips / rot90")
    p.add_argument("--flips-only", action="store_true", help="augment by flips only, no transposes (HouseExpo)")
    p.add_argument("--base-channels", type=int, default=16, help="channels of the first U-net level (default 16)")
    p.add_argument("--max-channels", type=int, default=128, help="channels of the deeper levels at most (default 128)")
    p.add_argument("--depth", type=int, default=4, help="U-net levels; the map side must divide by 2^depth (default 4)")
    p.add_argument("--dropout", type=float, default=0.2,
                   help="dropout probability, kept on when sampling completions (default 0.2)")
    p.add_argument("--dropout-levels", type=int, default=2, help="innermost decoder levels that carry dropout")
    p.add_argument("--free-weight", type=float, default=1.0, help="L2 weight factor on cells whose target is free")
    p.add_argument("--ema", type=float, default=0.0, help="EMA decay of the generator weights (0: off), e.g. 0.999")
    p.add_argument("--max-minutes", type=float, default=None, help="stop after this wall time (ends the epoch)")
    p.add_argument("--max-steps", type=int, default=None, help="stop after this many optimiser steps")
    p.add_argument("--init-from", default=None, help="initialise the generator from this checkpoint")
    p.add_argument("--resume", action="store_true", help="continue from OUT/last")
    p.add_argument("--device", default="auto", help="auto (CUDA when present), cpu, cuda")
    p.add_argument("--threads", type=int, default=2, help="torch CPU threads")
    p.add_argument("--houseexpo", default=None, help="json.tar.gz (default: installed, then ../shared/data)")
    p.add_argument("--cache", default=None, help="pair cache directory (default: <data>/cache/houseexpo-N)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
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
