"""Robot logs in, robot logs out: :func:`open_log` reads every supported format, :func:`write_log` writes them."""

from mcnkit.io.base import GroundTruthMap, LogReader, TopicInfo
from mcnkit.io.carmen import CarmenLog
from mcnkit.io.content import FORMATS, LogContent
from mcnkit.io.errors import LogError, LogWarning
from mcnkit.io.open import open_log
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
    "open_log",
    "write_log",
]
