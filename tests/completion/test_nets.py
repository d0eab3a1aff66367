from __future__ import annotations

import numpy as np
import pytest
import torch

from mcnkit.completion.nets import (
    DiscriminatorConfig,
    PatchDiscriminator,
    UNet,
    UNetConfig,
    has_spectral_norm,
    soft_convert,
    spectral_layers,
)
from mcnkit.grid import network_to_ternary, ternary_to_network


@pytest.mark.parametrize("size", [32, 64, 128])
def test_unet_any_size_divisible_by_two_to_depth(size: int) -> None:
    net = UNet(UNetConfig(base_channels=4, depth=3, size=size))
    with torch.no_grad():
        out = net(torch.rand(2, 2, size, size))
    assert out.shape == (2, 2, size, size)
    assert float(out.min()) >= 0.0 and float(out.max()) <= 1.0


def test_size_not_divisible_is_refused() -> None:
    with pytest.raises(ValueError, match="divisible"):
        UNetConfig(depth=4, size=72)


def test_spectral_norm_on_every_conv() -> None:
    gen = UNet(UNetConfig(base_channels=4, depth=4, noise_channels=1))
    disc = PatchDiscriminator(DiscriminatorConfig(base_channels=4))
    layers = spectral_layers(gen) + spectral_layers(disc)
    assert len(spectral_layers(gen)) == 8 and len(spectral_layers(disc)) == 4
    assert all(has_spectral_norm(m) for m in layers)
    assert not has_spectral_norm(torch.nn.Conv2d(1, 1, 3))


def test_discriminator_patch_logits() -> None:
    disc = PatchDiscriminator(DiscriminatorConfig(base_channels=4))
    out = torch.rand(3, 2, 64, 64)
    logits = disc(torch.rand(3, 1, 64, 64), soft_convert(out))
    assert logits.shape[:2] == (3, 1) and logits.shape[-1] > 1


def test_encodings_round_trip() -> None:
    rng = np.random.default_rng(0)
    m = rng.choice(np.array([0.0, 0.5, 1.0], np.float32), size=(5, 64, 64))
    assert np.array_equal(network_to_ternary(ternary_to_network(m)), m)
    # soft conversion of a hard output reproduces the ternary image
    soft = soft_convert(torch.from_numpy(ternary_to_network(m)))[:, 0].numpy()
    assert np.array_equal(soft, m)


def test_dropout_only_when_sampling() -> None:
    net = UNet(UNetConfig(base_channels=4, depth=3, dropout=0.5)).eval()
    x = torch.rand(1, 2, 64, 64)
    assert torch.equal(net(x), net(x))
    g = torch.Generator().manual_seed(0)
    assert not torch.equal(net(x, sample=True, generator=g), net(x, sample=True, generator=g))
