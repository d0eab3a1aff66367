"""Small hand-made plans for the exploration tests."""

from __future__ import annotations

import numpy as np
import pytest

from mcnkit.sim import PlanRaster
from mcnkit.types import GridSpec


def two_rooms() -> PlanRaster:
    """Two rooms, [0, 4) × [0, 3) m and [4.1, 8.1) × [0, 3) m, joined by a 1 m door at y ∈ [1, 2) in the 0.1 m wall
    between them; 1 m of occupied exterior; 0.05 m cells."""
    grid = GridSpec(0.05, -1.0, -1.0, 202, 100)
    free = np.zeros(grid.shape, bool)
    free[20:80, 20:100] = True
    free[20:80, 102:182] = True
    free[40:60, 100:102] = True
    return PlanRaster("two-rooms", free, grid, np.zeros((0, 2)))


@pytest.fixture
def rooms() -> PlanRaster:
    """See :func:`two_rooms`."""
    return two_rooms()
