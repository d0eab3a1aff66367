"""What every log reader offers: topics, the detected scan and odometry sources, and time-ordered frames."""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections import Counter
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from mcnkit.io.plausible import plausible_frames, without_odometry
from mcnkit.types import Frame, LidarSpec, Trajectory

__all__ = ["GroundTruthMap", "LogReader", "TopicInfo"]


@dataclass(frozen=True)
class TopicInfo:
    """A topic in a log: name, ROS message type (``pkg/msg/Type``) and how many messages it holds."""

    name: str
    msgtype: str
    count: int


@dataclass(frozen=True)
class GroundTruthMap:
    """A ``nav_msgs/OccupancyGrid`` as logged: ROS cell values -1 unknown, 0..100 occupancy, row 0 at the origin."""

    stamp_ns: int
    resolution_m: float
    origin_x_m: float
    origin_y_m: float
    data: np.ndarray  # (height, width) int8


class LogReader(ABC):
    """A robot log opened by :func:`mcnkit.io.open_log`.

    Use it as a context manager.  ``frames()`` yields :class:`~mcnkit.types.Frame` objects in stamp order,
    with the odometry pose of the base interpolated at each scan's stamp.
    """

    path: Path
    format: str
    laser_lines: int | None = None
    """How many laser records the log holds for the scan source, read or not (text logs; None: not counted)."""
    odometry: str = "use"
    """``"use"``: frames carry the log's odometry; ``"ignore"``: read the log as if it had none (every frame's
    motion unknown, its odometry frozen at the origin), so that any log can be run lidar-only."""

    @property
    @abstractmethod
    def topics(self) -> list[TopicInfo]:
        """Every topic with its type and message count."""

    @property
    @abstractmethod
    def scan_topic(self) -> str:
        """The LaserScan topic frames are built from."""

    @property
    @abstractmethod
    def odom_source(self) -> str:
        """Where odometry comes from: an Odometry topic, or ``tf:<odom frame>-><base frame>``."""

    @property
    @abstractmethod
    def lidar_spec(self) -> LidarSpec:
        """The scanner of the scan topic (from its first message), mount offset included."""

    @property
    def compression(self) -> str | None:
        """How the log's container compresses it beyond its own chunks, as ``mcnkit info`` shows it (``"zstd, each
        message (rosbag2)"``, ``"zstd, whole file"``); None: not at all."""
        return None

    @property
    def lidar_only(self) -> bool:
        """True when the frames carry no odometry: the log has none, or it is ignored (``odometry="ignore"``).
        Every frame then says its motion is unknown (``Frame.odom_known`` False) and repeats the origin."""
        return self.odometry == "ignore" or not self.odom_source

    def frames(self) -> Iterator[Frame]:
        """Time-ordered frames: scan, stamp and odometry at that stamp, each one physically plausible.

        Every reader's frames pass through :func:`mcnkit.io.plausible.plausible_frames`: what a robot could not
        have seen is dropped, counted in one warning (with what the reader itself skipped), or the log is refused
        with a :class:`~mcnkit.io.errors.LogError` when nothing usable remains.
        """
        skipped: Counter[str] = Counter()
        frames = self._read_frames(skipped)
        if self.odometry == "ignore":
            frames = without_odometry(frames)
        yield from plausible_frames(self.path, frames, skipped)

    @abstractmethod
    def _read_frames(self, skipped: Counter[str]) -> Iterator[Frame]:
        """The frames as the log holds them; counts what it skips into ``skipped`` (reason -> scans)."""

    @abstractmethod
    def time_range_ns(self) -> tuple[int, int]:
        """First and last message time in the log (ns)."""

    def check_frames(self) -> None:
        """Raises :class:`~mcnkit.io.errors.LogError` now if ``frames()`` cannot start (no usable laser)."""
        self.lidar_spec  # noqa: B018 - raises when there is no usable scan topic

    def ground_truth(self) -> Trajectory | None:
        """The ground-truth trajectory, when the log has one."""
        return None

    def ground_truth_map(self) -> GroundTruthMap | None:
        """The last ground-truth occupancy grid, when the log has one."""
        return None

    def messages(self, topic: str) -> Iterator[tuple[int, Any]]:
        """Decoded messages of any topic as ``(record time ns, message)`` pairs."""
        raise NotImplementedError(f"{type(self).__name__} does not expose raw messages")

    def close(self) -> None:  # noqa: B027 - optional hook
        """Releases open files."""

    def __enter__(self) -> LogReader:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
