"""Structure figures: one free region for a house, and a boundary length that tells blobs and noise apart."""

from __future__ import annotations

import numpy as np

from mcnkit.completion.structure import free_regions, roughness


def _two_rooms(door: bool) -> np.ndarray:
    m = np.ones((12, 20), np.float32)
    m[2:10, 2:9] = 0.0
    m[2:10, 10:18] = 0.0
    if door:
        m[5, 9] = 0.0
    return m


def test_rooms_joined_by_a_door_are_one_region() -> None:
    assert free_regions(np.stack([_two_rooms(True), _two_rooms(False)])).tolist() == [1, 2]


def test_specks_under_four_cells_are_ignored() -> None:
    m = _two_rooms(True)
    m[0, 0] = m[11, 19] = 0.0                     # two single free cells
    assert int(free_regions(m)) == 1
    assert int(free_regions(m, min_cells=1)) == 3


def test_roughness_of_a_square_room_is_four() -> None:
    m = np.ones((10, 10), np.float32)
    m[3:7, 3:7] = 0.0                             # 16 free cells, 16 boundary edges: 16 / √16
    assert float(roughness(m)) == 4.0


def test_noise_is_rougher_than_a_house_and_a_blob_smoother() -> None:
    rng = np.random.default_rng(0)
    house = _two_rooms(True)
    noise = np.where(rng.random(house.shape) < 0.5, 0.0, 1.0).astype(np.float32)
    blob = np.ones_like(house)
    blob[2:10, 2:18] = 0.0                         # the same footprint without the interior wall
    r_house, r_noise, r_blob = roughness(np.stack([house, noise, blob]))
    assert r_blob < r_house < r_noise


def test_a_map_without_free_cells_has_no_roughness() -> None:
    assert np.isnan(roughness(np.ones((4, 4), np.float32)))
