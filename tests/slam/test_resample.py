"""Weights and resampling on hand-computed cases."""

import math

import numpy as np
import pytest

from mcnkit.slam.resample import effective_sample_size, low_variance_resample, normalize_log_weights


def test_low_variance_resample_places_pointers_in_cumulative_slices() -> None:
    # cumulative weights [0.1, 0.2, 0.6, 1.0]; pointers (0.5 + k) / 4 = 0.125, 0.375, 0.625, 0.875
    w = np.array([0.1, 0.1, 0.4, 0.4])
    assert low_variance_resample(w, u=0.5).tolist() == [1, 2, 3, 3]
    # pointers 0, 0.25, 0.5, 0.75
    assert low_variance_resample(w, u=0.0).tolist() == [0, 2, 2, 3]


def test_low_variance_resample_keeps_uniform_weights_and_accepts_unnormalised() -> None:
    assert low_variance_resample(np.ones(5), u=0.3).tolist() == [0, 1, 2, 3, 4]
    assert low_variance_resample(np.array([0.0, 3.0, 0.0]), u=0.9).tolist() == [1, 1, 1]


def test_low_variance_resample_rejects_bad_input() -> None:
    with pytest.raises(ValueError, match="non-negative"):
        low_variance_resample(np.array([0.5, -0.1]), u=0.1)
    with pytest.raises(ValueError, match="u must be"):
        low_variance_resample(np.array([0.5, 0.5]), u=1.0)


def test_neff_of_uniform_and_degenerate_weights() -> None:
    assert effective_sample_size(np.full(4, 0.25)) == pytest.approx(4.0)
    assert effective_sample_size(np.array([1.0, 0.0, 0.0])) == pytest.approx(1.0)
    # 1 / (0.5² + 0.25² + 0.25²) = 1 / 0.375
    assert effective_sample_size(np.array([0.5, 0.25, 0.25])) == pytest.approx(8 / 3)


def test_normalize_log_weights_with_gmapping_flattening() -> None:
    lw = np.array([0.0, -math.log(3.0)])
    assert normalize_log_weights(lw).tolist() == pytest.approx([0.75, 0.25])
    # gain 1/(ogain·N) = 1/6 flattens a log-weight gap of 6·ln 2 to a factor of 2
    w = normalize_log_weights(np.array([0.0, -6 * math.log(2.0)]), gain=1 / 6)
    assert w.tolist() == pytest.approx([2 / 3, 1 / 3])
    # huge log-weights do not overflow
    assert normalize_log_weights(np.array([1e4, 1e4 - 1.0])).sum() == pytest.approx(1.0)
