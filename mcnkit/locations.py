"""Where mcnkit finds data: one place, the same rule everywhere — an explicit argument, then an environment
variable, then a documented default relative to the working directory (never to the source tree, so an
installed package finds the same data as a checkout run from its root).

- installed datasets (HouseExpo, pair caches): ``$MCNKIT_DATA``, else ``./data``;
- the shared read-only data (real-lab logs, HouseExpo archive, ROS bags; ``../shared/data`` beside a checkout):
  ``$MCNKIT_SHARED_DATA``, else ``../shared/data``.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["data_dir", "shared_data_dir"]


def data_dir(explicit: str | os.PathLike[str] | None = None) -> Path:
    """Where datasets are installed: ``explicit``, else ``$MCNKIT_DATA``, else ``./data``."""
    return Path(explicit) if explicit else Path(os.environ.get("MCNKIT_DATA") or "data")


def shared_data_dir(explicit: str | os.PathLike[str] | None = None) -> Path:
    """The shared data folder: ``explicit``, else ``$MCNKIT_SHARED_DATA``, else ``../shared/data``."""
    return Path(explicit) if explicit else Path(os.environ.get("MCNKIT_SHARED_DATA") or Path("..", "shared", "data"))
