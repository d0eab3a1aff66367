"""The dense matching window: a speed-up that never changes a match, and never takes unbounded memory."""

import numpy as np

from mcnkit.slam import SlamConfig
from mcnkit.slam.maps import TiledHitMaps
from mcnkit.slam.scanmatch import match_particles
from mcnkit.slam.window import WINDOW_MAX_CELLS, window


def _room_points() -> np.ndarray:
    """End points (M, 2) on the walls of a 6 m x 4 m room seen from its centre, in the room's frame."""
    t = np.linspace(-1.0, 1.0, 60)
    walls = [np.c_[3.0 * t, np.full_like(t, -2.0)], np.c_[3.0 * t, np.full_like(t, 2.0)],
             np.c_[np.full_like(t, -3.0), 2.0 * t], np.c_[np.full_like(t, 3.0), 2.0 * t]]
    return np.concatenate(walls)


def _beams(points: np.ndarray, res: float) -> tuple[np.ndarray, np.ndarray]:
    back = points - np.sqrt(2.0) * res * points / np.linalg.norm(points, axis=1, keepdims=True)
    return points, back


def test_particles_a_kilometre_apart_are_matched_without_a_window_and_as_precisely() -> None:
    # Örebro's log, nearly without odometry, once spread the particles over kilometres: the window's bounding box
    # would have been 24.6 GiB.  Past WINDOW_MAX_CELLS the matcher reads the tile tables alone.
    cfg = SlamConfig(n_particles=2)
    room = _room_points()
    far = np.array([1000.0, 500.0])
    maps = TiledHitMaps(2, cfg.resolution_m, cfg.map.tile_cells)
    maps.integrate(np.stack([room[:, 0], room[:, 0] + far[0]]), np.stack([room[:, 1], room[:, 1] + far[1]]))
    end, back = _beams(room, cfg.resolution_m)
    offset = np.array([0.08, -0.06, 0.03])  # both particles start equally off their room's centre
    poses = np.array([offset, [far[0] + offset[0], far[1] + offset[1], offset[2]]])

    together = match_particles(maps, poses, end, back, cfg).poses
    alone = match_particles(maps, poses[:1], end, back, cfg).poses  # close together: with the window

    assert np.abs(alone[0]).max() < 0.02  # the match finds the room's centre
    np.testing.assert_allclose(together[0], alone[0], atol=1e-9)
    np.testing.assert_allclose(together[1] - [far[0], far[1], 0.0], alone[0], atol=1e-6)
    points = np.array([[0.0, 0.0], far])
    shift = int(np.log2(cfg.map.tile_cells))
    assert window(points, cfg.resolution_m, shift, 1)[0].size == 0  # no window was made
    assert window(points / 100, cfg.resolution_m, shift, 1)[0].size // 2 <= WINDOW_MAX_CELLS
