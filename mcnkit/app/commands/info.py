"""``mcnkit info``: look inside a robot log."""

from __future__ import annotations

import argparse
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from mcnkit.app.options import add_options
from mcnkit.io.info import describe, print_info

__all__ = ["InfoOptions", "SourceOptions", "TopicOptions", "add_info_parser"]


@dataclass(frozen=True, kw_only=True)
class TopicOptions:
    """Which topics of a bag to read (a log with several scanners or odometry sources)."""

    scan_topic: str | None = None
    """scan topic to read (default: /scan, else the busiest LaserScan topic, else the busiest MultiEchoLaserScan
    topic, read as its first echoes)"""
    odom: str | None = None
    """Odometry topic, or tf:ODOM_FRAME->BASE_FRAME (default: detected)"""


@dataclass(frozen=True, kw_only=True)
class SourceOptions(TopicOptions):
    """Which streams of a log to read."""

    odometry: Literal["use", "ignore"] = "use"
    """use the log's odometry, or ignore it: read the log lidar-only, as a log without odometry is read"""


@dataclass(frozen=True, kw_only=True)
class InfoOptions(SourceOptions):
    """``mcnkit info LOG [--json]``."""

    log: Path
    """a log file or a ROS2 bag folder"""
    json: bool = False
    """print JSON instead of text"""


def _info(args: argparse.Namespace) -> int:
    from mcnkit.io.open import open_log

    with open_log(args.log, scan_topic=args.scan_topic, odom=args.odom, odometry=args.odometry) as log:
        info = describe(log)
    if args.json:
        print(json.dumps(info, indent=2))
    else:
        print_info(info)
    return 0


def add_info_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Registers ``mcnkit info``."""
    p = sub.add_parser(
        "info", help="show what a robot log holds",
        description="Show a log's format and compression, time span, topics (type and count), the detected scan and "
        "odometry sources, and the scanner (beams, field of view, range). Reads ROS1 .bag, ROS2 bag folders "
        "(sqlite3/mcap, compressed by rosbag2 or not), .mcap (ROS1 or ROS2 profile) and CARMEN/DP-SLAM logs.",
    )
    add_options(p, InfoOptions, positional=("log",))
    p.set_defaults(func=_info)
