"""The ``mcnkit`` command: one subcommand per job, each implemented next to the code it drives.

Every subcommand is a function ``(argparse.Namespace) -> exit code``.  Bad input ends with one line on
stderr naming the file and the problem, and exit code 2; Ctrl-C ends with exit code 130.
"""

from __future__ import annotations

import argparse
import importlib
import sys
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING, TextIO

from mcnkit import __version__

if TYPE_CHECKING:
    from mcnkit.drive import Signals

__all__ = ["EXIT_BAD_INPUT", "fail", "main"]

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


def fail(command: str, message: object) -> int:
    """Reports bad input the way every subcommand does: one line on stderr; returns the exit code (2)."""
    print(f"mcnkit {command}: error: {message}", file=sys.stderr)
    return EXIT_BAD_INPUT


def _show_warning(
    message: Warning | str, category: type[Warning], filename: str, lineno: int,
    file: TextIO | None = None, line: str | None = None,
) -> None:
    print(f"warning: {message}", file=sys.stderr)


# name -> (module, function adding its subparser).  Only the module of the command being run is imported, so
# `mcnkit slam` does not pay for rerun, torch or the dataset tools (time and memory).
COMMANDS: dict[str, tuple[str, str]] = {
    "demo": ("mcnkit.demo", "add_demo_parser"),
    "info": ("mcnkit.io.cli", "add_info_parser"),
    "convert": ("mcnkit.io.cli", "add_convert_parser"),
    "slam": ("mcnkit.slam.cli", "add_slam_parser"),
    "run": ("mcnkit.run", "add_run_parser"),
    "eval": ("mcnkit.slam.cli", "add_eval_parser"),
    "simulate": ("mcnkit.datasets.cli", "add_simulate_parser"),
    "data": ("mcnkit.datasets.cli", "add_data_parser"),
    "train": ("mcnkit.completion.cli", "add_train_parser"),
    "experiment": ("mcnkit.experiments.cli", "add_experiment_parser"),
}


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """The argument parser with every subcommand (or just ``only``)."""
    parser = argparse.ArgumentParser(
        prog="mcnkit",
        description="Map completion network SLAM: read robot logs, run grid FastSLAM with map completion, "
        "record every step to Rerun, train and evaluate completion networks.",
        epilog="Run 'mcnkit COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"mcnkit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module, adder) in COMMANDS.items():
        if only is None or name == only:
            getattr(importlib.import_module(module), adder)(sub)
    return parser


def _interrupted(command: str | None, signum: int) -> int:
    import signal

    print(f"mcnkit {command or ''}: interrupted by {signal.Signals(signum).name}".replace(" :", ":"), file=sys.stderr)
    return 128 + signum


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``mcnkit`` console script.

    SIGINT and SIGTERM end the command with one line on stderr and exit code 130 / 143; a command that writes
    results (``slam``, ``run``, ``demo``) first finishes the frame at hand and writes what it has (see
    :mod:`mcnkit.drive`).
    """
    import signal
    import threading

    from mcnkit.drive import SIGNALS

    with SIGNALS.installed(threading.current_thread() is threading.main_thread()):
        return _main(argv, SIGNALS, signal.SIGINT)


def _main(argv: Sequence[str] | None, signals: Signals, sigint: int) -> int:
    warnings.showwarning = _show_warning
    words = list(sys.argv[1:] if argv is None else argv)
    command = next((w for w in words if not w.startswith("-")), None)
    try:
        args = build_parser(command if command in COMMANDS else None).parse_args(words)
        from mcnkit.io.errors import LogError
        from mcnkit.outputs import OutputError

        try:
            code = int(args.func(args))
        except (LogError, OutputError) as err:
            code = fail(args.command, err)
        except (FileNotFoundError, IsADirectoryError, PermissionError) as err:
            code = fail(args.command, f"{err.filename}: {err.strerror}")
    except KeyboardInterrupt as err:
        return _interrupted(command, getattr(err, "signum", sigint))
    if signals.received is not None:
        return _interrupted(command, signals.received)
    return code


if __name__ == "__main__":
    sys.exit(main())
