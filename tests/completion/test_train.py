from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import torch

from mcnkit.completion.data import augment_dihedral, encode
from mcnkit.completion.nets import UNet, UNetConfig
from mcnkit.completion.train import TrainConfig, train, weighted_l2
from mcnkit.datasets import PairSplits

ROOT = Path(__file__).resolve().parents[2]


def test_tiny_model_loss_falls(tiny_splits: PairSplits) -> None:
    torch.manual_seed(0)
    net = UNet(UNetConfig(base_channels=4, max_channels=16, depth=3, dropout=0.0))
    x, y = encode(tiny_splits.train)
    opt = torch.optim.Adam(net.parameters(), lr=1e-2)
    losses = []
    for _ in range(25):
        loss = weighted_l2(net(x), y, x[:, 1:2], 2.0)
        opt.zero_grad()
        loss.backward()
        opt.step()
        losses.append(float(loss.detach()))
    assert losses[-1] < 0.6 * losses[0]


def test_augmentation_applies_the_same_symmetry() -> None:
    x = torch.arange(2 * 2 * 16, dtype=torch.float32).reshape(2, 2, 4, 4)
    ax, ay = augment_dihedral(x, x.clone(), torch.Generator().manual_seed(3))
    assert torch.equal(ax, ay) and sorted(ax.flatten().tolist()) == sorted(x.flatten().tolist())


def _cfg(out: Path, **kw: object) -> TrainConfig:
    base = dict(
        model="pix2pix", domain="procedural", out_dir=str(out), n_train=32, epochs=2, batch_size=8,
        base_channels=4, max_channels=16, depth=3, progress=False, threads=1,
    )  # fmt: skip
    base.update(kw)
    return TrainConfig(**base)  # type: ignore[arg-type]


def test_train_checkpoints_and_resume(tmp_path: Path, tiny_splits: PairSplits) -> None:
    res = train(_cfg(tmp_path, epochs=1), tiny_splits)
    assert res.best_path is not None and res.best_path.is_file()
    info = json.loads((tmp_path / "last.json").read_text())
    assert info["arch"] == "pix2pix" and info["info"]["epoch"] == 0 and len(info["info"]["history"]) == 1
    res2 = train(_cfg(tmp_path, epochs=2, resume=True), tiny_splits)
    assert res2.epochs_done == 2
    info = json.loads((tmp_path / "last.json").read_text())
    assert info["info"]["epoch"] == 1 and len(info["info"]["history"]) == 2 and info["info"]["steps"] == 8


def test_ddp_two_gloo_processes_two_steps(tmp_path: Path) -> None:
    cmd = [
        sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node=2",
        "-m", "mcnkit.app.commands.train", "train", "--model", "unet", "--domain", "procedural", "--out", str(tmp_path),
        "--n-train", "16", "--n-val", "4", "--n-test", "2", "--batch-size", "4", "--max-steps", "2", "--epochs", "1",
        "--base-channels", "4", "--max-channels", "8", "--depth", "3", "--threads", "1", "--no-progress",
    ]  # fmt: skip
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr[-2000:]
    info = json.loads((tmp_path / "last.json").read_text())["info"]
    assert info["steps"] == 2  # two optimizer steps, each over the two ranks' shards


def test_the_seen_domain_frames_pairs_as_the_explorer_frames_its_maps() -> None:
    from mcnkit.datasets.pairs import HOUSEEXPO_DOMAINS
    from mcnkit.explore.config import GainConfig

    g = GainConfig()
    for domain in ("houseexpo-seen", "houseexpo-seen-wide"):
        assert HOUSEEXPO_DOMAINS[domain]["seen_window"] == (g.window_margin_m, g.window_min_m, g.window_max_m)
