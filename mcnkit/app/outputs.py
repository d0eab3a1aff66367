"""Outputs that never clobber inputs: checked before anything is written, written under a temporary name.

* :func:`check_outputs` refuses an output path that is an input, lies inside one (a rosbag2 folder) or contains
  one (``--out .`` beside the log), and an existing output unless ``overwrite`` is set;
* :func:`staged_folder` writes an output folder's files in a hidden ``*.partial`` folder inside it and moves each
  into place (an atomic rename) only when all were written;
* :func:`partial_path` is the temporary name of a single file (``NAME.partial``, renamed by the writer when done).

Example:
    >>> check_outputs([Path("run.mcap")], [Output(Path("run.mcap"))], overwrite=True)  # doctest: +SKIP
    OutputError: run.mcap: is the input run.mcap (choose another output)
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Output", "OutputError", "check_outputs", "partial_path", "staged_folder"]


class OutputError(ValueError):
    """An output that cannot be written; ``str()`` is one line naming the path and the problem."""

    def __init__(self, path: Path | str, problem: str) -> None:
        self.path = Path(path)
        self.problem = problem
        super().__init__(f"{self.path}: {problem}")


@dataclass(frozen=True)
class Output:
    """An output path and whether it is a folder (``--out``), a file (``--rrd``) or either (None: a converted log,
    a file or a ROS2 bag folder)."""

    path: Path
    folder: bool | None = False


def _resolved(path: Path) -> Path:
    return Path(os.path.realpath(path))


def _relation(out: Path, inp: Path) -> str | None:
    """How ``out`` would touch ``inp``: ``"is"``, ``"contains"``, ``"inside"`` or None."""
    ro, ri = _resolved(out), _resolved(inp)
    if ro == ri or (out.exists() and inp.exists() and os.path.samefile(out, inp)):
        return "is"
    if ro in ri.parents:
        return "contains"
    if ri in ro.parents:
        return "inside"
    return None


def check_outputs(inputs: Sequence[Path], outputs: Sequence[Output], *, overwrite: bool) -> None:
    """Raises :class:`OutputError` for the first output that would overwrite, contain or sit inside an input,
    that is named twice, that has the wrong kind (a file where a folder goes), or that exists (a folder: is not
    empty) while ``overwrite`` is False.  Writes nothing."""
    seen: dict[Path, Path] = {}
    for out in outputs:
        path = out.path
        for inp in inputs:
            how = _relation(path, inp)
            if how == "is":
                raise OutputError(path, f"is the input {inp} (choose another output)")
            if how == "contains":
                raise OutputError(path, f"contains the input {inp} (choose another output)")
            if how == "inside":
                raise OutputError(path, f"lies inside the input {inp} (choose another output)")
        key = _resolved(path)
        if key in seen:
            raise OutputError(path, f"is named twice as an output (also {seen[key]})")
        seen[key] = path
        if out.folder is None:
            if path.exists() and not overwrite:
                raise OutputError(path, "exists already (pass --overwrite to replace it)")
        elif out.folder:
            if path.exists() and not path.is_dir():
                raise OutputError(path, "is a file, not a folder")
            if path.is_dir() and any(path.iterdir()) and not overwrite:
                raise OutputError(path, "exists and is not empty (pass --overwrite to replace the files written there)")
        elif path.exists():
            if path.is_dir():
                raise OutputError(path, "is a folder, not a file")
            if not overwrite:
                raise OutputError(path, "exists already (pass --overwrite to replace it)")


def partial_path(path: Path) -> Path:
    """The temporary name a file is written under before it is renamed to ``path``."""
    return path.with_name(path.name + ".partial")


@contextmanager
def staged_folder(out: Path) -> Iterator[Path]:
    """Yields a hidden temporary folder inside ``out`` (created) to write the outputs into; on success each file
    is moved to ``out`` (replacing its namesake), on failure the temporary folder is removed."""
    out.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".mcnkit-", suffix=".partial", dir=out))
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    for f in sorted(tmp.iterdir()):
        os.replace(f, out / f.name)
    tmp.rmdir()
