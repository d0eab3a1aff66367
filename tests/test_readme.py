"""The guide's recipes run as written.

The README's Python examples (and those of the guide pages in ``docs/``) run in a scratch folder with the shared
data they document; every command line of their shell blocks is one the program accepts (``mcnkit`` lines parse
with the command's own parser, ``rerun`` lines name options ``rerun --help`` lists, ``make`` lines name targets of
the Makefile, ``python -m benchmarks.…`` lines name modules that exist); the README's live-viewing recipe streams a
real run to a server bound to 127.0.0.1 with no display; every file and section the README links to exists.
"""

from __future__ import annotations

import contextlib
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
GUIDES = [README, *sorted((ROOT / "docs").glob("*.md"))]
BIN = Path(sys.executable).parent


def _blocks(path: Path, language: str) -> list[str]:
    return re.findall(rf"^```{language}\n(.*?)^```", path.read_text(), flags=re.MULTILINE | re.DOTALL)


PYTHON = [(path, index) for path in GUIDES for index in range(len(_blocks(path, "python")))]
SHELL = [(path, line) for path in GUIDES for block in _blocks(path, "bash") for line in block.splitlines()
         if line.strip() and not line.lstrip().startswith("#")]


def test_the_readme_is_a_short_guide_with_python_examples() -> None:
    assert len(_blocks(README, "python")) >= 2
    assert len(README.read_text().splitlines()) <= 250


@pytest.mark.parametrize(("path", "index"), PYTHON, ids=[f"{p.name}-{i + 1}" for p, i in PYTHON])
def test_python_block_runs(path: Path, index: int, tmp_path: Path, shared_data: Path,
                           monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    work, scratch = tmp_path / "work", tmp_path / "tmp"
    work.mkdir()
    scratch.mkdir()
    monkeypatch.chdir(work)
    monkeypatch.setattr(tempfile, "tempdir", str(scratch))  # where the examples' temporary folders go
    monkeypatch.setenv("MCNKIT_SHARED_DATA", str(shared_data))
    code = compile(_blocks(path, "python")[index], f"{path.name} python block {index + 1}", "exec")
    exec(code, {"__name__": f"guide_block_{index + 1}"})  # a fresh namespace: each block stands alone
    assert capsys.readouterr().out.strip(), "every example prints what it shows"
    assert not any(work.iterdir()), "examples write to a temporary folder, not the working directory"


def _words(line: str) -> list[str]:
    """One shell command line as words, its comment and a trailing ``&`` (run in the background) left out."""
    words = shlex.split(line, comments=True)
    return words[:-1] if words and words[-1] == "&" else words


def _rerun_help() -> str:
    return subprocess.run([str(BIN / "rerun"), "--help"], capture_output=True, text=True, check=True,
                          env={**os.environ, "RERUN_ANALYTICS": "0"}).stdout


def _check_command(words: list[str], rerun_help: str) -> str | None:
    """Why ``words`` (one shell command, program first) is not a command the program accepts; None if it is."""
    from mcnkit.app.main import build_parser

    program = words[0].removeprefix(".venv/bin/")
    if program == "mcnkit":
        try:
            build_parser(only=words[1]).parse_args(words[1:])
        except SystemExit:
            return "mcnkit does not accept it"
        return None
    if program == "rerun":
        unknown = [w.split("=")[0] for w in words[1:] if w.startswith("--") and w.split("=")[0] not in rerun_help]
        return f"rerun has no {unknown}" if unknown else None
    if program == "make":
        targets = re.findall(r"^([\w-]+):", (ROOT / "Makefile").read_text(), flags=re.MULTILINE)
        return None if all(w in targets or "=" in w for w in words[1:]) else f"no make target in {words[1:]}"
    if program == "python" and words[1] == "-m" and words[2].startswith("benchmarks."):
        module = ROOT / Path(*words[2].split(".")).with_suffix(".py")
        return None if module.is_file() else f"no {module.relative_to(ROOT)}"
    if program in ("jupyter", "pip") or re.fullmatch(r"\w+=\$\(mktemp -d\)", " ".join(words)):
        return None
    return f"a program the guide's test does not know: {program}"


def test_shell_commands_are_accepted() -> None:
    rerun_help = _rerun_help()
    wrong = []
    for path, line in SHELL:
        words = _words(line)
        if words and (why := _check_command(words, rerun_help)) is not None:
            wrong.append(f"{path.name}: {line.strip()}\n    {why}")
    assert not wrong, "\n".join(wrong)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.slow
def test_live_viewing_recipe_runs_headless_on_localhost(tmp_path: Path, shared_data: Path) -> None:
    block = next(b for b in _blocks(README, "bash") if "--serve-grpc" in b)
    server_line = next(line for line in block.splitlines() if "--serve-grpc" in line)
    run_line = next(line for line in block.splitlines() if "mcnkit" in line)
    assert "--bind 127.0.0.1" in server_line

    port = str(_free_port())
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env.update(RERUN_ANALYTICS="0", TMPDIR=str(tmp_path))  # the recipe's mktemp folders land in tmp_path

    def as_run_here(line: str) -> str:
        return (line.replace("9876", port).replace(".venv/bin/", f"{BIN}/")
                .replace("../shared/data", str(shared_data)))

    server_words = _words(as_run_here(server_line))
    log = tmp_path / "server.log"
    with log.open("w") as sink:
        server = subprocess.Popen(server_words, stdout=sink, stderr=subprocess.STDOUT, env=env, cwd=tmp_path,
                                  start_new_session=True)  # the rerun shim starts the viewer binary as its child
    try:
        deadline = time.monotonic() + 60
        while f"127.0.0.1:{port}" not in log.read_text():
            assert server.poll() is None and time.monotonic() < deadline, log.read_text()
            time.sleep(0.2)
        run = subprocess.run(["bash", "-c", as_run_here(run_line)], capture_output=True, text=True, env=env,
                             cwd=tmp_path, timeout=300, check=False)
        assert run.returncode == 0, run.stderr
        assert f"rerun+http://127.0.0.1:{port}/proxy" in run.stdout
        assert "Listening for gRPC connections on 127.0.0.1" in log.read_text()
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(server.pid, signal.SIGTERM)
        server.wait(timeout=30)


def _slug(heading: str) -> str:
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_the_readme_links_to_files_and_sections_that_exist() -> None:
    text = README.read_text()
    anchors = {_slug(h) for h in re.findall(r"^#+ (.*)$", text, flags=re.MULTILINE)}
    missing = []
    for target in re.findall(r"\]\(([^)]+)\)", text):
        if target.startswith(("http://", "https://")):
            continue
        path, _, anchor = target.partition("#")
        if path and not (README.parent / path).exists():
            missing.append(target)
        if not path and anchor not in anchors:
            missing.append(target)
    assert not missing, missing
