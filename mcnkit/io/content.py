"""What a writer puts in a log: frames plus the optional ground truth (trajectory and map)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

from mcnkit.io.base import GroundTruthMap
from mcnkit.types import Frame, Trajectory

__all__ = ["BAG_COMPRESSIONS", "FORMATS", "LogContent"]

# Output formats of :func:`mcnkit.io.write_log` and ``mcnkit convert --format``.
FORMATS = ("ros1", "ros2-sqlite3", "ros2-mcap", "mcap")
BAG_COMPRESSIONS = ("file", "message")
"""A rosbag2 folder's own zstd compression (``metadata.yaml``'s ``compression_mode``, any case): each bag file as
a whole, or each message."""


@dataclass(frozen=True)
class LogContent:
    """Everything :func:`mcnkit.io.write_log` writes.

    * ``frames``: one LaserScan on ``scan_topic`` (header stamp = ``stamp_ns``, frame ``laser``, ranges as they
      are: a "no return" stays one), one nav_msgs/Odometry on ``odom_topic`` and one ``odom → base_link``
      transform on ``/tf`` per frame (none with ``odometry`` False); the scanner's mount (``spec.base_to_laser``)
      once on ``/tf_static``.  Any iterable: frames are written as they come (a list, or a reader's ``frames()``).
    * ``ground_truth``: nav_msgs/Odometry poses of the base in the ``map`` frame on ``ground_truth_topic``.
    * ``ground_truth_map``: one nav_msgs/OccupancyGrid on ``map_topic``.
    """

    frames: Iterable[Frame]
    ground_truth: Trajectory | None = None
    ground_truth_map: GroundTruthMap | None = None
    scan_topic: str = "/scan"
    odom_topic: str | None = "/odom"  # None: odometry only as /tf (odom -> base_link)
    odometry: bool = True
    """False: a log without odometry (a lidar-only reading of a log): no Odometry topic, no odom → base on /tf."""
    mount_transform: bool = True
    """False: no ``/tf_static`` (a bag recorded without it: the scanner's mount is not in the log)."""
    ground_truth_topic: str = "/ground_truth"
    map_topic: str = "/map_gt"
