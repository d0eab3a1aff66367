"""A bad checkpoint is refused at load, and every command reports it the same way: one line, exit 2."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file, save_file

from mcnkit.app.main import main
from mcnkit.completion.checkpoint import CheckpointError, load_checkpoint
from mcnkit.completion.registry import MODELS, default_weights_dir
from mcnkit.io import LogContent, write_log
from mcnkit.mcn import load_model
from mcnkit.types import Frame


def _nan_checkpoint(tmp_path: Path, value: float = float("nan")) -> Path:
    """The shipped U-net with one weight set to ``value``."""
    src = default_weights_dir() / MODELS["unet"]
    dst = tmp_path / "bad"
    shutil.copy(src.with_suffix(".json"), dst.with_suffix(".json"))
    tensors = load_file(str(src.with_suffix(".safetensors")))
    key = next(k for k, v in tensors.items() if k.startswith("generator.") and v.is_floating_point() and v.numel() > 1)
    tensors[key] = tensors[key].clone()
    tensors[key].view(-1)[1] = value
    save_file(tensors, str(dst.with_suffix(".safetensors")))
    return dst


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_non_finite_weights_are_refused_at_load(tmp_path: Path, value: float) -> None:
    bad = _nan_checkpoint(tmp_path, value)
    with pytest.raises(CheckpointError, match=r"bad\.safetensors: 1 non-finite value\(s\)"):
        load_checkpoint(bad)
    with pytest.raises(CheckpointError, match="non-finite"):
        load_model(bad)
    assert torch.isfinite(next(load_model("unet").parameters())).all()  # the shipped ones still load


def test_an_unknown_model_name_says_what_exists(tmp_path: Path) -> None:
    with pytest.raises(CheckpointError, match=r"neither a shipped model \(sampler, sampler-explore, sampler-explore-large, sampler-seen, sampler-seen-large, "
                       r"sampler-seen-wide, unet, unet-explore"):
        load_model(str(tmp_path / "nothing"))


def test_every_command_reports_a_bad_checkpoint_alike(tmp_path: Path, frames: list[Frame],
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    bad = _nan_checkpoint(tmp_path)
    log = write_log(tmp_path / "run.mcap", LogContent(frames))
    expected_tail = f"{bad.with_suffix('.safetensors')}: 1 non-finite value(s)"
    commands = {
        "run": ["run", str(log), "--model", str(bad), "--no-progress"],
        "demo": ["demo", "--model", str(bad), "--duration-s", "3", "--out", str(tmp_path / "demo"),
                 "--rrd", str(tmp_path / "demo.rrd")],
        "experiment exp3": ["experiment", "exp3", "--out", str(tmp_path / "e3"), "--logs", str(log),
                            "--models", str(bad), "--quiet"],
    }
    for name, argv in commands.items():
        capsys.readouterr()
        assert main(argv) == 2, name
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and err[0].startswith(f"mcnkit {name}: {expected_tail}"), (name, err)
    assert not (tmp_path / "demo.rrd").exists()
