"""Outputs never clobber inputs: ``check_outputs`` and the commands ``slam``, ``run``, ``convert``, ``demo``."""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import pytest

from mcnkit.app.main import main
from mcnkit.app.outputs import Output, OutputError, check_outputs, staged_folder
from mcnkit.io import LogContent, write_log
from mcnkit.types import Frame

WEIGHTS = Path(__file__).resolve().parents[2] / "mcnkit" / "weights" / "unet-procedural.safetensors"


def _digest(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def log(tmp_path: Path, frames: list[Frame]) -> Path:
    (tmp_path / "logs").mkdir()
    return write_log(tmp_path / "logs" / "run.mcap", LogContent(frames))


def test_check_outputs_refuses_every_way_an_output_can_touch_an_input(tmp_path: Path) -> None:
    inp = tmp_path / "data" / "run.mcap"
    inp.parent.mkdir()
    inp.write_bytes(b"x")
    link = tmp_path / "alias.mcap"
    os.link(inp, link)
    cases = {
        Output(inp): "is the input",
        Output(tmp_path / "data" / ".." / "data" / "run.mcap"): "is the input",
        Output(link): "is the input",  # a hard link to it
        Output(tmp_path / "data", folder=True): "contains the input",
        Output(tmp_path, folder=True): "contains the input",
        Output(inp / "x.rrd"): "lies inside the input",
    }
    for out, problem in cases.items():
        with pytest.raises(OutputError, match=problem):
            check_outputs([inp], [out], overwrite=True)
    check_outputs([inp], [Output(tmp_path / "other.rrd"), Output(tmp_path / "out", folder=True)], overwrite=False)


def test_check_outputs_needs_overwrite_for_existing_outputs_and_checks_kinds(tmp_path: Path) -> None:
    rrd, out = tmp_path / "a.rrd", tmp_path / "out"
    rrd.write_bytes(b"old")
    out.mkdir()
    check_outputs([], [Output(out, folder=True)], overwrite=False)  # an empty folder is fine
    (out / "summary.json").write_text("{}")
    for o in (Output(rrd), Output(out, folder=True), Output(rrd, folder=None)):
        with pytest.raises(OutputError, match="--overwrite"):
            check_outputs([], [o], overwrite=False)
        check_outputs([], [o], overwrite=True)
    with pytest.raises(OutputError, match="is a file, not a folder"):
        check_outputs([], [Output(rrd, folder=True)], overwrite=True)
    with pytest.raises(OutputError, match="is a folder, not a file"):
        check_outputs([], [Output(out)], overwrite=True)
    with pytest.raises(OutputError, match="named twice"):
        check_outputs([], [Output(tmp_path / "b.rrd"), Output(tmp_path / "." / "b.rrd")], overwrite=True)


def test_staged_folder_moves_files_in_only_when_complete(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with staged_folder(out) as tmp:
        (tmp / "a.txt").write_text("new")
        assert not (out / "a.txt").exists()
    assert (out / "a.txt").read_text() == "new" and sorted(p.name for p in out.iterdir()) == ["a.txt"]
    with pytest.raises(RuntimeError), staged_folder(out) as tmp:
        (tmp / "a.txt").write_text("half")
        raise RuntimeError("failed half way")
    assert (out / "a.txt").read_text() == "new" and sorted(p.name for p in out.iterdir()) == ["a.txt"]


def _refused(argv: list[str], capsys: pytest.CaptureFixture[str], command: str, problem: str) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith(f"mcnkit {command}: ") and problem in err, err


@pytest.mark.parametrize("command", ["slam", "run"])
def test_slam_and_run_refuse_outputs_on_their_input_before_writing(
        command: str, log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    before = _digest(log)
    base = [command, str(log), "--no-progress"]
    out = ["--out", str(tmp_path / "out")]
    _refused([*base, "--rrd", str(log), *out], capsys, command, "is the input")
    _refused([*base, "--rrd", str(log), *out, "--overwrite"], capsys, command, "is the input")
    _refused([*base, "--out", str(log.parent)], capsys, command, "contains the input")
    assert _digest(log) == before and not (tmp_path / "out").exists()
    assert sorted(p.name for p in log.parent.iterdir()) == ["run.mcap"]


def test_run_refuses_to_write_over_its_model(log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = shutil.copy(WEIGHTS, tmp_path / "net.safetensors")
    before = _digest(Path(model))
    _refused(["run", str(log), "--model", str(model), "--rrd", str(model), "--no-progress"], capsys, "run",
             "is the input")
    assert _digest(Path(model)) == before


def test_slam_replaces_existing_outputs_only_with_overwrite(
        log: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    rrd, out = tmp_path / "run.rrd", tmp_path / "out"
    argv = ["slam", str(log), "--particles", "4", "--no-progress", "--rrd", str(rrd), "--out", str(out)]
    assert main(argv) == 0
    first = {p.name: _digest(p) for p in [rrd, *out.iterdir()]}
    assert "summary.json" in first and "trajectory.tum" in first
    _refused(argv, capsys, "slam", "is not empty (pass --overwrite")
    assert {p.name: _digest(p) for p in [rrd, *out.iterdir()]} == first
    shutil.rmtree(out)
    _refused(argv, capsys, "slam", "exists already (pass --overwrite")
    assert not out.exists() and _digest(rrd) == first["run.rrd"]
    assert main([*argv, "--overwrite"]) == 0
    again = {p.name: _digest(p) for p in [rrd, *out.iterdir()]}
    assert again.keys() == first.keys()
    assert again["trajectory.tum"] == first["trajectory.tum"]  # same seed, same trajectory
    assert not list(tmp_path.rglob("*.partial"))


def test_convert_refuses_its_input_even_with_overwrite(log: Path, tmp_path: Path,
                                                       capsys: pytest.CaptureFixture[str]) -> None:
    before = _digest(log)
    _refused(["convert", str(log), str(log), "--overwrite", "--quiet"], capsys, "convert", "is the input")
    _refused(["convert", str(log), str(log.parent), "--overwrite", "--quiet"], capsys, "convert",
             "contains the input")
    assert _digest(log) == before
    bag = tmp_path / "run.bag"
    assert main(["convert", str(log), str(bag), "--quiet"]) == 0
    _refused(["convert", str(log), str(bag), "--quiet"], capsys, "convert", "exists already")
    assert main(["convert", str(log), str(bag), "--quiet", "--overwrite"]) == 0
    assert not list(tmp_path.glob("*.partial"))


def test_demo_refuses_to_write_over_its_model_or_an_earlier_run(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    model = Path(shutil.copy(WEIGHTS, tmp_path / "net.safetensors"))
    before = _digest(model)
    out = tmp_path / "demo"
    _refused(["demo", "--model", str(model), "--rrd", str(model), "--out", str(out)], capsys, "demo", "is the input")
    _refused(["demo", "--model", str(model), "--out", str(tmp_path)], capsys, "demo", "contains the input")
    assert _digest(model) == before and not out.exists()
    out.mkdir()
    (out / "demo.rrd").write_bytes(b"an earlier run")
    _refused(["demo", "--out", str(out)], capsys, "demo", "is not empty (pass --overwrite")
    assert (out / "demo.rrd").read_bytes() == b"an earlier run"
