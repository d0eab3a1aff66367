"""Run configuration: a section of settings (a dataclass, sections within it included) from its defaults, a config
file, a command's short flags and the ``--SECTION.FIELD`` flags (:mod:`mcnkit.app.options` generates them).

    p = argparse.ArgumentParser()
    add_section_flags(p, SlamConfig, "slam")            # --slam.n-particles, --slam.loops.closure/--no-…, …
    args = p.parse_args(["--slam.loops.window-m", "1.0"])
    config = resolve_section(SlamConfig, args, "slam", read_config_file(path))

Precedence: the dataclass defaults, then the file (TOML tables ``[slam]``, ``[slam.loops]``, …, or the JSON
``summary.json`` a run writes), then the short flags, then ``--SECTION.FIELD``.  Unknown keys in a file are an
error (a typo must not be ignored quietly), and a value that a section refuses is reported under the name the
user gave it: ``--particles must be > 0, got 0``, or the file and its key.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any, TypeVar

from mcnkit.app.options import flag_name, hint_of, rename_fields, type_hints

if TYPE_CHECKING:
    from mcnkit.slam.config import SlamConfig

__all__ = ["SLAM_FLAG_ALIASES", "ConfigError", "build_dataclass", "config_file", "dataclass_overrides", "read_config_file",
           "resolve_section", "resolve_seed", "resolve_slam_config"]

T = TypeVar("T")

SLAM_FLAG_ALIASES: dict[str, tuple[str, ...]] = {"odometry": ("--slam.odometry",)}
"""More spellings of the short flags that :func:`resolve_slam_config` reads (``add_options(..., aliases=...)`` of
``slam`` and ``run``): ``--slam.odometry ignore`` is ``--odometry ignore``, as the issue tracker and users write it."""


class ConfigError(ValueError):
    """A config file or value that cannot be used; ``str()`` is one line."""


class _Refused(ConfigError):
    """A section refused its values: ``str()`` names its fields; ``path`` is where the section is."""

    def __init__(self, path: str, cls: type, message: str) -> None:
        super().__init__(message)
        self.path, self.cls = path, cls


def dataclass_overrides(args: argparse.Namespace, section: str) -> dict[str, Any]:
    """The ``--SECTION.FIELD`` values given on the command line, nested as the section's tables are."""
    out: dict[str, Any] = {}
    for key, value in vars(args).items():
        if key.startswith(section + "."):
            *tables, name = key[len(section) + 1:].split(".")
            target = out
            for table in tables:
                target = target.setdefault(table, {})
            target[name] = value
    return out


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


def _coerce(cls: type, path: str, name: str, value: Any) -> Any:
    hint = hint_of(type_hints(cls)[name])
    if hint.optional and value is None:
        return None
    if hint.many is not None:
        if not isinstance(value, list | tuple):
            raise ConfigError(f"{path}{name}: expected a list, got {value!r}")
        return hint.many(_scalar(hint, path, name, v) for v in value)
    return _scalar(hint, path, name, value)


def _scalar(hint: Any, path: str, name: str, value: Any) -> Any:
    if hint.choices is not None and value not in hint.choices:
        raise ConfigError(f"{path}{name}: expected one of {', '.join(map(repr, hint.choices))}, got {value!r}")
    kind = hint.kind
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if kind is Path and isinstance(value, str):
        return Path(value)
    if not isinstance(value, kind) or (kind is int and isinstance(value, bool)):
        raise ConfigError(f"{path}{name}: expected {kind.__name__}{' or null' if hint.optional else ''}, "
                          f"got {value!r}")
    return value


def _merge(into: dict[str, Any], layer: Mapping[str, Any]) -> None:
    for key, value in layer.items():
        if isinstance(value, dict) and isinstance(into.get(key), dict):
            _merge(into[key], value)
        else:
            into[key] = value


def _build(cls: type[T], table: Mapping[str, Any], path: str) -> T:
    hints = type_hints(cls)
    names = {f.name for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    unknown = sorted(set(table) - names)
    if unknown:
        raise ConfigError(f"unknown {cls.__name__} setting{'s' * (len(unknown) > 1)}: "
                          f"{', '.join(path + u for u in unknown)}")
    values: dict[str, Any] = {}
    for key, value in table.items():
        section = hint_of(hints[key]).kind
        if dataclasses.is_dataclass(section):
            if not isinstance(value, dict):
                raise ConfigError(f"{path}{key}: expected a table of settings, got {value!r}")
            values[key] = _build(section, value, f"{path}{key}.")  # type: ignore[arg-type]
        else:
            values[key] = _coerce(cls, path, key, value)
    try:
        return cls(**values)
    except (TypeError, ValueError) as err:
        raise _Refused(path, cls, str(err)) from err


def build_dataclass(cls: type[T], *layers: Mapping[str, Any]) -> T:
    """``cls`` from its defaults updated by each layer in turn (a section's table updates that section field by
    field); unknown or mistyped keys and refused values raise :class:`ConfigError`."""
    merged: dict[str, Any] = {}
    for layer in layers:
        _merge(merged, layer)
    return _build(cls, merged, "")


def config_file(args: argparse.Namespace) -> dict[str, Any]:
    """The ``--config`` file as a dict (empty without ``--config``)."""
    path = getattr(args, "config", None)
    return read_config_file(path) if path is not None else {}


def _given(table: Mapping[str, Any], dotted: str) -> bool:
    *tables, name = dotted.split(".")
    for key in tables:
        table = table.get(key, {})
        if not isinstance(table, Mapping):
            return False
    return name in table


def _named(err: _Refused, section: str, flags: Mapping[str, Any], short: Mapping[str, str], table: Mapping[str, Any],
           where: Path | None) -> ConfigError:
    """``err`` with each field it names written as the user gave it: a short flag, ``--SECTION.FIELD``, or the
    config file's key."""
    labels: dict[str, str] = {}
    from_file = False
    for f in dataclasses.fields(err.cls):
        dotted = err.path + f.name
        if _given(flags, dotted) or (dotted not in short and not _given(table, dotted)):
            label = f"--{section}.{'.'.join(flag_name(p) for p in dotted.split('.'))}"
        elif dotted in short:
            label = short[dotted]
        else:
            label, from_file = f"{section}.{dotted}", True
        labels[f.name] = label
    message = rename_fields(str(err), labels)
    return ConfigError(f"{where}: {message}" if from_file else message)


def resolve_section(cls: type[T], args: argparse.Namespace, section: str, file: dict[str, Any],
                    short: Mapping[str, tuple[str, Any]] | None = None, *, file_keys: tuple[str, ...] = (),
                    defaults: dict[str, Any] | None = None) -> T:
    """One section of the run configuration: ``cls``'s defaults (a command's own ``defaults`` over them), then the
    file's table (the first of ``section``, ``*file_keys`` it has), then the short flags ``short`` (field ->
    (flag, value); None values: not given), then ``--SECTION.FIELD``."""
    key = next((k for k in (section, *file_keys) if k in file), None)
    table = file.get(key, {}) if key is not None else {}
    where = getattr(args, "config", None)
    if not isinstance(table, dict):
        raise ConfigError(f"{where}: '{key}' is not a table of settings")
    try:
        build_dataclass(cls, table)
    except _Refused as err:
        raise _named(err, section, {}, {}, table, where) from err
    except ConfigError as err:
        raise ConfigError(f"{where}: {err}") from err
    given = {k: value for k, (_, value) in (short or {}).items() if value is not None}
    flags = dataclass_overrides(args, section)
    try:
        return build_dataclass(cls, defaults or {}, table, given, flags)
    except _Refused as err:
        names = {k: flag for k, (flag, _) in (short or {}).items() if k in given}
        raise _named(err, section, flags, names, table, where) from err


def resolve_seed(args: argparse.Namespace, file: dict[str, Any]) -> int:
    """``--seed``, else the file's ``seed``, else 0."""
    seed = args.seed if getattr(args, "seed", None) is not None else file.get("seed", 0)
    if not isinstance(seed, int) or isinstance(seed, bool):
        raise ConfigError(f"{getattr(args, 'config', None)}: seed: expected an integer, got {seed!r}")
    return seed


def resolve_slam_config(args: argparse.Namespace, file: dict[str, Any] | None = None) -> tuple[SlamConfig, int]:
    """The filter's settings and the seed: defaults, then ``--config`` (its ``slam`` table, or the ``config`` of a
    ``summary.json``; the flat names of a file written before SlamConfig had sections are read into their
    sections), then ``--particles`` / ``--resolution`` / ``--odometry``, then ``--slam.FIELD`` flags."""
    from mcnkit.slam.config import SlamConfig, nest_flat_config

    file = config_file(args) if file is None else file
    file = {k: nest_flat_config(v) if k in ("slam", "config") and isinstance(v, dict) else v for k, v in file.items()}
    odometry = getattr(args, "odometry", None)
    short = {"n_particles": ("--particles", getattr(args, "particles", None)),
             "resolution_m": ("--resolution", getattr(args, "resolution", None)),
             "motion": ("--odometry", None if odometry is None else {"odometry": odometry})}
    config = resolve_section(SlamConfig, args, "slam", file, short, file_keys=("config",))
    return config, resolve_seed(args, file)
