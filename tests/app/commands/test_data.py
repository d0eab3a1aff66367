"""``mcnkit data install|pairs|examples`` as functions (the lead wires them into ``mcnkit``)."""

from __future__ import annotations

import argparse
import hashlib
import json
from pathlib import Path

import pytest

from mcnkit.app.commands.data import add_data_parser


def _run(argv: list[str]) -> int:
    parser = argparse.ArgumentParser()
    add_data_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(argv)
    return int(args.func(args))


def test_install(tiny_houseexpo: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    digest = hashlib.sha256(tiny_houseexpo.read_bytes()).hexdigest()
    dest = tmp_path / "data"
    argv = ["data", "install", "houseexpo", "--from", tiny_houseexpo.as_uri(), "--dest", str(dest)]
    assert _run([*argv, "--sha256", digest]) == 0
    assert (dest / "houseexpo" / "json.tar.gz").is_file()
    assert _run(argv) == 2  # the default digest is the real archive's
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "sha256 mismatch" in err[0]
    assert _run([*argv[:-2], "--from", str(tmp_path / "nope.tar.gz"), "--dest", str(dest)]) == 2


def test_pairs(tiny_houseexpo: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    base = ["data", "pairs", "--out", str(tmp_path / "c"), "--houseexpo", str(tiny_houseexpo), "--no-progress"]
    assert _run([*base, "--train", "2", "--val", "1", "--test", "1"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["rebuilt"] and [s["n"] for s in report["splits"]] == [2, 1, 1]
    assert _run([*base, "--train", "2", "--val", "1", "--test", "1"]) == 0
    assert not json.loads(capsys.readouterr().out)["rebuilt"]
    out = tmp_path / "p"
    assert _run(["data", "pairs", "--domain", "procedural", "--out", str(out), "--train", "3", "--val", "1"]) == 0
    assert (out / "procedural-pairs.npz").is_file()
    # Every training domain's pairs can be built ahead of training: the seen window's are keyed by it.
    seen = tmp_path / "s"
    argv = ["data", "pairs", "--domain", "houseexpo-seen", "--out", str(seen), "--houseexpo", str(tiny_houseexpo)]
    assert _run([*argv, "--train", "2", "--val", "1", "--test", "1", "--no-progress"]) == 0
    manifest = json.loads((seen / "houseexpo-pairs.manifest.json").read_text())
    assert manifest["key"]["config"]["seen_window"] == [2.0, 8.0, 30.0]


def test_examples(tiny_houseexpo: Path, tmp_path: Path) -> None:
    png = tmp_path / "ex.png"
    argv = ["data", "examples", "--out", str(png), "--n", "2", "--houseexpo", str(tiny_houseexpo)]
    assert _run([*argv, "--cache", str(tmp_path / "c")]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
