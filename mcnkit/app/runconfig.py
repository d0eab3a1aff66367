"""Run configuration from the dataclasses themselves: ``--<section>.<field>`` flags generated from every field of
a config dataclass (help text = the field's docstring), and config files (TOML, or the JSON ``summary.json`` a run
writes) read into the same dataclass.

    p = argparse.ArgumentParser()
    add_dataclass_flags(p, SlamConfig, "slam")          # --slam.n-particles, --slam.loop-closure/--no-slam.…, …
    args = p.parse_args(["--slam.n-particles", "50"])
    config = build_dataclass(SlamConfig, read_config_file(path).get("slam", {}), dataclass_overrides(args, "slam"))

Precedence: the dataclass defaults, then the file, then the flags.  Unknown keys in a file are an error (a typo
must not be ignored quietly).  Chosen over a library (tyro, draccus, jsonargparse, simple-parsing): those build
the whole command line from types and import much more at start-up; here argparse stays the one parser of
``mcnkit`` and only the dataclass sections are generated.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import itertools
import json
import re
import typing
from functools import cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

if TYPE_CHECKING:
    from mcnkit.slam.config import SlamConfig

__all__ = ["ConfigError", "add_dataclass_flags", "build_dataclass", "config_file", "dataclass_overrides",
           "read_config_file", "resolve_section", "resolve_seed", "resolve_slam_config"]

T = TypeVar("T")


class ConfigError(ValueError):
    """A config file or value that cannot be used; ``str()`` is one line."""


@cache
def _field_docs(cls: type) -> dict[str, str]:
    """The docstring under each field of a dataclass (its first sentence), from the source."""
    try:
        tree = ast.parse(inspect.getsource(cls))
    except (OSError, TypeError, SyntaxError):
        return {}
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    docs: dict[str, str] = {}
    for node, after in itertools.pairwise(body):
        if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and isinstance(after, ast.Expr)
                and isinstance(after.value, ast.Constant) and isinstance(after.value.value, str)):
            text = " ".join(after.value.value.split())
            text = re.sub(r":\w+:`~?([^`]+)`", r"\1", text).replace("``", "")  # reST roles and literals, as plain text
            docs[node.target.id] = text.split(". ")[0].rstrip(".") + "."  # the first sentence
    return docs


def _flag(field: str) -> str:
    return field.rstrip("_").replace("_", "-")


def _kind(hint: Any) -> tuple[type, bool]:
    """(the scalar type, whether None is allowed) of a field's type hint (a ``Literal`` of strings: ``str``)."""
    if typing.get_origin(hint) is typing.Literal:
        return str, False
    args = [a for a in typing.get_args(hint) if a is not type(None)]
    if args:
        return _kind(args[0])[0], len(args) < len(typing.get_args(hint))
    return hint, False


def _choices(hint: Any) -> tuple[Any, ...] | None:
    """The values a ``Literal[...]`` field allows (None for other fields)."""
    if typing.get_origin(hint) is typing.Literal:
        return typing.get_args(hint)
    return None


def _parser_of(kind: type, optional: bool) -> Any:
    def parse(text: str) -> Any:
        if optional and text.lower() in ("none", "null", ""):
            return None
        return kind(text)

    parse.__name__ = kind.__name__ + (" or none" if optional else "")
    return parse


def add_dataclass_flags(parser: argparse.ArgumentParser, cls: type, section: str) -> None:
    """Adds ``--SECTION.FIELD`` for every field of the dataclass ``cls`` (underscores as dashes; booleans as
    ``--SECTION.FIELD`` / ``--no-SECTION.FIELD``), in an argument group, with the default and docstring as help.
    Values land in ``args`` as ``SECTION.FIELD`` only when given (see :func:`dataclass_overrides`)."""
    hints = typing.get_type_hints(cls)
    docs = _field_docs(cls)
    group = parser.add_argument_group(f"{section} settings ({cls.__name__}; override --config)")
    for f in dataclasses.fields(cls):
        kind, optional = _kind(hints[f.name])
        default = f.default if f.default is not dataclasses.MISSING else None
        help_text = f"{docs.get(f.name, f.name)} (default {default})".replace("%", "%%")
        flag = f"--{section}.{_flag(f.name)}"
        if kind is bool:
            group.add_argument(flag, dest=f"{section}.{f.name}", action=argparse.BooleanOptionalAction,
                               default=argparse.SUPPRESS, help=help_text)
        elif (choices := _choices(hints[f.name])) is not None:
            group.add_argument(flag, dest=f"{section}.{f.name}", choices=choices, default=argparse.SUPPRESS,
                               help=help_text)
        else:
            group.add_argument(flag, dest=f"{section}.{f.name}", type=_parser_of(kind, optional),
                               default=argparse.SUPPRESS, metavar=kind.__name__.upper(), help=help_text)


def dataclass_overrides(args: argparse.Namespace, section: str) -> dict[str, Any]:
    """The ``--SECTION.FIELD`` values given on the command line, by field name."""
    prefix = section + "."
    return {k[len(prefix):]: v for k, v in vars(args).items() if k.startswith(prefix)}


def read_config_file(path: Path) -> dict[str, Any]:
    """A config file as a dict: TOML (``.toml``) or JSON (``.json``, e.g. a run's ``summary.json``)."""
    try:
        if path.suffix == ".toml":
            import tomllib

            with open(path, "rb") as fh:
                return tomllib.load(fh)
        data = json.loads(Path(path).read_text())
    except OSError as err:
        raise ConfigError(f"{path}: {err.strerror}") from err
    except ValueError as err:  # tomllib.TOMLDecodeError and json.JSONDecodeError are ValueErrors
        raise ConfigError(f"{path}: not valid {'TOML' if path.suffix == '.toml' else 'JSON'}: {err}") from err
    if not isinstance(data, dict):
        raise ConfigError(f"{path}: expected a table of settings")
    return data


def _coerce(cls: type, name: str, value: Any) -> Any:
    hint = typing.get_type_hints(cls)[name]
    choices = _choices(hint)
    if choices is not None and value not in choices:
        raise ConfigError(f"{name}: expected one of {', '.join(map(repr, choices))}, got {value!r}")
    kind, optional = _kind(hint)
    if value is None and optional:
        return None
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise ConfigError(f"{name}: expected {kind.__name__}{' or null' if optional else ''}, got {value!r}")
    return value


def build_dataclass(cls: type[T], *layers: dict[str, Any]) -> T:
    """``cls(**defaults updated by each layer in turn)``; unknown or mistyped keys raise :class:`ConfigError`."""
    names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    values: dict[str, Any] = {}
    for layer in layers:
        unknown = sorted(set(layer) - names)
        if unknown:
            raise ConfigError(f"unknown {cls.__name__} setting{'s' * (len(unknown) > 1)}: {', '.join(unknown)}")
        values.update({k: _coerce(cls, k, v) for k, v in layer.items()})
    try:
        return cls(**values)
    except (TypeError, ValueError) as err:
        raise ConfigError(f"{cls.__name__}: {err}") from err


def config_file(args: argparse.Namespace) -> dict[str, Any]:
    """The ``--config`` file as a dict (empty without ``--config``)."""
    path = getattr(args, "config", None)
    return read_config_file(path) if path is not None else {}


def resolve_section(cls: type[T], args: argparse.Namespace, section: str, file: dict[str, Any],
                    short: dict[str, Any] | None = None, *, file_keys: tuple[str, ...] = (),
                    defaults: dict[str, Any] | None = None) -> T:
    """One section of the run configuration: ``cls``'s defaults (a command's own ``defaults`` over them), then the
    file's table (the first of ``section``, ``*file_keys`` it has), then the short flags ``short`` (None values:
    not given), then ``--SECTION.FIELD``."""
    key = next((k for k in (section, *file_keys) if k in file), None)
    table = file.get(key, {}) if key is not None else {}
    where = getattr(args, "config", None)
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: '{key}' is not a table of settings")
    try:
        build_dataclass(cls, table)
    except ConfigError as err:
        raise ConfigError(f"{where}: {err}") from err
    given = {k: v for k, v in (short or {}).items() if v is not None}
    return build_dataclass(cls, defaults or {}, table, given, dataclass_overrides(args, section))


def resolve_seed(args: argparse.Namespace, file: dict[str, Any]) -> int:
    """``--seed``, else the file's ``seed``, else 0."""
    seed = args.seed if getattr(args, "seed", None) is not None else file.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool):
        raise ConfigError(f"{getattr(args, 'config', None)}: seed: expected an integer, got {seed!r}")
    return seed


def resolve_slam_config(args: argparse.Namespace, file: dict[str, Any] | None = None) -> tuple[SlamConfig, int]:
    """The filter's settings and the seed: defaults, then ``--config`` (its ``slam`` table, or the ``config`` of a
    ``summary.json``), then ``--particles`` / ``--resolution``, then ``--slam.FIELD`` flags."""
    from mcnkit.slam.config import SlamConfig

    file = config_file(args) if file is None else file
    short = {"n_particles": getattr(args, "particles", None), "resolution_m": getattr(args, "resolution", None)}
    config = resolve_section(SlamConfig, args, "slam", file, short, file_keys=("config",))
    return config, resolve_seed(args, file)
