"""Floor plans as occupancy images: map_server's modes, and what lies outside the building a plan draws on a light
background."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from mcnkit.datasets.images import outside_walls, read_occupancy_image

RES_M = 0.05


def light_plan(door_px: int, wall_px: int = 2) -> np.ndarray:
    """A 30 × 25 m image (free = True) of a 20 × 15 m building on a light background: outer walls ``wall_px``
    thick, one inner wall with a 1 m door, and a ``door_px`` wide opening in the outer wall (0: none)."""
    free = np.ones((500, 600), bool)
    free[100:400, 100:500] = False
    free[100 + wall_px : 400 - wall_px, 100 + wall_px : 500 - wall_px] = True  # the inside
    free[100:400, 300 : 300 + wall_px] = False  # an inner wall ...
    free[240:260, 300 : 300 + wall_px] = True  # ... with a 1 m door
    if door_px:
        free[400 - wall_px : 400, 200 : 200 + door_px] = True  # a door in the outer wall
    return free


def test_the_light_space_around_a_building_is_outside_it() -> None:
    free = light_plan(door_px=0)
    outside = outside_walls(free, RES_M)
    inside = free & ~outside
    assert outside[0, 0] and outside[499, 599] and outside[50, 300]  # the image's margins
    assert inside[250, 200] and inside[250, 400] and inside[250, 301]  # both rooms and the door between them
    assert inside.sum() == free[100:400, 100:500].sum()  # nothing inside the walls is lost


def test_a_door_in_the_outer_wall_does_not_let_the_outside_in() -> None:
    for door_px in (16, 30, 36):  # 0.8, 1.5, 1.8 m
        outside = outside_walls(light_plan(door_px), RES_M)
        inside = light_plan(door_px) & ~outside
        assert outside[450, 215] and inside[250, 200] and inside[250, 400]
        # the doorway is sealed close to the wall: at most a door's half-width of the room behind it is lost
        lost = light_plan(0)[100:400, 100:500].sum() - inside[100:400, 100:500].sum()
        assert lost < door_px * 0.5 / 2 / RES_M


def test_a_gap_wider_than_a_door_joins_the_inside_to_the_outside() -> None:
    outside = outside_walls(light_plan(door_px=60), RES_M)  # 3 m: a wall that is not drawn
    assert outside[250, 200]  # the room it opens is outside ...
    assert not outside[250, 400]  # ... and the one behind that room's door is not


def test_a_map_from_slam_has_nothing_outside() -> None:
    free = np.zeros((200, 300), bool)  # unknown and walls around the seen space
    free[50:150, 50:250] = True
    assert not outside_walls(free, RES_M).any()


def test_a_plan_cropped_through_its_rooms_keeps_everything() -> None:
    free = np.ones((100, 100), bool)  # free space to every edge: no wall says where the inside is
    free[40:60, 20:80] = False
    assert not outside_walls(free, RES_M).any()


def test_a_raw_mode_map_reads_its_values_as_occupancy_in_percent(tmp_path: Path) -> None:
    """nav2's ``mode: raw``: 0 free, 100 occupied, 255 (-1) unknown, no 255-scale."""
    pixels = np.full((10, 12), 255, np.uint8)
    pixels[2:8, 2:10] = 100
    pixels[3:7, 3:9] = 0
    Image.fromarray(pixels).save(tmp_path / "raw.pgm")
    (tmp_path / "raw.yaml").write_text("image: raw.pgm\nresolution: 0.1\norigin: [0, 0, 0]\nmode: raw\n")
    free, grid = read_occupancy_image(tmp_path / "raw.pgm")
    assert grid.resolution_m == 0.1 and free.sum() == 4 * 6 and free[::-1][3:7, 3:9].all()
    (tmp_path / "raw.yaml").write_text("image: raw.pgm\nresolution: 0.1\nmode: bitmap\n")
    with pytest.raises(ValueError, match="unknown mode 'bitmap'"):
        read_occupancy_image(tmp_path / "raw.pgm")


def test_a_rotated_origin_is_read_unrotated_with_a_warning(tmp_path: Path) -> None:
    """map_server's ``origin: [x, y, yaw]``: most ROS tools ignore the yaw, and so does a floor plan here: the
    image's axes are the plan's, placed at ``x, y``."""
    Image.fromarray(np.full((10, 12), 254, np.uint8)).save(tmp_path / "turned.pgm")
    (tmp_path / "turned.yaml").write_text("image: turned.pgm\nresolution: 0.1\norigin: [1.5, -2.0, 0.7854]\n")
    with pytest.warns(UserWarning, match=r"turned.yaml: the origin's yaw \(0.7854 rad\) is ignored"):
        free, grid = read_occupancy_image(tmp_path / "turned.pgm")
    assert free.all() and (grid.width, grid.height) == (12, 10)
    assert (grid.origin_x_m, grid.origin_y_m) == (1.5, -2.0)
