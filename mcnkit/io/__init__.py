"""Robot logs in, robot logs out: :func:`open_log` reads every supported format, :func:`write_log` writes them.

The names below are imported on first use (``import mcnkit.io.errors`` alone stays light)."""

from typing import TYPE_CHECKING

from mcnkit._lazy import lazy_exports

if TYPE_CHECKING:
    from mcnkit.io.base import GroundTruthMap, LogReader, TopicInfo
    from mcnkit.io.carmen import CarmenLog
    from mcnkit.io.content import FORMATS, LogContent
    from mcnkit.io.errors import LogError, LogWarning
    from mcnkit.io.open import looks_like_log, open_log
    from mcnkit.io.writers import infer_format, write_log

__all__ = [
    "FORMATS",
    "CarmenLog",
    "GroundTruthMap",
    "LogContent",
    "LogError",
    "LogReader",
    "LogWarning",
    "TopicInfo",
    "infer_format",
    "looks_like_log",
    "open_log",
    "write_log",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "mcnkit.io.base": ("GroundTruthMap", "LogReader", "TopicInfo"),
    "mcnkit.io.carmen": ("CarmenLog",),
    "mcnkit.io.content": ("FORMATS", "LogContent"),
    "mcnkit.io.errors": ("LogError", "LogWarning"),
    "mcnkit.io.open": ("looks_like_log", "open_log"),
    "mcnkit.io.writers": ("infer_format", "write_log"),
})
