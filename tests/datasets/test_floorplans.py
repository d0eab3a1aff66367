"""The procedural apartment domain and the HOME'S masking."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from mcnkit.datasets.floorplans import apply_mask, generate_apartment, homes_mask, rasterize_apartment
from mcnkit.types import UNKNOWN


def test_deterministic_per_seed() -> None:
    a, b, c = generate_apartment(5), generate_apartment(5), generate_apartment(6)
    np.testing.assert_array_equal(a.rooms_m, b.rooms_m)
    np.testing.assert_array_equal(a.doors_m, b.doors_m)
    assert a.rooms_m.shape != c.rooms_m.shape or not np.allclose(a.rooms_m, c.rooms_m)


@pytest.mark.parametrize("seed", range(40))
def test_plausible(seed: int) -> None:
    plan = generate_apartment(seed)
    x0, y0, x1, y1 = plan.bbox_m
    assert 7.0 <= x1 - x0 <= 15.0 and 6.0 <= y1 - y0 <= 11.0
    assert len(plan.rooms_m) >= 3 and len(plan.doors_m) >= 2
    free, grid = rasterize_apartment(plan, resolution_m=0.05, border_cells=4)
    share = free.mean()
    assert 0.4 < share < 0.95
    # Doors connect every room: the free space is one connected region.
    _, n = ndimage.label(free)
    assert n == 1
    # Every room centre is free and rooms (corridors included) are at least 0.95 m wide.
    rc = grid.world_to_cell(plan.room_centres_m)
    assert free[rc[:, 0], rc[:, 1]].all()
    assert np.all(plan.rooms_m[:, 2:] - plan.rooms_m[:, :2] >= 0.95)
    # Interior walls exist: the free space is not just the footprint.
    assert free.sum() * 0.05**2 < 0.99 * (x1 - x0) * (y1 - y0)


def test_varied_shapes() -> None:
    plans = [generate_apartment(s) for s in range(60)]
    sizes = np.array([p.bbox_m[2] * p.bbox_m[3] for p in plans])
    rooms = np.array([len(p.rooms_m) for p in plans])
    assert sizes.std() > 10.0 and rooms.min() < rooms.max()
    assert any(len(p.chamfers) for p in plans)


@pytest.mark.parametrize("seed", range(30))
def test_homes_mask_fraction(seed: int) -> None:
    mask = homes_mask((64, 64), np.random.default_rng(seed))
    assert 0.1 <= mask.mean() <= 0.53
    target = np.zeros((64, 64), np.float32)
    masked = apply_mask(target, mask)
    assert np.all(masked[mask] == UNKNOWN) and np.all(masked[~mask] == 0.0)
