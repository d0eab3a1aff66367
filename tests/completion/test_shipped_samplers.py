"""The shipped masked samplers: loaded by name, the default of MCN-SLAM, and K different whole maps that keep m_t."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcnkit.completion.nets import MaskedSampler
from mcnkit.completion.registry import DEFAULT_MODEL
from mcnkit.completion.sample import sample_completions
from mcnkit.completion.structure import free_regions
from mcnkit.datasets import PairSplits
from mcnkit.mcn import load_model
from mcnkit.types import UNKNOWN


def test_mcn_slam_samples_from_a_shipped_sampler_by_default() -> None:
    assert DEFAULT_MODEL == "sampler-explore"
    for name in ("sampler", "sampler-explore", "sampler-explore-large"):
        assert isinstance(load_model(name), MaskedSampler)


@pytest.mark.parametrize("name", ["sampler-explore", "sampler-explore-large"])
def test_the_k_samples_differ_where_m_t_is_unknown_and_keep_what_it_observed(tiny_splits: PairSplits, name: str) -> None:
    partial = tiny_splits.test.partial[:4]
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
