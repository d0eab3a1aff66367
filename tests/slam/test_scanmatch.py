"""The scan matcher's correction kept where the scan pins it down: along a corridor's walls the predicted step
stands, across them and in a room the match corrects as it does without the option."""

import dataclasses

import numpy as np

from mcnkit.slam import SlamConfig
from mcnkit.slam.maps import TiledHitMaps
from mcnkit.slam.scanmatch import match_particles
from tests.slam.test_window import _beams, _room_points


def _corridor_points(seed: int) -> np.ndarray:
    """End points (M, 2) on the two walls of a corridor 3 m wide, 20 m of each, in the corridor's frame: where a
    scan's beams happen to land (uniformly along the walls, 1 cm of range noise across them)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-10.0, 10.0, (2, 400))
    y = np.array([[-1.5], [1.5]]) + rng.normal(0.0, 0.01, (2, 400))
    return np.c_[x.ravel(), y.ravel()]


def _match(map_points: np.ndarray, scan_points: np.ndarray, predicted: np.ndarray, ratio: float) -> np.ndarray:
    cfg = SlamConfig(n_particles=1)
    cfg = dataclasses.replace(cfg, matching=dataclasses.replace(cfg.matching, pinned_ratio=ratio))
    maps = TiledHitMaps(1, cfg.resolution_m, cfg.map.tile_cells)
    maps.integrate(map_points[None, :, 0], map_points[None, :, 1])
    end, back = _beams(scan_points[np.abs(scan_points[:, 0]) < 6.0], cfg.resolution_m)  # it sees 6 m each way
    return match_particles(maps, predicted[None, :], end, back, cfg).poses[0]


def test_in_a_corridor_the_predicted_step_along_it_stands_and_the_walls_correct_the_rest() -> None:
    walls, scan = _corridor_points(0), _corridor_points(1)  # the map's returns and the new scan's: other places
    drift = []
    for along in (0.1, 0.3, -0.2):  # truth: the origin; the prediction off along the walls and across them
        predicted = np.array([along, 0.12, 0.02])
        pinned = _match(walls, scan, predicted, 0.3)
        assert abs(pinned[0] - along) < 0.01  # along the walls nothing pins the pose: the prediction stands
        assert abs(pinned[1]) < 0.02 and abs(pinned[2]) < np.radians(0.5)  # across them and in heading: corrected
        climbed = _match(walls, scan, predicted, 0.0)
        assert abs(climbed[1]) < 0.02  # the same correction across the walls without the option ...
        drift.append(abs(climbed[0] - along))
    assert max(drift) > 0.05  # ... which slides along them on the field's noise


def test_in_a_room_every_direction_is_pinned_and_the_match_is_the_same() -> None:
    predicted = np.array([0.08, -0.06, 0.03])
    room = _room_points()
    pinned, climbed = _match(room, room, predicted, 0.3), _match(room, room, predicted, 0.0)
    assert np.abs(climbed[:2]).max() < 0.02  # the match finds the room's centre
    np.testing.assert_allclose(pinned, climbed, atol=0.01)
