"""How a command ends: its exit codes, and the one line that reports bad input (``mcnkit COMMAND: FILE: problem``).

Below everything that runs a command (the dispatcher :mod:`mcnkit.app.main`, the command functions next to the code
they drive), so that any of them reports alike without importing the dispatcher.
"""

from __future__ import annotations

import sys

__all__ = ["EXIT_BAD_INPUT", "EXIT_INTERRUPTED", "fail"]

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130


def fail(command: str, message: object) -> int:
    """Reports bad input the way every subcommand does: one line ``mcnkit COMMAND: FILE: problem`` on stderr
    (the message names the file); returns the exit code (2)."""
    text = str(message).strip()
    print(f"mcnkit {command}: {text.splitlines()[0] if text else 'failed'}", file=sys.stderr)
    return EXIT_BAD_INPUT
