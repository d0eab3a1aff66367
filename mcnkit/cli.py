"""The ``mcnkit`` command: one subcommand per job, each implemented next to the code it drives.

Every subcommand is a function ``(argparse.Namespace) -> exit code``.  Bad input ends with one line on
stderr naming the file and the problem, and exit code 2; Ctrl-C ends with exit code 130.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Sequence
from typing import TextIO

from mcnkit import __version__
from mcnkit.datasets.cli import add_data_parser, add_simulate_parser
from mcnkit.demo import add_demo_parser
from mcnkit.io.cli import add_convert_parser, add_info_parser
from mcnkit.io.errors import LogError
from mcnkit.slam.cli import add_eval_parser, add_slam_parser

__all__ = ["main"]

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


def _show_warning(
    message: Warning | str, category: type[Warning], filename: str, lineno: int,
    file: TextIO | None = None, line: str | None = None,
) -> None:
    print(f"warning: {message}", file=sys.stderr)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser with every subcommand."""
    parser = argparse.ArgumentParser(
        prog="mcnkit",
        description="Map completion network SLAM: read robot logs, run grid FastSLAM with map completion, "
        "record every step to Rerun, train and evaluate completion networks.",
        epilog="Run 'mcnkit COMMAND --help' for the options of a command.",
    )
    parser.add_argument("--version", action="version", version=f"mcnkit {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for add in (add_demo_parser, add_info_parser, add_convert_parser, add_slam_parser, add_eval_parser, add_simulate_parser,
                add_data_parser):
        add(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``mcnkit`` console script."""
    warnings.showwarning = _show_warning
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except LogError as err:
        print(f"mcnkit {args.command}: error: {err}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (FileNotFoundError, IsADirectoryError, PermissionError) as err:
        print(f"mcnkit {args.command}: error: {err.filename}: {err.strerror}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"mcnkit {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
