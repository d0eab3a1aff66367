"""The completions' window during exploration, and K completions that keep the known cells."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from mcnkit.completion.nets import UNet, UNetConfig
from mcnkit.explore.config import GainConfig
from mcnkit.explore.predict import choose_window, complete_on
from mcnkit.types import FREE, OCCUPIED, UNKNOWN


@pytest.mark.parametrize(("bounds", "margin", "side"), [((0.0, 0.0, 10.0, 6.0), 2.0, 14.0),
                                                         ((1.0, 1.0, 3.0, 2.0), 1.0, 8.0)])
def test_window_is_the_seen_bounds_plus_margin_padded_square(bounds: tuple[float, float, float, float],
                                                             margin: float, side: float) -> None:
    w = choose_window(bounds, GainConfig(window_margin_m=margin, window_min_m=8.0), 64, 0.05)
    assert w.width == w.height == 64
    assert w.resolution_m * 64 == pytest.approx(side)
    x0, y0, x1, y1 = bounds
    assert w.origin_x_m + 32 * w.resolution_m == pytest.approx((x0 + x1) / 2)
    assert w.origin_y_m + 32 * w.resolution_m == pytest.approx((y0 + y1) / 2)


def test_completions_keep_the_known_cells() -> None:
    net = UNet(UNetConfig(base_channels=4, depth=2, dropout=0.5)).eval()
    partial = np.full((16, 16), UNKNOWN, np.float32)
    partial[4:8, 4:8] = FREE
    partial[3, 3:9] = OCCUPIED
    samples, mean = complete_on(net, partial, 3, torch.Generator().manual_seed(0))
    assert samples.shape == (3, 16, 16) and mean.shape == (16, 16)
    known = partial != UNKNOWN
    assert (samples[:, known] == partial[known]).all() and (mean[known] == partial[known]).all()
    assert set(np.unique(samples)) <= {FREE, UNKNOWN, OCCUPIED}


def test_a_building_wider_than_the_largest_window_is_completed_around_the_robot() -> None:
    cfg = GainConfig(window_margin_m=2.0, window_max_m=20.0)
    w = choose_window((0.0, 0.0, 50.0, 10.0), cfg, 64, 0.05, np.array([30.0, 4.0]))
    assert w.resolution_m * 64 == pytest.approx(20.0)
    assert w.origin_x_m == pytest.approx(20.0) and w.origin_y_m == pytest.approx(-6.0)
    with pytest.raises(ValueError, match="window_min_m"):
        GainConfig(window_min_m=40.0, window_max_m=30.0)
