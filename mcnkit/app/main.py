"""The ``mcnkit`` command: one subcommand per job, each implemented next to the code it drives.

Every subcommand is a function ``(argparse.Namespace) -> exit code``.  Bad input ends with one line on
stderr naming the file and the problem, and exit code 2; SIGINT (Ctrl-C) and SIGTERM end with one line and exit
code 130 / 143.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, TextIO

from mcnkit import __version__
from mcnkit.app.exits import fail

if TYPE_CHECKING:
    from mcnkit.app.drive import Signals

__all__ = ["COMMANDS", "build_parser", "main"]

def _show_warning(
    message: Warning | str, category: type[Warning], filename: str, lineno: int,
    file: TextIO | None = None, line: str | None = None,
) -> None:
    print(f"warning: {message}", file=sys.stderr)


# name -> (module, function adding its subparser, one-line summary for `mcnkit --help`).  Only the module of the
# command being run is imported, and these modules import torch, rerun, numba and the readers inside the command
# functions, so that `mcnkit --help` and `mcnkit COMMAND --help` print at once.
COMMANDS: dict[str, tuple[str, str, str]] = {
    "demo": ("mcnkit.app.commands.demo", "add_demo_parser",
             "simulate an apartment, run MCN-SLAM on its log, record it for Rerun (no dataset)"),
    "info": ("mcnkit.app.commands.info", "add_info_parser", "show what a robot log holds"),
    "convert": ("mcnkit.app.commands.convert", "add_convert_parser", "rewrite a log as ROS1 bag, ROS2 bag (sqlite3/mcap) or MCAP"),
    "slam": ("mcnkit.app.commands.slam", "add_slam_parser", "run grid FastSLAM (gmapping-class) on a robot log"),
    "run": ("mcnkit.app.commands.run", "add_run_parser",
            "MCN-SLAM on a robot log: SLAM + sampled map completions, recorded to Rerun"),
    "eval": ("mcnkit.app.commands.eval", "add_eval_parser",
             "score a TUM trajectory (relations error, ATE/RPE), or write a log's ground truth as TUM"),
    "simulate": ("mcnkit.app.commands.simulate", "add_simulate_parser",
                 "simulate a robot with a lidar on a floor plan and write a log"),
    "explore": ("mcnkit.app.commands.explore", "add_explore_parser",
                "a simulated robot explores a floor plan on its own (frontier or mcn planner)"),
    "data": ("mcnkit.app.commands.data", "add_data_parser", "install datasets, build training pairs, draw example pairs"),
    "train": ("mcnkit.app.commands.train", "add_train_parser",
              "train a map completion network (U-net, pix2pix or masked sampler)"),
    "experiment": ("mcnkit.app.commands.experiment", "add_experiment_parser",
                   "run one of the paper's experiments (exp1, exp2, exp3)"),
}


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The argument parser: ``only``'s full subparser (its module imported), the others as one-line entries."""
    parser = argparse.ArgumentParser(
        prog="mcnkit",
        description="Map completion network SLAM: read robot logs, run grid FastSLAM with map completion, "
        "record every step to Rerun, train and evaluate completion networks.",
        epilog="Run 'mcnkit COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"mcnkit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module, adder, summary) in COMMANDS.items():
        if name == only:
            getattr(importlib.import_module(module), adder)(sub)
        else:
            sub.add_parser(name, help=summary)
    return parser


def _interrupted(name: str | None, signum: int) -> int:
    import signal

    print(f"mcnkit {name}: interrupted by {signal.Signals(signum).name}" if name else
          f"mcnkit: interrupted by {signal.Signals(signum).name}", file=sys.stderr)
    return 128 + signum


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``mcnkit`` console script.

    SIGINT and SIGTERM end the command with one line on stderr and exit code 130 / 143; a command that writes
    results (``slam``, ``run``, ``demo``) first finishes the frame at hand and writes what it has (see
    :mod:`mcnkit.app.drive`).
    """
    import signal
    import threading

    from mcnkit.app.drive import SIGNALS
    from mcnkit.app.heap import return_big_frees_to_os

    return_big_frees_to_os()  # long runs: peak memory = what they hold, not what the heap kept (see mcnkit.app.heap)
    with SIGNALS.installed(threading.current_thread() is threading.main_thread()):
        return _main(argv, SIGNALS, signal.SIGINT)


def _main(argv: Sequence[str] | None, signals: Signals, sigint: int) -> int:
    warnings.showwarning = _show_warning
    words = list(sys.argv[1:] if argv is None else argv)
    command = next((w for w in words if not w.startswith("-")), None)
    name = command if command in COMMANDS else None
    try:
        try:
            parser = build_parser(name)  # a command's flags may come from a module of an optional extra
        except ModuleNotFoundError as err:
            return _missing_extra(name or "", err)
        args = parser.parse_args(words)
        from mcnkit.app.outputs import OutputError
        from mcnkit.completion.registry import CheckpointError  # after parsing: --help needs none of these
        from mcnkit.io.errors import LogError
        from mcnkit.slam.limits import MapLimitError

        name = " ".join(str(w) for w in (args.command, *(getattr(args, k, None) for k in _SUBCOMMAND_KEYS)) if w)
        try:
            code = int(args.func(args))
        except (LogError, CheckpointError, OutputError, MapLimitError) as err:
            code = fail(name, err)
        except (FileNotFoundError, IsADirectoryError, PermissionError, FileExistsError) as err:
            code = fail(name, f"{err.filename}: {err.strerror}")
        except ModuleNotFoundError as err:
            code = _missing_extra(name, err)
    except KeyboardInterrupt as err:  # a signal outside a drive (mcnkit.app.drive.Interrupted), or Ctrl-C elsewhere
        return _interrupted(name, getattr(err, "signum", sigint))
    except Exception:  # raised while the signal's exception unwound compiled code (numba's SystemError): the signal
        if signals.received is not None:
            return _interrupted(name, signals.received)
        raise
    if signals.received is not None:
        return _interrupted(name, signals.received)
    return code


def _missing_extra(name: str, err: ModuleNotFoundError) -> int:
    """One line naming the extra that installs the missing module (re-raised when no extra does)."""
    extra = EXTRAS.get((err.name or "").split(".")[0])
    if extra is None:
        raise err
    return fail(name, f"needs the optional '{extra}' dependencies ({err.name} is not installed): "
                      f"pip install 'mcnkit[{extra}]'")


EXTRAS = {"torch": "completion", "safetensors": "completion", "skimage": "completion", "matplotlib": "completion",
          "ipywidgets": "notebooks", "jupyterlab": "notebooks", "rerun_notebook": "notebooks"}
"""Top-level modules of the optional dependencies and the extra (pyproject.toml) that installs each."""


_SUBCOMMAND_KEYS = ("eval_command", "data_command", "experiment")
"""Namespace keys of the second word of two-word commands (``eval ate``, ``data pairs``, ``experiment exp2``)."""


if __name__ == "__main__":
    sys.exit(main())
