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
from mcnkit.completion.train_config import TrainConfig

__all__ = ["add_train_parser", "cmd_train", "main"]


_FLAGS = {"out_dir": "--out", "ema_decay": "--ema", "cache_dir": "--cache", "augment": "--no-augment",
          "augment_transpose": "--flips-only", "progress": "--no-progress"}
"""TrainConfig fields whose flag is not their name (the last three turn the field off)."""

_HELP = {"augment": "no flips / transposes", "augment_transpose": "augment by flips only, no transposes (HouseExpo)",
         "progress": "no progress bar"}
"""Help of the flags that turn a field off (the other flags take their field's docstring)."""


def cmd_train(args: argparse.Namespace) -> int:
    """``mcnkit train --model unet|pix2pix|sampler --out DIR ...`` (torchrun-aware)."""
    from mcnkit.completion.checkpoint import CheckpointError
    from mcnkit.completion.train import distributed_train

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
    """Adds ``train``: a flag for every :class:`~mcnkit.completion.train_config.TrainConfig` field."""
    p = subparsers.add_parser("train", help="train a map completion network (U-net, pix2pix or masked sampler)")
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
