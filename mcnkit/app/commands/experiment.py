"""``mcnkit experiment exp1|exp2|exp3``: the paper's experiments, each with its own options.

* ``exp1``: map completion from one scan on HouseExpo test maps (:mod:`.exp1`);
* ``exp2``: MCN-SLAM on simulated HouseExpo houses, at the first filter update and at T−5 (:mod:`.exp2`);
* ``exp3``: the real labs, MIT CSAIL and the Intel lab, along the run (:mod:`.exp3`).

Each writes a CSV, a Markdown report (also printed) and PNG figures into ``--out``.
"""

from __future__ import annotations

import argparse
import importlib
from typing import Any

from mcnkit.app.options import add_options, from_args

__all__ = ["add_experiment_parser", "experiment_config"]


_FLAGS = {"out_dir": "--out", "weights_dir": "--weights", "n_samples": "--samples", "cache_dir": "--cache",
          "lidar_range_m": "--range", "window_m": "--window", "progress": "--quiet"}
"""Config fields whose flag is not their name (``--quiet`` turns the progress bar off)."""

_EXPERIMENTS = {
    "exp1": ("map completion from one scan, HouseExpo test maps (paper Exp 1)", "Exp1Config", "run_exp1"),
    "exp2": ("MCN-SLAM on simulated HouseExpo houses: iteration 1 and T-5 (paper Exp 2)", "Exp2Config", "run_exp2"),
    "exp3": ("the real labs, MIT CSAIL and Intel, along the run (paper Exp 3)", "Exp3Config", "run_exp3"),
}
"""Experiment -> (summary, its config class in :mod:`mcnkit.experiments.config`, its run function)."""


def experiment_config(args: argparse.Namespace) -> Any:
    """The config of the experiment that ``args`` (parsed by the ``experiment`` subparser) names."""
    from mcnkit.experiments import config

    return from_args(getattr(config, _EXPERIMENTS[args.experiment][1]), args, flags=_FLAGS)


def _run(args: argparse.Namespace) -> int:
    """Builds the experiment's config, runs it (its module imported only then), prints its Markdown report."""
    from mcnkit.app.exits import fail
    from mcnkit.completion.registry import CheckpointError
    from mcnkit.experiments.houses import RunCacheError

    try:
        config = experiment_config(args)
        run = getattr(importlib.import_module(f"mcnkit.experiments.{args.experiment}"), _EXPERIMENTS[args.experiment][2])
        print(run(config))
    except (CheckpointError, RunCacheError, ValueError) as err:
        return fail(f"experiment {args.experiment}", err)
    return 0


_DESCRIPTION = """The paper's experiments, each with its own options ('mcnkit experiment NAME --help'):

  exp1  map completion from one scan, on HouseExpo test maps
  exp2  MCN-SLAM on simulated HouseExpo houses, at the first filter update and at T-5
  exp3  the real labs, MIT CSAIL and the Intel lab, along the run

Each writes a CSV, a Markdown report (also printed) and PNG figures into --out."""


def add_experiment_parser(subparsers: Any) -> None:
    """Adds ``experiment`` with one sub-command per experiment, a flag for every field of its config."""
    from mcnkit.experiments import config

    p = subparsers.add_parser("experiment", help="run one of the paper's experiments (exp1, exp2, exp3)",
                              description=_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="experiment", metavar="NAME", required=True)
    for name, (summary, cls, _) in _EXPERIMENTS.items():
        e = sub.add_parser(name, help=summary)
        add_options(e, getattr(config, cls), flags=_FLAGS, required=("out_dir",), help={"progress": "no progress bar"})
        e.set_defaults(func=_run)
