"""Particle hit maps (copy-on-write tiles) and the ray-cast output map on tiny grids."""

import numpy as np
import pytest

from mcnkit.slam.fastslam import counts_to_grid
from mcnkit.slam.maps import TiledHitMaps
from mcnkit.slam.raycast import ray_cast_counts
from mcnkit.types import GridSpec


def test_single_end_point_sets_count_and_mean() -> None:
    maps = TiledHitMaps(n_particles=1, resolution_m=0.1, tile_cells=4)
    maps.integrate(np.array([[0.12]]), np.array([[0.33]]))
    maps.integrate(np.array([[0.18]]), np.array([[0.37]]))  # same cell (1, 3)
    spec, hits, mx, my = maps.dense(0)
    row, col = spec.world_to_cell(np.array([0.15, 0.35]))
    assert hits[row, col] == 2 and hits.sum() == 2
    assert mx[row, col] == pytest.approx(0.15, abs=1e-6)
    assert my[row, col] == pytest.approx(0.35, abs=1e-6)


def test_nan_end_points_are_skipped() -> None:
    maps = TiledHitMaps(n_particles=2, resolution_m=0.1, tile_cells=4)
    maps.integrate(np.array([[np.nan], [0.05]]), np.array([[np.nan], [0.05]]))
    assert maps.dense(0)[1].sum() == 0
    assert maps.dense(1)[1].sum() == 1


def test_resampled_particles_share_tiles_until_one_writes() -> None:
    maps = TiledHitMaps(n_particles=2, resolution_m=0.1, tile_cells=4)
    maps.integrate(np.array([[0.05], [1.05]]), np.array([[0.05], [1.05]]))
    maps.resample(np.array([0, 0]))  # both particles are copies of particle 0
    assert maps.n_tiles_used == 1  # particle 1's old tile is freed, particle 0's is shared
    maps.integrate(np.array([[np.nan], [0.15]]), np.array([[np.nan], [0.05]]))  # particle 1 writes
    assert maps.dense(0)[1].sum() == 1  # particle 0 unchanged
    assert maps.dense(1)[1].sum() == 2
    assert maps.n_tiles_used == 2


def test_ray_cast_single_beam_passes_then_hits() -> None:
    # laser at (0.05, 0.05) facing +x, one 0.4 m beam: passes in 4 cells, a hit in the 5th
    spec, hits, passes = ray_cast_counts(
        np.array([[0.05, 0.05, 0.0]]), np.array([[0.4]]), np.array([0.0]), 10.0, 10.0, 0.1, margin_m=0.0
    )
    assert spec.shape == (1, 5)
    assert passes.tolist() == [[1, 1, 1, 1, 0]]
    assert hits.tolist() == [[0, 0, 0, 0, 1]]


def test_ray_cast_beyond_usable_range_clears_without_hit() -> None:
    _, hits, passes = ray_cast_counts(
        np.array([[0.05, 0.05, 0.0]]), np.array([[0.9]]), np.array([0.0]), 10.0, 0.4, 0.1, margin_m=0.0
    )
    assert hits.sum() == 0 and passes.sum() == 4


def test_counts_to_grid_uses_the_occupancy_threshold() -> None:
    hits = np.array([[0, 1, 1, 0]])
    passes = np.array([[0, 1, 9, 3]])  # unknown, 0.5, 0.1, 0.0
    grid = counts_to_grid(GridSpec(0.1, 0.0, 0.0, 4, 1), hits, passes, occ_thresh=0.25)
    lo = grid.log_odds[0]
    assert lo[0] == 0 and lo[1] > 0 and lo[2] < 0 and lo[3] < 0


def test_the_map_clears_space_only_up_to_the_map_range_and_long_returns_mark_no_hit() -> None:
    from mcnkit.slam import SlamConfig, ray_cast_counts
    from mcnkit.slam.config import MapConfig
    from mcnkit.types import LidarSpec

    one_degree = LidarSpec(-np.pi / 2, np.pi / 180, 181, 0.0, 50.0)
    half_degree = LidarSpec(-np.pi / 2, np.pi / 360, 361, 0.0, 81.9)
    cfg = SlamConfig()
    assert cfg.map_range(one_degree) == pytest.approx(4 * 0.05 / (np.pi / 180))  # 11.5 m: beams 4 cells apart
    assert cfg.map_range(half_degree) == pytest.approx(4 * 0.05 / (np.pi / 360))
    assert SlamConfig(map=MapConfig(range_m=100.0)).map_range(one_degree) == pytest.approx(49.99)  # never beyond the scanner
    # one beam along +x hitting a wall at 30 m, mapped with a 10 m map range: free to 10 m, no hit at 30 m
    spec, hits, passes = ray_cast_counts(np.zeros((1, 3)), np.array([[30.0]]), np.zeros(1), 49.99, 10.0, 0.05)
    row, col = spec.world_to_cell(np.array([9.0, 0.01]))
    assert passes[row, col] == 1 and hits.sum() == 0
    assert spec.origin_x_m + spec.width * spec.resolution_m < 12.0  # the grid stops near the map range
