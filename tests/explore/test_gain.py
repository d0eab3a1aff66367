"""The expected information of a viewpoint: ray casting through each sample's walls, cell weights, trade-offs."""

from __future__ import annotations

import numpy as np
import pytest

from mcnkit.explore.config import GainConfig
from mcnkit.explore.gain import (
    beyond_window_gains,
    cell_weights,
    expected_gains,
    finished_pockets,
    sample_walls,
    trade_off,
    visible_gains,
    visible_mask,
)
from mcnkit.types import FREE, OCCUPIED, UNKNOWN


def test_an_open_square_is_seen_whole_and_a_wall_hides_what_is_behind_it() -> None:
    walls = np.zeros((2, 10, 10), bool)
    walls[1, :, 6] = True  # sample 1: a wall at column 6
    gains = visible_gains(walls, np.ones((10, 10)), np.array([[2.5, 5.5]]), n_beams=720, range_cells=30.0)
    assert gains.shape == (1, 2)
    assert gains[0, 0] == 100  # every cell
    assert gains[0, 1] == 70  # columns 0-6: the wall is seen, what lies behind it is not
    mask = visible_mask(walls[1], np.array([2.5, 5.5]), 720, 30.0)
    assert mask[:, :7].all() and not mask[:, 7:].any()


def test_a_slanted_wall_one_cell_thick_hides_what_is_behind_it() -> None:
    walls = np.zeros((1, 40, 40), bool)
    rows = np.arange(40)
    walls[0, rows, 39 - rows] = True  # cells touching only at their corners: a drawn line at 45°
    behind = np.add.outer(rows, rows) > 39  # row + col > 39: the far side of the line
    for origin in ([10.5, 12.5], [3.2, 30.7], [25.9, 1.3]):
        mask = visible_mask(walls[0], np.array(origin), 3600, 80.0)
        assert mask[walls[0]].any() and not mask[behind].any()


def test_range_and_weights_bound_the_gain() -> None:
    walls = np.zeros((1, 21, 21), bool)
    weight = np.zeros((21, 21))
    weight[10, 10:] = 1.0  # the cells right of the origin, one of them per column
    near = visible_gains(walls, weight, np.array([[10.5, 10.5]]), 360, range_cells=4.0)
    assert near[0, 0] == 5  # columns 10-14: within four cells (plus the origin's own)
    assert visible_gains(walls, weight, np.array([[10.5, 10.5]]), 360, 40.0)[0, 0] == 11


def test_cell_weights() -> None:
    partial = np.full((2, 2), UNKNOWN, np.float32)
    partial[0, 0] = FREE
    samples = np.stack([np.full((2, 2), OCCUPIED), np.full((2, 2), FREE)]).astype(np.float32)
    samples[1, 1, 1] = OCCUPIED  # both samples say occupied at (1, 1)
    unknown = cell_weights(samples, partial, 0.25, "unknown")
    np.testing.assert_allclose(unknown, [[0.0, 0.25], [0.25, 0.25]])
    np.testing.assert_allclose(cell_weights(samples, partial, 0.25, "disagreement"), [[0.0, 0.25], [0.25, 0.0]])
    np.testing.assert_array_equal(cell_weights(samples, partial, 0.25, "observed"), unknown)
    assert sample_walls(samples, partial, "unknown").shape == (2, 2, 2)
    assert sample_walls(samples, partial, "observed").sum() == 0  # the map itself holds no wall
    np.testing.assert_array_equal(cell_weights(samples, partial, 0.25, "consensus"), unknown)
    with pytest.raises(ValueError, match="unknown gain"):
        cell_weights(samples, partial, 1.0, "bogus")


def test_trade_offs() -> None:
    gain, cost = np.array([10.0, 10.0, 20.0]), np.array([0.0, 4.0, 9.0])
    np.testing.assert_allclose(trade_off(gain, cost, "ratio", 0.3, 1.0), [10.0, 2.0, 2.0])
    np.testing.assert_allclose(trade_off(gain, cost, "exp", 0.5, 1.0), 10.0 * np.exp(-0.5 * cost) * [1, 1, 2])
    with pytest.raises(ValueError, match="trade-off"):
        trade_off(gain, cost, "bogus", 0.3, 1.0)


def _closet_plan() -> tuple[np.ndarray, np.ndarray]:
    """A 20 × 20 window: the robot's known hall on the left (columns 0-9) and its mapped wall (column 10) with two
    doors; in the one sample a closet (rows 2-5, columns 11-14) behind the door at row 4, and the rest of the house
    behind the door at row 12, running out of the window on the right."""
    partial = np.full((20, 20), UNKNOWN, np.float32)
    partial[:, :10] = FREE
    sample = np.full((20, 20), FREE, np.float32)
    sample[:, 10] = OCCUPIED
    sample[4, 10] = FREE  # the closet's door
    sample[12, 10] = FREE  # the door to the rest of the house
    sample[1, 10:16] = OCCUPIED
    sample[6, 10:16] = OCCUPIED
    sample[1:7, 15] = OCCUPIED  # the closet: rows 2-5, columns 11-14
    partial[:, 10] = sample[:, 10]  # the wall and its two doors are mapped
    return sample[None], partial


def test_a_pocket_a_scan_would_finish_counts_again_and_the_open_house_does_not() -> None:
    sample, partial = _closet_plan()
    at_door = np.array([[10.5, 4.5]])  # in the closet's door
    far = np.array([[1.5, 17.5]])  # across the hall: the closet's door is a slit from there
    bonus = finished_pockets(sample, partial, np.r_[at_door, far], 720, 30.0, 0.25, share=0.9)
    assert bonus.shape == (2, 1)
    assert bonus[0, 0] == pytest.approx(16 * 0.25)  # the closet's 4 × 4 cells, all seen from its door
    assert bonus[1, 0] == 0.0  # too little of it seen from there to be done with it
    # the rest of the house runs out of the window: however much of it a scan sees, it is never finished
    in_house_door = finished_pockets(sample, partial, np.array([[10.5, 12.5]]), 720, 30.0, 0.25, share=0.01)
    assert in_house_door[0, 0] == 0.0
    assert not finished_pockets(sample, partial, at_door, 720, 30.0, 0.25, share=0.0).any()  # 0: no bonus


def test_a_wall_only_one_sample_draws_does_not_hide_the_room_behind_it() -> None:
    samples = np.full((4, 10, 10), FREE, np.float32)
    samples[0, :, 6] = OCCUPIED  # one sample of four walls the room off at column 6
    samples[:3, :, 8] = OCCUPIED  # three of four put a wall at column 8
    partial = np.full((10, 10), UNKNOWN, np.float32)
    walls = sample_walls(samples, partial, "consensus")
    assert walls.shape == (1, 10, 10) and walls[0, :, 8].all() and walls.sum() == 10
    weight = cell_weights(samples, partial, 1.0, "consensus")
    origin = np.array([[2.5, 5.5]])
    seen = visible_gains(walls, weight, origin, 720, 30.0)[0, 0]
    assert seen == 90  # columns 0-8: the lone wall at 6 hides nothing
    each = visible_gains(sample_walls(samples, partial, "unknown"), weight, origin, 720, 30.0)[0]
    np.testing.assert_array_equal(each, [70, 90, 90, 100])  # one sample at a time: one hides columns 7-9


def test_open_counts_the_house_the_samples_draw_but_not_their_inner_walls() -> None:
    samples = np.full((2, 10, 10), FREE, np.float32)
    samples[:, :, 8:] = OCCUPIED  # both samples: the house ends at column 8 (outside is wall)
    samples[0, :, 5] = OCCUPIED  # one sample draws an inner wall at column 5
    partial = np.full((10, 10), UNKNOWN, np.float32)
    walls = sample_walls(samples, partial, "open")
    assert walls.shape == (1, 10, 10) and not walls.any()  # only the map's own walls stop the rays
    weight = cell_weights(samples, partial, 1.0, "open")
    np.testing.assert_allclose(weight[:, [0, 5, 8]], np.tile([1.0, 0.5, 0.0], (10, 1)))  # share of samples free
    seen = visible_gains(walls, weight, np.array([[2.5, 5.5]]), 720, 30.0)[0, 0]
    assert seen == pytest.approx(10 * 7 + 10 * 0.5)  # columns 0-7 behind the one-sample wall; nothing outside


def test_free_counts_the_floor_each_sample_draws_not_its_walls() -> None:
    samples = np.full((2, 10, 10), FREE, np.float32)
    samples[:, :, 8:] = OCCUPIED  # the house ends at column 8
    samples[0, :, 5] = OCCUPIED  # one sample walls the room off at column 5
    partial = np.full((10, 10), UNKNOWN, np.float32)
    partial[:, :2] = FREE  # the robot's side is known already
    origin = np.array([[1.5, 5.5]])
    free = expected_gains(samples, partial, origin, GainConfig(gain="free", beams=720), 30.0, 1.0)[0]
    # sample 0: columns 2-4 (its wall at 5 hides the rest), sample 1: columns 2-7; walls and outside count nothing
    assert free == pytest.approx((10 * 3 + 10 * 6) / 2)
    unknown = expected_gains(samples, partial, origin, GainConfig(gain="unknown", beams=720), 30.0, 1.0)[0]
    assert unknown == pytest.approx((10 * 4 + 10 * 7) / 2)  # the unknown gain counts the wall cells it sees too


def test_a_viewpoint_beyond_the_window_is_worth_the_unknown_it_would_see_there() -> None:
    """A building wider than the completions' window: the window holds its left half.  A viewpoint on the right,
    beside unknown space, is worth what it would see of it, scaled by the share of the unknown area that the
    samples expect to be seen inside the window; one whose scan stays inside the window gets nothing more."""
    outer = np.full((40, 40), FREE, np.float32)
    outer[10:30, 5:16] = UNKNOWN  # unknown space inside the window (columns 0-19) ...
    outer[10:30, 25:36] = UNKNOWN  # ... and beyond it
    outer[:, 38] = OCCUPIED
    inside = np.zeros((40, 40), bool)
    inside[:, :20] = True
    origins = np.array([[10.5, 5.5], [30.5, 5.5]])  # in the window; beyond it
    seen_inside = visible_gains((outer == OCCUPIED)[None], (outer == UNKNOWN) & inside, origins, 720, 12.0)[0, 0]
    half = beyond_window_gains(outer, inside, np.array([seen_inside / 2, 0.0]), origins, 720, 12.0, 1.0)
    assert half[0] == 0.0  # its scan does not reach past column 22
    seen_beyond = visible_gains((outer == OCCUPIED)[None], (outer == UNKNOWN) & ~inside, origins, 720, 12.0)[1, 0]
    assert seen_beyond > 0 and half[1] == pytest.approx(seen_beyond / 2)
    whole = beyond_window_gains(outer, inside, np.array([3 * seen_inside, 0.0]), origins, 720, 12.0, 1.0)
    assert whole[1] == pytest.approx(seen_beyond)  # never more than the map itself says is there
    held = beyond_window_gains(outer, np.ones((40, 40), bool), np.array([5.0, 5.0]), origins, 720, 12.0, 1.0)
    assert not held.any()  # a house the window holds whole: the samples alone
