"""Coverage: what a scan from a pose sees on the ground truth, and the reachable free space."""

from __future__ import annotations

import numpy as np

from mcnkit.explore.coverage import mark_seen, reachable_free
from mcnkit.sim import PlanRaster, SimConfig, safe_region


def test_a_scan_sees_its_room_and_through_the_door(rooms: PlanRaster) -> None:
    seen = np.zeros_like(rooms.free)
    mark_seen(rooms.free, rooms.grid, seen, np.array([[2.0, 1.5]]), range_m=20.0, rays=1440)
    assert seen[20:80, 20:100].all()  # the whole first room
    assert not (seen & ~rooms.free).any()
    right = seen[20:80, 102:182]
    assert 0 < right.sum() < right.size  # part of the second room, through the door
    short = np.zeros_like(rooms.free)
    mark_seen(rooms.free, rooms.grid, short, np.array([[2.0, 1.5]]), range_m=1.0, rays=1440)
    rc = np.argwhere(short)
    assert np.hypot(*(rooms.grid.cell_to_world(rc) - [2.0, 1.5]).T).max() <= 1.0 + 0.05


def test_reachable_free_space_leaves_out_a_sealed_room(rooms: PlanRaster) -> None:
    free = rooms.free.copy()
    free[40:60, 100:102] = False  # close the door
    sealed = PlanRaster("sealed", free, rooms.grid, rooms.goals_m)
    safe, _ = safe_region(sealed, SimConfig())
    reach = reachable_free(sealed, safe, np.array([2.0, 1.5]), 8.0, 720, 0.5)
    assert reach[20:80, 20:100].all() and not reach[:, 100:].any()
    safe, _ = safe_region(rooms, SimConfig())
    assert reachable_free(rooms, safe, np.array([2.0, 1.5]), 8.0, 720, 0.5).sum() == rooms.free.sum()
