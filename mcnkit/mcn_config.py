"""MCN-SLAM's settings (:class:`McnConfig`), apart from :mod:`mcnkit.mcn` so that the command line can generate
its ``--mcn.FIELD`` flags without importing torch."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["McnConfig"]


@dataclass(frozen=True)
class McnConfig:
    """How MCN-SLAM completes maps (the SLAM itself is configured by :class:`~mcnkit.slam.SlamConfig`)."""

    samples: int = 4
    """K completions per particle."""
    ranks: int = 3
    """R best particles completed at each filter update."""
    window: Literal["map", "robot"] = "map"
    """``"map"``: the whole map seen so far shrunk to ``size``² (the paper); ``"robot"``: a robot-centred square."""
    window_m: float = 12.8
    """Side of the robot-centred window [m]."""
    size: int = 64
    """Cells per side of the network's window (divisible by 2^depth of the network)."""
    margin_m: float = 0.0
    """Border around the seen map in the ``"map"`` window [m] (0: the map's own extent, as the training maps)."""
    every: int = 1
    """Complete at every ``every``-th filter update."""
    full_map_every: int = 1
    """Put the best particle's full-resolution map in every ``full_map_every``-th completed step (0: never)."""
    full_map_max_cells: int = 600_000
    """Larger maps come in ``StepResult.best_map`` pooled by a whole factor (walls kept) to at most this many cells."""
    completion_weight: float = 0.0
    """> 0: weight particles by how well the scan fits their completed map in unknown cells (see module doc)."""
    hit_epsilon: float = 0.1
    """Floor of the per-beam likelihood of the completion weighting."""

    def __post_init__(self) -> None:
        for name, least in (("samples", 1), ("ranks", 1), ("every", 1), ("size", 4)):
            if getattr(self, name) < least:
                raise ValueError(f"{name} must be >= {least}, got {getattr(self, name)}")
        if self.window not in ("map", "robot"):
            raise ValueError(f"window must be 'map' or 'robot', got {self.window!r}")
