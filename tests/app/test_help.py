"""``mcnkit --help`` and ``mcnkit COMMAND --help``: instant (no torch, rerun, numba or readers loaded), every
option explained, no development notes; every command reports bad input as ``mcnkit COMMAND: FILE: problem``."""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from mcnkit.app.main import COMMANDS, build_parser, main

HEAVY = ("torch", "rerun", "numba", "scipy", "matplotlib", "mcap", "tqdm", "mcnkit.slam.fastslam", "mcnkit.io.open",
         "mcnkit.io.writers")
HELP_ARGS = [[], *([name] for name in COMMANDS), ["eval", "ate"], ["eval", "groundtruth"], ["data", "pairs"],
             ["experiment", "exp2"], ["experiment", "exp3"], ["experiment", "exp1"]]


@pytest.mark.parametrize("words", HELP_ARGS, ids=lambda w: " ".join(w) or "mcnkit")
def test_help_loads_no_heavy_module(words: list[str]) -> None:
    script = (
        "import contextlib, io, json, sys\n"
        "from mcnkit.app.main import main\n"
        "out = io.StringIO()\n"
        "with contextlib.redirect_stdout(out), contextlib.suppress(SystemExit):\n"
        f"    main({[*words, '--help']!r})\n"
        f"print(json.dumps([out.getvalue(), [m for m in {HEAVY!r} if m in sys.modules]]))\n"
    )
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, check=True)
    text, loaded = json.loads(run.stdout)
    assert text.startswith("usage: mcnkit")
    assert loaded == [], f"`mcnkit {' '.join(words)} --help` imports {loaded}"


def _parsers(parser: argparse.ArgumentParser) -> Iterator[argparse.ArgumentParser]:
    yield parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from _parsers(sub)


@pytest.mark.parametrize("name", list(COMMANDS))
def test_every_option_has_help_and_no_development_notes(name: str) -> None:
    parser = build_parser(name)
    command = next(p for p in _parsers(parser) if p.prog == f"mcnkit {name}")
    for p in _parsers(command):
        for action in p._actions:
            if isinstance(action, argparse._SubParsersAction | argparse._HelpAction):
                continue
            assert action.help and action.help.strip(), f"{p.prog}: {action.option_strings or action.dest} has no help"
            said = action.help.split(" (default")[0].strip()  # what the option does: a phrase, not "." or a cut one
            assert len(said) > 5 and said.count("(") == said.count(")"), f"{p.prog}: {action.option_strings}: {said!r}"
        text = p.format_help()
        for note in ("``", ":mod:", ":func:", ":class:", ":meth:", "lead's", "TODO", "until the"):
            assert note not in text, f"`{p.prog} --help` shows {note!r}"


def test_the_command_summaries_are_the_commands_own() -> None:
    for name, (_module, _adder, summary) in COMMANDS.items():
        parser = build_parser(name)
        sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
        own = next(a.help for a in sub._choices_actions if a.dest == name)
        assert own == summary, name


@pytest.mark.parametrize(
    "argv",
    [
        ["info", "{missing}"],
        ["convert", "{missing}", "{tmp}/out.bag"],
        ["slam", "{missing}", "--out", "{tmp}/o", "--no-progress"],
        ["run", "{missing}", "--no-progress"],
        ["eval", "ate", "{missing}", "{missing}"],
        ["eval", "relations", "{missing}", "{missing}"],
        ["eval", "groundtruth", "{missing}", "{tmp}/gt.tum"],
    ],
    ids=lambda a: " ".join(w for w in a[:2] if not w.startswith("{")),
)
def test_one_error_format_everywhere(argv: list[str], tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    missing = tmp_path / "missing.log"
    words = [w.format(missing=missing, tmp=tmp_path) for w in argv]
    assert main(words) == 2
    err = capsys.readouterr().err.strip().splitlines()
    command = " ".join(words[:2] if words[0] == "eval" else words[:1])
    assert len(err) == 1 and err[0].startswith(f"mcnkit {command}: {missing}: "), err
