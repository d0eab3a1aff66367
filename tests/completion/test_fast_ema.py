"""Inference fast path (frozen spectral norm, folded batch norm), class-weighted L2 and the EMA of training."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from mcnkit.completion.checkpoint import load_checkpoint, load_generator, save_checkpoint
from mcnkit.completion.data import augment_dihedral, encode
from mcnkit.completion.nets import UNet, UNetConfig, has_spectral_norm, spectral_layers
from mcnkit.completion.sample import complete, inference_net, sample_completions
from mcnkit.completion.train import TrainConfig, ema_update, train, weighted_l2
from mcnkit.datasets import PairSplits

TINY = UNetConfig(base_channels=4, max_channels=16, depth=3, dropout=0.3)


def _trained_a_bit(splits: PairSplits) -> UNet:
    torch.manual_seed(0)
    net = UNet(TINY)
    x, y = encode(splits.train)
    opt = torch.optim.Adam(net.parameters(), lr=1e-2)
    for _ in range(5):  # moves weights and batch-norm statistics away from their initial values
        loss = weighted_l2(net(x), y, x[:, 1:2], 2.0)
        opt.zero_grad()
        loss.backward()
        opt.step()
    return net.eval()


def test_fast_path_computes_the_same_function(tiny_splits: PairSplits) -> None:
    net = _trained_a_bit(tiny_splits)
    x, _ = encode(tiny_splits.test)
    fast = inference_net(net)
    assert fast is not net and inference_net(net) is fast  # cached
    assert not any(has_spectral_norm(m) for m in spectral_layers(fast))
    assert all(has_spectral_norm(m) for m in spectral_layers(net))  # the original keeps its parametrization
    with torch.no_grad():
        torch.testing.assert_close(fast(x), net(x), atol=1e-5, rtol=1e-4)
        a = fast(x, sample=True, generator=torch.Generator().manual_seed(2))
        b = net(x, sample=True, generator=torch.Generator().manual_seed(2))
    torch.testing.assert_close(a, b, atol=1e-5, rtol=1e-4)  # same dropout draws: sampling is unchanged


def test_fast_path_follows_weight_changes(tiny_splits: PairSplits) -> None:
    net = _trained_a_bit(tiny_splits)
    before = complete(net, tiny_splits.test.partial)
    first = inference_net(net)
    with torch.no_grad():
        for p in net.parameters():
            p.mul_(-1.0)
    assert inference_net(net) is not first  # rebuilt
    x, _ = encode(tiny_splits.test)
    with torch.no_grad():
        torch.testing.assert_close(inference_net(net)(x), net(x), atol=1e-5, rtol=1e-4)
    assert not np.array_equal(complete(net, tiny_splits.test.partial), before)


def test_a_checkpoint_loaded_under_inference_mode_completes(tmp_path: Path, tiny_splits: PairSplits) -> None:
    # weights made under torch.inference_mode keep no in-place version; the fast path must still take them
    net = _trained_a_bit(tiny_splits)
    expected = complete(net, tiny_splits.test.partial)
    save_checkpoint(tmp_path / "ckpt", "unet", net)
    with torch.inference_mode():
        loaded, _ = load_generator(tmp_path / "ckpt")
        assert np.array_equal(complete(loaded, tiny_splits.test.partial), expected)
        assert sample_completions(loaded, tiny_splits.test.partial[:2], k=2).samples.shape[:2] == (2, 2)


def test_sampling_through_fast_path_is_seeded_and_diverse(tiny_splits: PairSplits) -> None:
    net = _trained_a_bit(tiny_splits)
    s1 = sample_completions(net, tiny_splits.test.partial[:2], k=4, generator=torch.Generator().manual_seed(5))
    s2 = sample_completions(net, tiny_splits.test.partial[:2], k=4, generator=torch.Generator().manual_seed(5))
    assert np.array_equal(s1.samples, s2.samples) and (s1.diversity > 0).all()


def test_free_weight_moves_the_l2_optimum() -> None:
    # one cell, target free (0) with prob. p, occupied (1) otherwise: the weighted L2 optimum is
    # (1 - p)·w_o / (p·w_f + (1 - p)·w_o); with p = 0.45 and w_f = 1.5 it falls below 0.5 (predicts free)
    out = torch.linspace(0, 1, 1001).view(-1, 1, 1, 1).expand(-1, 2, 1, 1)
    free_t, occ_t = torch.zeros(1001, 2, 1, 1), torch.ones(1001, 2, 1, 1)
    unknown = torch.ones(1001, 1, 1, 1)

    def risk(wf: float) -> torch.Tensor:
        per = [((out - t) ** 2).mean(dim=(1, 2, 3)) * (wf if t is free_t else 1.0) for t in (free_t, occ_t)]
        return 0.45 * per[0] + 0.55 * per[1]

    assert float(out[risk(1.0).argmin(), 0]) > 0.5 and float(out[risk(1.5).argmin(), 0]) < 0.5
    # the function itself weights free-target cells by free_weight before normalization
    y = torch.cat([free_t[:1], occ_t[:1]])
    o = torch.full_like(y, 0.5)
    assert torch.isclose(weighted_l2(o, y, unknown[:2], 1.0, 1.5), weighted_l2(o, y, unknown[:2], 1.0))


def test_ema_update_averages_and_keeps_unit_vectors() -> None:
    torch.manual_seed(0)
    a, b = UNet(TINY), UNet(TINY)
    wa = dict(a.state_dict())
    wa = {k: v.clone() for k, v in wa.items()}
    ema_update(a, b, 0.75)
    for k, v in a.state_dict().items():
        if k.endswith("._u") or k.endswith("._v"):
            assert torch.isclose(v.norm(), torch.tensor(1.0), atol=1e-5)
        elif v.dtype.is_floating_point:
            torch.testing.assert_close(v, 0.75 * wa[k] + 0.25 * b.state_dict()[k])


def test_train_with_ema_and_free_weight(tmp_path: Path, tiny_splits: PairSplits) -> None:
    cfg = TrainConfig(
        model="unet", domain="procedural", out_dir=str(tmp_path), n_train=32, epochs=2, batch_size=8,
        base_channels=4, max_channels=16, depth=3, progress=False, threads=1, ema_decay=0.9, free_weight=1.5,
    )  # fmt: skip
    res = train(cfg, tiny_splits)
    assert res.best_path is not None
    last = load_checkpoint(tmp_path / "last")
    assert last.section("ema.generator") and last.info["train_config"]["free_weight"] == 1.5
    # resume restores the average too
    res2 = train(TrainConfig(**{**cfg.__dict__, "epochs": 3, "resume": True}), tiny_splits)
    assert res2.epochs_done == 3


def test_flips_only_augmentation_never_transposes() -> None:
    x = torch.arange(64 * 4 * 16, dtype=torch.float32).reshape(64, 4, 4, 4)
    ax, ay = augment_dihedral(x, x.clone(), torch.Generator().manual_seed(0), transpose=False)
    assert torch.equal(ax, ay)
    flips = [lambda t: t, lambda t: t.flip(-1), lambda t: t.flip(-2), lambda t: t.flip(-1).flip(-2)]
    seen = set()
    for i in range(64):
        hits = [k for k, f in enumerate(flips) if torch.equal(ax[i], f(x[i]))]
        assert len(hits) == 1
        seen.add(hits[0])
    assert seen == {0, 1, 2, 3}
