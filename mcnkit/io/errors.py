"""The one error type every reader and writer raises, and the warning for data skipped on the way."""

from __future__ import annotations

import sqlite3
import struct
import warnings
import zlib
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import zstandard
from rosbags.serde import SerdeError
from rosbags.typesys import TypesysError

__all__ = ["DECODE_ERRORS", "PARSE_ERRORS", "LogError", "LogWarning", "as_log_error", "one_line", "warn_skipped"]

# What parsers of damaged bytes raise (struct, codecs, decompressors — lz4 raises RuntimeError —, rosbags'
# deserialisers, sqlite).  Not TypeError, AttributeError, AssertionError, MemoryError, RecursionError: those are
# bugs (or limits) in mcnkit and keep their traceback.
DECODE_ERRORS: tuple[type[BaseException], ...] = (
    ValueError, KeyError, IndexError, EOFError, OSError, RuntimeError, OverflowError, struct.error, zlib.error,
    zstandard.ZstdError, SerdeError, TypesysError, sqlite3.Error,
)

# What decoding one damaged message raises: a message failing with one of these is skipped and counted.  Programming
# errors (TypeError, AttributeError, ...) are not among them.
PARSE_ERRORS: tuple[type[BaseException], ...] = (
    ValueError, KeyError, IndexError, EOFError, OverflowError, struct.error, SerdeError,
)


_MAX_TEXT = 2000  # characters of a message kept in its one line


def one_line(text: str, limit: int = _MAX_TEXT) -> str:
    """``text`` as one line: its lines joined with ``"; "`` (libraries such as sqlite report over several lines),
    runs of blanks collapsed, cut at ``limit`` characters."""
    folded = "; ".join(" ".join(line.split()) for line in text.splitlines() if line.strip())
    return folded if len(folded) <= limit else folded[: limit - 1] + "…"


class LogError(Exception):
    """A log that cannot be read or written; ``str()`` is one line naming the file and the problem."""

    def __init__(self, path: Path | str, problem: str) -> None:
        self.path = Path(path)
        self.problem = one_line(problem) or "unreadable"
        super().__init__(f"{self.path}: {self.problem}")


class LogWarning(UserWarning):
    """Some of a log was skipped (a truncated tail, scans whose stamps went backwards, ...)."""


def warn_skipped(path: Path | str, what: str) -> None:
    """Warns, in one line naming the file, that part of it was skipped."""
    warnings.warn(f"{path}: {one_line(what)}", LogWarning, stacklevel=3)


@contextmanager
def as_log_error(path: Path | str, doing: str) -> Iterator[None]:
    """Turns whatever a parser raises on damaged bytes into a one-line :class:`LogError`."""
    try:
        yield
    except LogError:
        raise
    except DECODE_ERRORS as err:
        detail = one_line(str(err), 200)
        raise LogError(path, f"{doing}: {type(err).__name__}{': ' + detail if detail else ''}") from err
