"""How large a SLAM map may grow, and the error past it (no numba here: the command line catches it cheaply)."""

from __future__ import annotations

__all__ = ["MAX_TABLE_BYTES", "MapLimitError"]

MAX_TABLE_BYTES = 1 << 30
"""The tile tables of all particles together may take at most this much memory (1 GiB: 30 particles at 5 cm
cells span about 2.3 × 2.3 km).  A log whose path and sensor range need more is refused by :class:`MapLimitError`
instead of growing without bound (readers already drop odometry a robot cannot make)."""


class MapLimitError(ValueError):
    """A map would grow past :data:`MAX_TABLE_BYTES`; the message says how far it would reach."""
