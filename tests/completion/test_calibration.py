"""Sampler figures: error, spread, calibration, best-of-K and F of one / the majority of the samples."""

import numpy as np
import pytest

from mcnkit.completion.calibration import majority_labels, score_samples
from mcnkit.completion.scores import score_maps
from mcnkit.types import FREE, OCCUPIED, UNKNOWN


def _problem(n: int = 40, size: int = 16, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.random.Generator]:
    rng = np.random.default_rng(seed)
    target = np.where(rng.random((n, size, size)) < 0.6, FREE, OCCUPIED).astype(np.float32)
    partial = target.copy()
    partial[:, :, size // 2 :] = UNKNOWN
    return partial, target, rng


def test_near_copies_have_no_spread_and_are_badly_calibrated() -> None:
    partial, target, _ = _problem()
    guess = np.where(partial == UNKNOWN, FREE, partial)          # "all free" for every sample
    samples = np.repeat(guess[:, None], 8, axis=1)
    r = score_samples(samples, partial, target)
    assert r.spread == 0.0 and r.spread_over_error == 0.0
    assert r.error == pytest.approx(0.4, abs=0.03)               # 40 % of the hidden cells are occupied
    assert r.ece == pytest.approx(0.4, abs=0.03)                 # says "free" with certainty, right 60 % of the time
    assert r.best_of_k_ratio == pytest.approx(1.0)
    assert r.f_single == pytest.approx(r.f_majority)


def test_a_calibrated_sampler_spreads_as_much_as_it_errs() -> None:
    partial, target, rng = _problem()
    p_free = rng.random(partial.shape)                           # each cell's true probability of being free
    target = np.where(partial == UNKNOWN, np.where(rng.random(partial.shape) < p_free, FREE, OCCUPIED), target)
    k = 32                                                       # enough samples for the share to estimate p_free
    draws = np.where(rng.random((len(partial), k, *partial.shape[1:])) < p_free[:, None], FREE, OCCUPIED)
    samples = np.where(partial[:, None] == UNKNOWN, draws, partial[:, None]).astype(np.float32)
    r = score_samples(samples, partial, target)
    assert r.spread_over_error == pytest.approx(1.0, abs=0.05)
    assert r.ece < 0.05
    occupied_rows = r.reliability[~np.isnan(r.reliability[:, 0])]
    assert occupied_rows[:, 2].sum() == (partial == UNKNOWN).sum()
    assert r.f_best_of_k > r.f_single


def test_majority_and_shape_checks() -> None:
    s = np.array([[[[FREE]], [[OCCUPIED]], [[OCCUPIED]]]], np.float32)   # (1, 3, 1, 1)
    assert majority_labels(s)[0, 0, 0] == OCCUPIED
    partial, target, _ = _problem(n=3)
    with pytest.raises(ValueError, match="shapes"):
        score_samples(np.zeros((3, 16, 16), np.float32), partial, target)
    with pytest.raises(ValueError, match="unknown"):
        score_samples(np.repeat(target[:, None], 2, axis=1), target, target)
    assert score_maps(majority_labels(np.repeat(target[:, None], 2, axis=1)), target, partial).f_measure == 1.0
