"""Experiment tables as CSV: a row is a frozen dataclass, a table a list of rows of one type.

A CSV column is a field of the row; a field that is itself a dataclass (e.g. the
:class:`~mcnkit.completion.scores.Scores` of a row) is flattened into its own fields.  The columns are the
flattened fields in field order unless a table names its own order (the same set of names, checked).  Floats are
written with 6 decimals (``nan`` for any non-finite value), everything else as ``str``.  :func:`read_rows` reads
such a CSV back into the dataclass, :func:`read_csv` into plain dicts.
"""

from __future__ import annotations

import csv
import dataclasses
import math
import typing
from collections.abc import Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any, TypeVar

__all__ = ["columns", "flatten", "read_csv", "read_rows", "write_rows"]

R = TypeVar("R")


def _fields(row_type: type) -> Iterator[tuple[str, type]]:
    """(name, type) of each field, nested dataclasses flattened."""
    hints = typing.get_type_hints(row_type)
    for f in dataclasses.fields(row_type):
        t = hints[f.name]
        if dataclasses.is_dataclass(t):
            yield from _fields(t)  # type: ignore[arg-type]
        else:
            yield f.name, t


def columns(row_type: type) -> list[str]:
    """The CSV columns of ``row_type``: its fields, nested dataclasses flattened, in field order."""
    names = [name for name, _ in _fields(row_type)]
    if len(set(names)) != len(names):
        raise TypeError(f"{row_type.__name__}: a column name repeats in {names}")
    return names


def flatten(row: Any) -> dict[str, Any]:
    """A row's fields as one flat dict (nested dataclasses flattened)."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(row):
        value = getattr(row, f.name)
        if dataclasses.is_dataclass(value) and not isinstance(value, type):
            out.update(flatten(value))
        else:
            out[f.name] = value
    return out


def _cell(value: object) -> object:
    if isinstance(value, float):
        return f"{value:.6f}" if math.isfinite(value) else "nan"
    return value


def write_rows(path: str | Path, rows: Sequence[Any], row_type: type, order: Sequence[str] | None = None) -> None:
    """Writes ``rows`` (instances of ``row_type``) as CSV; ``order``: the column order, the same names as
    :func:`columns` (default: that order)."""
    names = columns(row_type)
    if order is not None:
        if sorted(order) != sorted(names):
            raise ValueError(f"{row_type.__name__}: column order {list(order)} does not name the fields {names}")
        names = list(order)
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=names)
        w.writeheader()
        for r in rows:
            if not isinstance(r, row_type):
                raise TypeError(f"a {type(r).__name__} in a table of {row_type.__name__}")
            w.writerow({k: _cell(v) for k, v in flatten(r).items()})


def _build(row_type: type[R], values: dict[str, str]) -> R:
    hints = typing.get_type_hints(row_type)
    kwargs: dict[str, Any] = {}
    for f in dataclasses.fields(row_type):  # type: ignore[arg-type]
        t = hints[f.name]
        if dataclasses.is_dataclass(t):
            kwargs[f.name] = _build(t, values)  # type: ignore[arg-type]
        elif t is float:
            kwargs[f.name] = float(values[f.name])
        elif t is int:
            kwargs[f.name] = int(values[f.name])
        elif t is str:
            kwargs[f.name] = values[f.name]
        else:
            raise TypeError(f"{row_type.__name__}.{f.name}: no CSV reading for {t}")
    return row_type(**kwargs)


def read_rows(path: str | Path, row_type: type[R]) -> list[R]:
    """Reads a CSV written by :func:`write_rows` back into ``row_type`` rows; a missing column is an error."""
    with open(path, newline="") as fh:
        reader = csv.DictReader(fh)
        missing = set(columns(row_type)) - set(reader.fieldnames or ())
        if missing:
            raise ValueError(f"{path}: not a table of {row_type.__name__} (no column {', '.join(sorted(missing))})")
        return [_build(row_type, r) for r in reader]


def read_csv(path: str | Path, text_columns: Iterable[str]) -> list[dict[str, Any]]:
    """Reads a CSV written by :func:`write_rows` as dicts: the ``text_columns`` as strings, the rest as floats."""
    text = set(text_columns)
    with open(path, newline="") as fh:
        return [{k: v if k in text else float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
