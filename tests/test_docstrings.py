"""The package's docstrings and comments name only files that exist in this repository (or are placeholders
such as ``WEIGHTS/NAME.md``, or outputs git ignores): a reader can open every file the code points to."""

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PATH = re.compile(r"(?<![\w$./-])((?:[\w.-]+/)+[\w.-]+\.(?:py|md|json|png|rrd|ipynb|yaml|toml|tex|txt))")
NOTE = re.compile(r"(?<![\w/.-])([A-Z][A-Z-]+\.md)")


PLACEHOLDERS = {"NAME.md"}
"""Bare names that stand for a pattern (a model card is ``WEIGHTS/NAME.md``)."""


def _output(token: str) -> bool:
    """Where a command writes and git ignores (``recordings/demo/demo.rrd``): named, not shipped."""
    return subprocess.run(["git", "check-ignore", "-q", token], cwd=ROOT, check=False).returncode == 0


def _placeholder(token: str) -> bool:
    """Paths under an upper-case placeholder folder (``RUN_DIR/best``, ``WEIGHTS/NAME.md``) name no real file."""
    return "/" in token and token.split("/")[0].isupper()


def test_named_files_exist() -> None:
    in_repo = {p.name for p in ROOT.rglob("*.md") if ".venv" not in p.parts}
    missing = []
    for source in sorted((ROOT / "mcnkit").rglob("*.py")):
        text = source.read_text()
        for token in PATH.findall(text):
            if not _placeholder(token) and not _output(token) and not any((b / token).exists() for b in (ROOT, ROOT / "mcnkit", source.parent)):
                missing.append(f"{source.relative_to(ROOT)}: {token}")
        missing += [f"{source.relative_to(ROOT)}: {name}" for name in NOTE.findall(text)
                    if name not in in_repo and name not in PLACEHOLDERS]
    assert not missing, "files named but not in the repository:\n" + "\n".join(missing)
