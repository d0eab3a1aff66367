"""Command-line options generated from typed dataclasses: the one way every ``mcnkit`` command gets its flags.

:func:`add_options` adds a flag for every field of a dataclass, with the field's docstring (its first paragraph)
as help and its type as the parser:

* ``int``, ``float``, ``str``, ``Path`` and ``X | None`` take one value (``none`` for None);
* ``Literal["a", "b"]`` takes one of its values;
* ``tuple[X, ...]`` and ``list[X]`` take one or more values;
* ``bool`` is ``--FIELD`` when it defaults to False, ``--FIELD`` / ``--no-FIELD`` when it defaults to True;
* a field whose type is itself a dataclass is a section of settings: its fields become ``--SECTION.FIELD`` flags
  (nested sections ``--SECTION.SUB.FIELD``), set in ``args`` only when given, to override the section's defaults
  and a config file (:mod:`mcnkit.app.runconfig`).

A field without a default is a required option.  The arguments of :func:`add_options` shape the rest:
``positional`` names the positional arguments, ``required`` makes options with a default required too, ``flags``
renames a flag (``{"source": "--from"}``; a renamed flag of a ``bool`` that defaults to True turns it off),
``choices`` narrows a ``str`` field, ``const`` lets a flag stand alone for the value it names (``--connect``),
and ``help`` gives the help of a field that has no docstring (or of a renamed flag that turns a field off).  The
parsed values land in ``args`` under the field names; :func:`from_args` builds the dataclass from them::

    @dataclass(frozen=True, kw_only=True)
    class InfoOptions:
        log: Path
        \"\"\"a log file or a ROS2 bag folder\"\"\"
        json: bool = False
        \"\"\"print JSON instead of text\"\"\"

    add_options(parser, InfoOptions, positional=("log",))     # LOG, --json

Chosen over a library (tyro, draccus, jsonargparse, simple-parsing): those build the whole command line from
types and import much more at start-up; here argparse stays the one parser of ``mcnkit``.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import inspect
import itertools
import re
import sys
import textwrap
import typing
from collections.abc import Mapping, Sequence
from functools import cache
from pathlib import Path
from typing import Any, TypeVar

__all__ = ["Hint", "add_options", "add_section_flags", "field_docs", "flag_name", "from_args", "hint_of",
           "plain", "rename_fields", "type_hints"]

T = TypeVar("T")


@cache
def _module_docs(module: str) -> dict[str, dict[str, str]]:
    """Class name -> its fields' docstrings, for every top-level class of ``module`` (its source parsed once)."""
    try:
        tree = ast.parse(inspect.getsource(sys.modules[module]))
    except (OSError, TypeError, SyntaxError, KeyError):
        return {}
    out: dict[str, dict[str, str]] = {}
    for cls in (node for node in tree.body if isinstance(node, ast.ClassDef)):
        docs = out.setdefault(cls.name, {})
        for node, after in itertools.pairwise(cls.body):
            if (isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and isinstance(after, ast.Expr)
                    and isinstance(after.value, ast.Constant) and isinstance(after.value.value, str)):
                docs[node.target.id] = plain(after.value.value)
    return out


@cache
def _hint(module: str, text: str) -> Any:
    return eval(text, vars(sys.modules[module]))  # an annotation of that module, as typing.get_type_hints does


def type_hints(cls: type) -> dict[str, Any]:
    """The resolved type hints of a class's fields, its bases' included (``typing.get_type_hints``, with each
    annotation string of a module evaluated once: the help of a command stays quick)."""
    hints: dict[str, Any] = {}
    for base in reversed(cls.__mro__):
        for name, hint in vars(base).get("__annotations__", {}).items():
            hints[name] = _hint(base.__module__, hint) if isinstance(hint, str) else hint
    return hints


def plain(doc: str) -> str:
    """The first paragraph of a docstring on one line, its reST roles and literals as plain text."""
    text = " ".join(inspect.cleandoc(doc).split("\n\n")[0].split())
    return re.sub(r":\w+:`~?([^`]+)`", r"\1", text).replace("``", "")


def field_docs(cls: type) -> dict[str, str]:
    """The first paragraph of the docstring under each field of a dataclass (its bases' included), as plain text."""
    docs: dict[str, str] = {}
    for base in reversed(cls.__mro__):
        if dataclasses.is_dataclass(base):
            docs.update(_module_docs(base.__module__).get(base.__qualname__, {}))
    return docs


@dataclasses.dataclass(frozen=True)
class Hint:
    """What a field's type hint asks of the parser."""

    kind: Any
    """The scalar type (``str`` for a ``Literal``), or the dataclass of a section."""
    optional: bool = False
    """None is allowed."""
    many: type | None = None
    """``tuple`` or ``list`` for a field of several values, else None."""
    choices: tuple[Any, ...] | None = None
    """The values a ``Literal`` allows."""


def hint_of(hint: Any) -> Hint:
    """The :class:`Hint` of a field's (resolved) type hint."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin is typing.Literal:
        return Hint(type(args[0]), choices=args)
    if origin in (tuple, list):
        inner = hint_of(args[0])
        return Hint(inner.kind, many=origin, choices=inner.choices)
    present = [a for a in args if a is not type(None)]
    if present:  # X | None
        inner = hint_of(present[0])
        return dataclasses.replace(inner, optional=len(present) < len(args))
    return Hint(hint)


def flag_name(field: str) -> str:
    """A field's name as it is written in a flag: underscores as dashes, a trailing underscore dropped."""
    return field.rstrip("_").replace("_", "-")


def _parser_of(kind: type, optional: bool) -> Any:
    def parse(text: str) -> Any:
        if optional and kind is not str and text.lower() in ("none", "null", ""):
            return None
        return kind(text)

    parse.__name__ = kind.__name__ + (" or none" if optional else "")  # argparse names it in its errors
    return parse


def _default_text(value: Any) -> str:
    if isinstance(value, tuple | list):
        return " ".join(str(v) for v in value) if value else "none"
    return str(value)


def _help(doc: str, default: Any, *, always: bool = False) -> str:
    """The help text: the docstring and the default (a settings flag's always, an option's when it says more than
    'not given')."""
    unset = default is None or default is False or default is dataclasses.MISSING or default == ()
    if (unset and not always) or "default" in doc.lower():
        return doc.replace("%", "%%")
    return f"{doc} (default {_default_text(default)})".replace("%", "%%")


def _default(f: dataclasses.Field[Any]) -> Any:
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return dataclasses.MISSING


def add_section_flags(parser: argparse.ArgumentParser, cls: type, section: str,
                      group: argparse._ArgumentGroup | None = None) -> None:
    """Adds ``--SECTION.FIELD`` for every field of the dataclass ``cls`` (sections within it recursively, as
    ``--SECTION.SUB.FIELD``), in one argument group per section.  A value lands in ``args`` as ``SECTION.FIELD``
    only when the flag is given."""
    hints = type_hints(cls)
    docs = field_docs(cls)
    summary = textwrap.fill(plain(cls.__doc__ or ""), 110).replace("%", "%%")
    group = parser.add_argument_group(f"--{section}.* settings ({cls.__name__}; override --config)", summary or None)
    for f in dataclasses.fields(cls):
        hint = hint_of(hints[f.name])
        if isinstance(hint.kind, type) and dataclasses.is_dataclass(hint.kind):
            add_section_flags(parser, hint.kind, f"{section}.{f.name}")
            continue
        flag, dest = f"--{section}.{flag_name(f.name)}", f"{section}.{f.name}"
        help_text = _help(docs.get(f.name, f.name), _default(f), always=True)
        if hint.kind is bool:
            group.add_argument(flag, dest=dest, action=argparse.BooleanOptionalAction, default=argparse.SUPPRESS,
                               help=help_text)
        else:
            group.add_argument(flag, dest=dest, type=_parser_of(hint.kind, hint.optional), choices=hint.choices,
                               nargs="+" if hint.many else None, default=argparse.SUPPRESS,
                               metavar=hint.kind.__name__.upper() if hint.choices is None else None, help=help_text)


def add_options(parser: argparse.ArgumentParser, cls: type, *, positional: Sequence[str] = (),
                flags: Mapping[str, str] | None = None, choices: Mapping[str, Sequence[str]] | None = None,
                const: Mapping[str, Any] | None = None, required: Sequence[str] = (),
                help: Mapping[str, str] | None = None, aliases: Mapping[str, Sequence[str]] | None = None) -> None:
    """Adds a flag (or a positional argument) for every field of the dataclass ``cls``, and the ``--SECTION.FIELD``
    flags of every field that is itself a dataclass (see the module docstring); ``aliases``: more spellings of a
    field's flag."""
    hints = type_hints(cls)
    docs = {**field_docs(cls), **(help or {})}
    flags, choices = flags or {}, choices or {}
    for f in dataclasses.fields(cls):
        hint = hint_of(hints[f.name])
        if isinstance(hint.kind, type) and dataclasses.is_dataclass(hint.kind):
            add_section_flags(parser, hint.kind, f.name)
            continue
        default = _default(f)
        doc = docs.get(f.name)
        if doc is None:
            raise TypeError(f"{cls.__name__}.{f.name}: a command-line option needs a docstring or a help text")
        flag = flags.get(f.name, f"--{flag_name(f.name)}")
        shown = None if f.name in required or (hint.kind is bool and f.name in flags) else default
        text = _help(doc, shown)
        given: dict[str, Any] = {"default": None if default is dataclasses.MISSING else default, "help": text}
        if hint.kind is bool:  # off by default: --FLAG; on: --FLAG/--no-FLAG, or the renamed flag turns it off
            action = ("store_true" if default is not True else "store_false" if f.name in flags
                      else argparse.BooleanOptionalAction)
            parser.add_argument(flag, dest=f.name, action=action, **given)
            continue
        values = tuple(choices.get(f.name, ())) or hint.choices
        kwargs: dict[str, Any] = {"type": _parser_of(hint.kind, hint.optional), "choices": values, **given}
        if hint.many:
            kwargs["nargs"] = "+"
        if const is not None and f.name in const:  # the flag alone stands for this value
            kwargs.update(nargs="?", const=const[f.name])
        if f.name in positional:
            kwargs["nargs"] = kwargs.get("nargs") or ("?" if default is not dataclasses.MISSING else None)
            kwargs["metavar"] = f.name.upper() if values is None else None
            parser.add_argument(f.name, **kwargs)
            continue
        if f.name in flags and values is None:
            kwargs["metavar"] = flag.lstrip("-").replace("-", "_").upper()
        parser.add_argument(flag, *(aliases or {}).get(f.name, ()), dest=f.name,
                            required=default is dataclasses.MISSING or f.name in required, **kwargs)


def rename_fields(message: str, labels: Mapping[str, str]) -> str:
    """``message`` with each field name of ``labels`` written as its label (the flag the user typed)."""
    for name, label in labels.items():
        message = re.sub(rf"(?<![\w.-]){re.escape(name)}\b", label, message)
    return message


def from_args(cls: type[T], args: argparse.Namespace, *, flags: Mapping[str, str] | None = None, **extra: Any) -> T:
    """``cls`` from the values that :func:`add_options` parsed into ``args`` (its sections and the fields
    ``args`` lacks keep their defaults; ``extra`` overrides), tuples for tuple fields.  A value ``cls`` refuses
    raises ValueError naming the flag (``flags``: the renamed ones)."""
    hints = type_hints(cls)
    values: dict[str, Any] = {}
    for f in dataclasses.fields(cls):  # type: ignore[arg-type]
        if not hasattr(args, f.name) or dataclasses.is_dataclass(hint_of(hints[f.name]).kind):
            continue
        value = getattr(args, f.name)
        values[f.name] = tuple(value) if isinstance(value, list) and hint_of(hints[f.name]).many is tuple else value
        if isinstance(value, Path) and hint_of(hints[f.name]).kind is str:
            values[f.name] = str(value)
    try:
        return cls(**{**values, **extra})
    except ValueError as err:
        labels = {name: (flags or {}).get(name, f"--{flag_name(name)}") for name in values}
        raise ValueError(rename_fields(str(err), labels)) from err
