from __future__ import annotations

import argparse
from pathlib import Path

import pytest

from mcnkit.app.commands.experiment import add_experiment_parser
from mcnkit.app.commands.train import add_train_parser, main


def test_parsers_set_func() -> None:
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers()
    add_train_parser(sub)
    add_experiment_parser(sub)
    assert callable(parser.parse_args(["train", "--out", "x"]).func)
    for name in ("exp1", "exp2", "exp3"):
        args = parser.parse_args(["experiment", name, "--out", "x"])
        assert args.experiment == name and callable(args.func)


def test_bad_checkpoint_is_one_line_exit_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    code = main(
        ["train", "--domain", "procedural", "--n-train", "4", "--n-val", "2", "--n-test", "2", "--out", str(tmp_path),
         "--init-from", str(tmp_path / "nope"), "--no-progress"]
    )  # fmt: skip
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "nope.safetensors: checkpoint file not found" in err
