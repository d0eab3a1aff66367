"""``mcnkit experiment exp1|exp2|exp3``: the paper's experiments, each with its own options.

* ``exp1``: map completion from one scan on HouseExpo test maps (:mod:`.exp1`);
* ``exp2``: MCN-SLAM on simulated HouseExpo houses, at the first filter update and at T−5 (:mod:`.exp2`);
* ``exp3``: the real labs, MIT CSAIL and the Intel lab, along the run (:mod:`.exp3`).

Each writes a CSV, a Markdown report (also printed) and PNG figures into ``--out``.
"""

from __future__ import annotations

import argparse
import importlib
from collections.abc import Callable
from typing import Any

__all__ = ["add_experiment_parser"]


def _runner(run: str, config_from_args: Callable[[argparse.Namespace], Any]) -> Callable[[argparse.Namespace], int]:
    """The command function of one experiment: build its config, run it (``run``: ``module:function``, imported
    only then), print its Markdown report."""

    def command(args: argparse.Namespace) -> int:
        from mcnkit.app.exits import fail
        from mcnkit.completion.registry import CheckpointError
        from mcnkit.experiments.houses import RunCacheError

        module, name = run.split(":")
        try:
            config = config_from_args(args)
            print(getattr(importlib.import_module(module), name)(config))
        except (CheckpointError, RunCacheError, ValueError) as err:
            return fail(f"experiment {args.experiment}", err)
        return 0

    return command


_DESCRIPTION = """The paper's experiments, each with its own options ('mcnkit experiment NAME --help'):

  exp1  map completion from one scan, on HouseExpo test maps
  exp2  MCN-SLAM on simulated HouseExpo houses, at the first filter update and at T-5
  exp3  the real labs, MIT CSAIL and the Intel lab, along the run

Each writes a CSV, a Markdown report (also printed) and PNG figures into --out."""


def add_experiment_parser(subparsers: Any) -> None:
    """Adds ``experiment`` with one sub-command per experiment."""
    from mcnkit.experiments.options import (
        add_exp1_arguments,
        add_exp2_arguments,
        add_exp3_arguments,
        exp1_config_from_args,
        exp2_config_from_args,
        exp3_config_from_args,
    )

    p = subparsers.add_parser("experiment", help="run one of the paper's experiments (exp1, exp2, exp3)",
                              description=_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="experiment", metavar="NAME", required=True)
    e1 = sub.add_parser("exp1", help="map completion from one scan, HouseExpo test maps (paper Exp 1)")
    add_exp1_arguments(e1)
    e1.set_defaults(func=_runner("mcnkit.experiments.exp1:run_exp1", exp1_config_from_args))
    e2 = sub.add_parser("exp2", help="MCN-SLAM on simulated HouseExpo houses: iteration 1 and T-5 (paper Exp 2)")
    add_exp2_arguments(e2)
    e2.set_defaults(func=_runner("mcnkit.experiments.exp2:run_exp2", exp2_config_from_args))
    e3 = sub.add_parser("exp3", help="the real labs, MIT CSAIL and Intel, along the run (paper Exp 3)")
    add_exp3_arguments(e3)
    e3.set_defaults(func=_runner("mcnkit.experiments.exp3:run_exp3", exp3_config_from_args))
