"""The shipped masked samplers: loaded by name, the default of MCN-SLAM, and K different whole maps that keep m_t."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from mcnkit.completion.nets import MaskedSampler
from mcnkit.completion.registry import DEFAULT_MODEL
from mcnkit.completion.sample import sample_completions
from mcnkit.completion.structure import free_regions
from mcnkit.datasets import PairConfig, PairSplits, PseudoSlamConfig, load_or_build_houseexpo_pairs
from mcnkit.mcn import load_model
from mcnkit.types import FREE, UNKNOWN


def test_mcn_slam_samples_from_a_shipped_sampler_by_default() -> None:
    assert DEFAULT_MODEL == "sampler-explore"
    for name in ("sampler", "sampler-explore", "sampler-explore-large", "sampler-seen", "sampler-seen-large",
                 "sampler-seen-wide"):
        assert isinstance(load_model(name), MaskedSampler)


def _seen_frame_maps(shared_data: Path, tmp_path: Path) -> np.ndarray:
    """Four HouseExpo maps on the window an explorer completes (the frame the ``*-seen`` nets learnt), those of 12
    with the most unseen floor: a map whose house was seen whole has nothing left to disagree on."""
    cfg = PairConfig(12, 1, 1, pseudoslam=PseudoSlamConfig(range_m=8.0, fov_deg=360.0), max_scans=12,
                     seen_window=(2.0, 8.0, 30.0))
    splits, _ = load_or_build_houseexpo_pairs(shared_data / "houseexpo" / "json.tar.gz", tmp_path, cfg, progress=False)
    m_t, m_T = splits.train.partial, splits.train.target
    unseen_floor = ((m_t == UNKNOWN) & (m_T == FREE)).sum(axis=(1, 2))
    return m_t[np.argsort(-unseen_floor)[:4]]


@pytest.mark.parametrize("name", ["sampler-explore", "sampler-explore-large", "sampler-seen", "sampler-seen-large",
                                  "sampler-seen-wide"])
def test_the_k_samples_differ_where_m_t_is_unknown_and_keep_what_it_observed(
        tiny_splits: PairSplits, shared_data: Path, tmp_path: Path, name: str) -> None:
    # each net on maps of the frame it learnt (see docs/completion.md, "The frame a net learns")
    partial = _seen_frame_maps(shared_data, tmp_path) if "seen" in name else tiny_splits.test.partial[:4]
    s = sample_completions(load_model(name), partial, 4, torch.Generator().manual_seed(0))
    assert s.samples.shape == (4, 4, 64, 64) and not (s.samples == UNKNOWN).any()
    known = np.broadcast_to((partial != UNKNOWN)[:, None], s.samples.shape)
    assert np.array_equal(s.samples[known], np.broadcast_to(partial[:, None], s.samples.shape)[known])
    unknown = ~known[:, 0]
    differ = [(s.samples[i, 0] != s.samples[i, j])[unknown[i]].mean() for i in range(4) for j in range(1, 4)]
    assert min(differ) > 0.01  # no two samples of a map are copies
    assert s.uncertainty[unknown].mean() > 0.05  # the uncertainty panel is not black


def test_a_sample_is_one_house_more_often_than_not(tiny_splits: PairSplits) -> None:
    partial = tiny_splits.test.partial
    s = sample_completions(load_model("sampler"), partial, 4, torch.Generator().manual_seed(1))
    assert np.mean(free_regions(s.samples) == 1) >= 0.5
