"""The ``mcnkit`` command: info and convert, and how bad input ends (one line, exit code 2)."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from mcnkit.app.main import main
from mcnkit.io import LogContent, open_log, write_log
from mcnkit.types import Frame


def test_info_prints_format_topics_and_scanner(tmp_path: Path, frames: list[Frame], capsys: pytest.CaptureFixture[str]) -> None:
    path = write_log(tmp_path / "run.mcap", LogContent(frames))
    assert main(["info", str(path)]) == 0
    out = capsys.readouterr().out
    assert "format    mcap-ros2" in out
    assert "/scan" in out and "sensor_msgs/msg/LaserScan" in out
    assert "20 scans of 8 beams, field of view 180.0°" in out
    assert main(["info", str(path), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["scans"] == 20 and info["odom_source"] == "/odom" and info["duration_s"] == 1.9


def test_convert_between_every_pair_of_formats(tmp_path: Path, frames: list[Frame]) -> None:
    src = write_log(tmp_path / "src.bag", LogContent(frames))
    outputs = {"ros2-sqlite3": tmp_path / "a", "ros2-mcap": tmp_path / "b", "mcap": tmp_path / "c.mcap",
               "ros1": tmp_path / "d.bag"}
    previous = src
    for fmt, out in outputs.items():
        assert main(["convert", str(previous), str(out), "--format", fmt, "--quiet"]) == 0
        previous = out
    with open_log(previous) as log:
        back = list(log.frames())
    assert [f.stamp_ns for f in back] == [f.stamp_ns for f in frames]


def test_convert_real_lab_log_to_a_bag_by_suffix(tmp_path: Path, shared_data: Path) -> None:
    out = tmp_path / "loop5.bag"
    assert main(["convert", str(shared_data / "reallab/dpslam-loop5/loop5.log"), str(out), "--quiet"]) == 0
    with open_log(out) as log:
        assert log.format == "ros1" and sum(1 for _ in log.frames()) == 551


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["info", "/no/such/file.bag"], "mcnkit info: /no/such/file.bag: no such file or folder"),
        (["convert", "/no/such.clf", "out.bag"], "mcnkit convert: /no/such.clf: no such file or folder"),
    ],
)
def test_bad_input_ends_with_one_line_and_exit_code_2(args: list[str], message: str, tmp_path: Path) -> None:
    exe = shutil.which("mcnkit", path=str(Path(sys.executable).parent))
    assert exe is not None, "the mcnkit console script is installed next to the interpreter"
    run = subprocess.run([exe, *args], capture_output=True, text=True, cwd=tmp_path, check=False)
    assert run.returncode == 2
    assert run.stderr.strip() == message
    assert "Traceback" not in run.stderr


def test_a_log_without_laser_cannot_be_converted(tmp_path: Path, shared_data: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["convert", str(shared_data / "fixtures/rosbag_js/example.bag"), str(tmp_path / "x.bag")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"mcnkit convert: {shared_data / 'fixtures/rosbag_js/example.bag'}: no sensor_msgs/LaserScan "
                   "(or MultiEchoLaserScan) topic (topics: ['/rosout', '/turtle1/color_sensor', '/tf_static', '/turtle2/color_sensor', "
                   "'/turtle1/pose', '/turtle2/pose', '/tf', '/turtle2/cmd_vel', '/turtle1/cmd_vel'])"]
    assert not (tmp_path / "x.bag").exists()


def test_a_command_missing_an_optional_dependency_names_the_extra(monkeypatch, capsys) -> None:
    """A core install (logs + SLAM + Rerun) running `mcnkit train` is told which extra to install, in one line."""
    import builtins

    real_import = builtins.__import__

    def no_torch(name, *args, **kwargs):  # type: ignore[no-untyped-def]
        if name == "torch" or name.startswith("torch."):
            raise ModuleNotFoundError(f"No module named '{name}'", name=name)
        return real_import(name, *args, **kwargs)

    for mod in [m for m in sys.modules if m == "torch" or m.startswith(("torch.", "mcnkit.completion"))]:
        monkeypatch.delitem(sys.modules, mod)
    monkeypatch.setattr(builtins, "__import__", no_torch)
    from mcnkit.app.main import main

    code = main(["train", "--model", "unet", "--domain", "procedural", "--out", "unused"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err == ["mcnkit train: needs the optional 'completion' dependencies (torch is not installed): "
                   "pip install 'mcnkit[completion]'"]
