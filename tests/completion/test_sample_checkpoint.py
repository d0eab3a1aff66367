from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from mcnkit.completion.checkpoint import CheckpointError, load_checkpoint, load_generator, save_checkpoint
from mcnkit.completion.nets import DiscriminatorConfig, PatchDiscriminator, UNet, UNetConfig
from mcnkit.completion.sample import complete, diversity, sample_completions
from mcnkit.datasets import PairSplits

TINY = UNetConfig(base_channels=4, max_channels=16, depth=3, dropout=0.3)


def test_k_different_samples(tiny_splits: PairSplits) -> None:
    torch.manual_seed(0)
    net = UNet(TINY)
    s = sample_completions(net, tiny_splits.test.partial[:3], k=5, generator=torch.Generator().manual_seed(1))
    assert s.samples.shape == (3, 5, 64, 64) and s.mean.shape == (3, 64, 64) and s.uncertainty.shape == (3, 64, 64)
    assert set(np.unique(s.samples)) <= {0.0, 0.5, 1.0}
    assert 0.0 <= float(s.uncertainty.min()) and float(s.uncertainty.max()) <= 1.0
    for b in range(3):
        flat = s.samples[b].reshape(5, -1)
        assert len({row.tobytes() for row in flat}) == 5  # all K samples differ
    assert (s.diversity > 0).all()
    again = sample_completions(net, tiny_splits.test.partial[:3], k=5, generator=torch.Generator().manual_seed(1))
    assert np.array_equal(again.samples, s.samples)  # seeded


def test_diversity_of_identical_samples_is_zero() -> None:
    same = np.zeros((2, 4, 8, 8), np.float32)
    assert diversity(same).tolist() == [0.0, 0.0]


def test_checkpoint_round_trip(tmp_path: Path, tiny_splits: PairSplits) -> None:
    torch.manual_seed(0)
    gen, disc = UNet(TINY), PatchDiscriminator(DiscriminatorConfig(base_channels=4))
    gen.eval()
    path = save_checkpoint(tmp_path / "m", "pix2pix", gen, disc, {"epoch": 3})
    assert path.suffix == ".safetensors" and (tmp_path / "m.json").is_file()
    loaded, info = load_generator(tmp_path / "m.safetensors", expect_arch="pix2pix")
    assert info["epoch"] == 3
    x = tiny_splits.test.partial
    assert np.array_equal(complete(loaded, x), complete(gen, x))
    assert load_checkpoint(tmp_path / "m").section("discriminator")


def test_wrong_checkpoint_is_refused(tmp_path: Path) -> None:
    save_checkpoint(tmp_path / "u", "unet", UNet(TINY))
    with pytest.raises(CheckpointError, match=r"u\.safetensors: checkpoint is a unet model, expected pix2pix"):
        load_generator(tmp_path / "u", expect_arch="pix2pix")
    other = UNetConfig(base_channels=8, max_channels=16, depth=3)
    with pytest.raises(CheckpointError, match=r"u\.safetensors: generator shape differs: base_channels=4"):
        load_generator(tmp_path / "u", expect_config=other)
    # tensors of another shape under a config that claims this one
    save_checkpoint(tmp_path / "v", "unet", UNet(other))
    (tmp_path / "v.json").write_text((tmp_path / "u.json").read_text())
    with pytest.raises(CheckpointError, match=r"v\.safetensors: generator tensor .* has shape"):
        load_generator(tmp_path / "v")
    (tmp_path / "w.json").write_text("{}")
    (tmp_path / "w.safetensors").write_bytes(b"x")
    with pytest.raises(CheckpointError, match=r"w\.json: not an mcnkit completion checkpoint"):
        load_generator(tmp_path / "w")
    with pytest.raises(CheckpointError, match="not found"):
        load_generator(tmp_path / "missing")
    assert "\n" not in str(CheckpointError("x"))


def test_symmetric_completion_of_a_symmetric_net_is_unchanged(tiny_splits: PairSplits) -> None:
    class Identity(UNet):
        def forward(
            self, x: torch.Tensor, sample: bool = False, generator: torch.Generator | None = None
        ) -> torch.Tensor:
            return x

    net = Identity(TINY)
    m = tiny_splits.test.partial
    assert np.array_equal(complete(net, m, symmetric=True), complete(net, m))
    assert np.array_equal(complete(net, m, symmetric=True, transpose=False), complete(net, m))  # the 4 flips
