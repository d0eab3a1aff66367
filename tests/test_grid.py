"""The paper's map encodings and the thin-wall-keeping resize."""

import numpy as np
import pytest

from mcnkit.grid import (
    log_odds_to_ternary,
    network_to_ternary,
    pad_to_square,
    probabilities_to_ternary,
    resize_ternary,
    ternary_to_network,
    unknown_mask,
)
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, GridSpec, OccupancyGrid


def test_probabilities_map_to_ternary_by_the_papers_rule():
    p = np.array([[0.0, 0.49, 0.5], [0.51, 1.0, 0.5]])
    assert probabilities_to_ternary(p).tolist() == [[0.0, 0.0, 0.5], [1.0, 1.0, 0.5]]


def test_log_odds_give_the_same_ternary_as_their_probabilities():
    lo = np.random.default_rng(1).normal(0, 2, (16, 16)).astype(np.float32)
    lo[::3, ::2] = 0.0
    grid = OccupancyGrid(GridSpec(0.05, 0, 0, 16, 16), lo)
    assert np.array_equal(log_odds_to_ternary(lo), probabilities_to_ternary(grid.probabilities))


def test_mask_is_one_exactly_where_unknown():
    img = np.array([[FREE, UNKNOWN], [OCCUPIED, UNKNOWN]], np.float32)
    assert unknown_mask(img).tolist() == [[0.0, 1.0], [0.0, 1.0]]


def test_network_round_trip_is_exact_for_ternary_maps():
    img = np.random.default_rng(0).choice([FREE, UNKNOWN, OCCUPIED], size=(2, 64, 64)).astype(np.float32)
    net = ternary_to_network(img)
    assert net.shape == (2, 2, 64, 64)
    assert np.array_equal(network_to_ternary(net), img)


def test_network_output_rule_mask_first_then_image_threshold():
    out = np.array([[[0.7, 0.7, 0.2, 0.5]], [[0.5, 0.49, 0.49, 0.1]]], np.float32)  # (2, 1, 4)
    assert network_to_ternary(out).tolist() == [[UNKNOWN, OCCUPIED, FREE, OCCUPIED]]
    with pytest.raises(ValueError, match="2 channels"):
        network_to_ternary(np.zeros((3, 4, 4)))


def test_shrinking_keeps_a_one_cell_wall():
    img = np.zeros((256, 256), np.float32)
    img[:, 101] = OCCUPIED  # one-cell wall, 1/4 of an output cell wide
    small = resize_ternary(img, 64)
    assert small.shape == (64, 64)
    assert (small[:, 25] == OCCUPIED).all()
    assert (small == OCCUPIED).sum() == 64


def test_shrinking_priority_is_occupied_then_free_then_unknown():
    img = np.full((4, 4), UNKNOWN, np.float32)
    img[0, 0] = FREE  # top-left block: free + unknown -> free
    img[0, 2], img[1, 3] = FREE, OCCUPIED  # top-right block: occupied wins
    assert resize_ternary(img, 2).tolist() == [[FREE, OCCUPIED], [UNKNOWN, UNKNOWN]]


def test_non_integer_factors_and_enlarging():
    img = np.random.default_rng(2).choice([FREE, UNKNOWN, OCCUPIED], size=(100, 70)).astype(np.float32)
    assert resize_ternary(img, (64, 64)).shape == (64, 64)
    big = resize_ternary(np.array([[FREE, OCCUPIED]], np.float32), (2, 4))
    assert big.tolist() == [[FREE, FREE, OCCUPIED, OCCUPIED]] * 2


def test_pad_to_square_centres_the_map():
    img = np.zeros((2, 4), np.float32)
    sq = pad_to_square(img, fill=OCCUPIED)
    assert sq.shape == (4, 4)
    assert sq[0].tolist() == [1.0] * 4 and sq[1].tolist() == [0.0] * 4


def test_continuous_cell_coordinates_agree_with_integer_cells_and_centres():
    spec = GridSpec(0.05, -1.0, 2.0, 40, 30)
    rc = np.array([[0, 0], [7, 12], [29, 39]])
    centres = spec.cell_to_world(rc)
    xy = spec.world_to_cells_xy(centres)
    np.testing.assert_allclose(xy, rc[:, ::-1] + 0.5)  # [x, y] = [col, row] + half a cell
    np.testing.assert_array_equal(np.floor(xy[:, ::-1]).astype(int), spec.world_to_cell(centres))
    np.testing.assert_allclose(spec.world_to_cells_xy(np.array([-1.0, 2.0])), [0.0, 0.0])
