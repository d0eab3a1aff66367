"""The masked sampler: trained on partly revealed maps, it draws whole maps round by round, keeping m_t."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch

from mcnkit.completion.checkpoint import load_generator, save_checkpoint
from mcnkit.completion.masked import draw, reveal_for_training, reveal_share
from mcnkit.completion.nets import MaskedSampler, SamplerConfig, UNetConfig
from mcnkit.completion.sample import SubPixelUp, complete, inference_net, sample_completions
from mcnkit.completion.train import TrainConfig, train
from mcnkit.datasets import PairSplits
from mcnkit.grid import ternary_to_network
from mcnkit.types import UNKNOWN

TINY = SamplerConfig(UNetConfig(out_channels=1, base_channels=4, max_channels=16, depth=3, dropout=0.0),
                     (0.1, 0.4, 1.0))


def test_the_reveal_share_follows_the_schedule_round_by_round() -> None:
    t = torch.tensor([0.0, 0.5, 1.0, 2.0, 2.5, 3.0])
    share = reveal_share(t, (0.1, 0.4, 1.0))
    assert torch.allclose(share, torch.tensor([0.0, 0.05, 0.1, 0.4, 0.7, 1.0]))


def test_training_reveals_true_labels_only_where_m_t_is_unknown(tiny_splits: PairSplits) -> None:
    x = torch.from_numpy(ternary_to_network(tiny_splits.train.partial[:16]))
    y = torch.from_numpy(ternary_to_network(tiny_splits.train.target[:16]))
    x_in, cells = reveal_for_training(x, y, (0.1, 0.4, 1.0), torch.Generator().manual_seed(0))
    was_unknown = x[:, 1:2] > 0.5
    revealed = was_unknown & (x_in[:, 1:2] < 0.5)
    assert torch.equal(x_in[:, :1][~was_unknown], x[:, :1][~was_unknown])       # m_t's known cells untouched
    assert torch.equal(x_in[:, :1][revealed], y[:, :1][revealed])               # revealed = m_T's labels
    assert torch.equal(cells, was_unknown & ~revealed)                          # the loss is on the rest
    shares = revealed.flatten(1).sum(1) / was_unknown.flatten(1).sum(1).clamp_min(1)
    assert 0.0 <= float(shares.min()) and float(shares.max()) <= 1.0 and float(shares.std()) > 0.05


def test_each_round_conditions_on_the_labels_drawn_before() -> None:
    seen: list[torch.Tensor] = []

    def net(x: torch.Tensor) -> torch.Tensor:  # records its inputs; p(occupied) = 0.5 everywhere
        seen.append(x.clone())
        return torch.full((x.shape[0], 1, *x.shape[2:]), 0.5)

    x = torch.stack([torch.full((2, 8, 8), 0.5), torch.ones(2, 8, 8)], dim=1)
    out, first = draw(net, x, k=3, schedule=(0.25, 0.5, 1.0), generator=torch.Generator().manual_seed(0))
    assert out.shape == (2, 3, 8, 8) and set(out.unique().tolist()) <= {0.0, 1.0}
    assert first.shape == (2, 1, 8, 8)
    assert [len(s) for s in seen] == [2, 6, 6]              # the first round: one pass per map, shared by the K
    known = [float((s[:, 1] < 0.5).float().mean()) for s in seen]
    assert known[0] == 0.0 and 0.1 < known[1] < 0.4 and 0.35 < known[2] < 0.65


def test_late_rounds_sharpen_and_settle_sweeps_take_the_likeliest_label() -> None:
    def net(x: torch.Tensor) -> torch.Tensor:  # p(occupied) = 0.7 everywhere
        return torch.full((x.shape[0], 1, *x.shape[2:]), 0.7)

    x = torch.stack([torch.full((4, 16, 16), 0.5), torch.ones(4, 16, 16)], dim=1)
    g = torch.Generator
    plain, _ = draw(net, x, 8, (0.5, 1.0), g().manual_seed(0))
    sharp, _ = draw(net, x, 8, (0.5, 1.0), g().manual_seed(0), late_temperature=0.05, late_from=0.5)
    assert 0.6 < float(plain.mean()) < 0.8                     # calibrated: 70 % occupied
    assert 0.8 < float(sharp.mean()) < 0.9                     # the second half drawn (almost) all occupied
    settled, _ = draw(net, x, 8, (0.5, 1.0), g().manual_seed(0), settle=(1.0,))
    assert float(settled.mean()) == 1.0                        # every cell set to its likeliest label


def test_samples_keep_m_t_and_differ(tiny_splits: PairSplits) -> None:
    torch.manual_seed(0)
    net = MaskedSampler(TINY).eval()
    partial = tiny_splits.test.partial[:4]
    s = sample_completions(net, partial, k=4, generator=torch.Generator().manual_seed(1))
    known = partial != UNKNOWN
    assert s.samples.shape == (4, 4, 64, 64)
    assert np.array_equal(s.samples[np.broadcast_to(known[:, None], s.samples.shape)],
                          np.broadcast_to(partial[:, None], s.samples.shape)[np.broadcast_to(known[:, None],
                                                                                              s.samples.shape)])
    assert not (s.samples == UNKNOWN).any()                   # every unknown cell gets a label
    assert (s.diversity > 0).all()
    again = sample_completions(net, partial, k=4, generator=torch.Generator().manual_seed(1))
    assert np.array_equal(again.samples, s.samples)           # seeded
    det = complete(net, partial)                              # the deterministic view: p(occupied | m_t) ≥ 0.5
    assert np.array_equal(det[known], partial[known]) and not (det == UNKNOWN).any()


def test_the_frozen_copy_computes_the_same_probabilities(tiny_splits: PairSplits) -> None:
    torch.manual_seed(0)
    net = MaskedSampler(TINY)
    net.train()
    for _ in range(3):  # move the batch-norm statistics away from their initial values
        net(torch.from_numpy(ternary_to_network(tiny_splits.train.partial[:8])))
    net.eval()
    x = torch.from_numpy(ternary_to_network(tiny_splits.test.partial))
    fast = inference_net(net)
    assert isinstance(fast, MaskedSampler) and fast is not net
    with torch.no_grad():
        assert torch.allclose(fast(x), net(x), atol=1e-5)


def test_the_frozen_copy_upsamples_by_sub_pixel_convolution_the_same_function() -> None:
    torch.manual_seed(0)
    deconv = torch.nn.ConvTranspose2d(6, 5, 4, 2, padding=1)
    sub = SubPixelUp(deconv)
    x = torch.randn(3, 6, 8, 8)
    with torch.no_grad():
        assert torch.allclose(sub(x), deconv(x), atol=1e-6)
    assert any(isinstance(m, SubPixelUp) for m in inference_net(MaskedSampler(TINY).eval()).modules())


def test_a_trained_sampler_round_trips_through_its_checkpoint(tmp_path: Path, tiny_splits: PairSplits) -> None:
    cfg = TrainConfig(model="sampler", out_dir=str(tmp_path / "run"), epochs=1, batch_size=8, base_channels=4,
                      max_channels=16, depth=3, schedule=(0.1, 0.4, 1.0), threads=1, progress=False)
    result = train(cfg, tiny_splits)
    assert result.best_path is not None and "val_nll" in result.history[0]
    loaded, info = load_generator(tmp_path / "run" / "best", expect_arch="sampler")
    assert isinstance(loaded, MaskedSampler) and loaded.config.schedule == (0.1, 0.4, 1.0)
    g = torch.Generator
    a = sample_completions(loaded, tiny_splits.test.partial, 3, g().manual_seed(0)).samples
    path = save_checkpoint(tmp_path / "copy", "sampler", loaded, info=info)
    again, _ = load_generator(path)
    assert np.array_equal(sample_completions(again, tiny_splits.test.partial, 3, g().manual_seed(0)).samples, a)
