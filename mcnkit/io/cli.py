"""``mcnkit info`` and ``mcnkit convert``: look inside a robot log, and rewrite it in another format."""

from __future__ import annotations

import argparse
import json
import math
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mcnkit.io.content import FORMATS, LogContent

if TYPE_CHECKING:
    from mcnkit.io.base import LogReader

__all__ = ["add_convert_parser", "add_info_parser", "describe", "print_info"]


def _add_source_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scan-topic", help="LaserScan topic to use (default: /scan, else the busiest LaserScan topic)")
    p.add_argument("--odom", help="Odometry topic, or tf:ODOM_FRAME->BASE_FRAME (default: detected)")


def describe(log: LogReader) -> dict[str, object]:
    """Everything ``mcnkit info`` prints, as a JSON-ready dict."""
    start, end = log.time_range_ns()
    info: dict[str, object] = {
        "path": str(log.path),
        "format": log.format,
        "start_ns": start,
        "end_ns": end,
        "duration_s": round((end - start) / 1e9, 3),
        "topics": [{"name": t.name, "type": t.msgtype, "count": t.count} for t in log.topics],
        "scan_topic": log.scan_topic or None,
        "odom_source": log.odom_source or None,
    }
    if log.scan_topic:
        spec = log.lidar_spec
        info["scans"] = next((t.count for t in log.topics if t.name == log.scan_topic), 0)
        if log.laser_lines is not None:
            info["laser_lines"] = log.laser_lines
        info["scanner"] = {
            "beams": spec.n_beams,
            "fov_deg": round(math.degrees(spec.fov_rad), 3),
            "angle_min_deg": round(math.degrees(spec.angle_min_rad), 3),
            "angle_increment_deg": round(math.degrees(spec.angle_increment_rad), 4),
            "range_min_m": round(spec.range_min_m, 3),
            "range_max_m": round(spec.range_max_m, 3),
            "base_to_laser": [spec.base_to_laser.x_m, spec.base_to_laser.y_m, spec.base_to_laser.yaw_rad],
        }
    return info


def _stamp_text(ns: int) -> str:
    if ns > 10**17:  # absolute (epoch) time
        return datetime.fromtimestamp(ns / 1e9, tz=UTC).isoformat(timespec="milliseconds")
    return f"{ns / 1e9:.3f} s (relative)"


def print_info(info: dict[str, Any]) -> None:
    """Prints :func:`describe`'s dict as ``mcnkit info`` shows it."""
    print(f"file      {info['path']}")
    print(f"format    {info['format']}")
    print(f"start     {_stamp_text(info['start_ns'])}")
    print(f"end       {_stamp_text(info['end_ns'])}")
    print(f"duration  {info['duration_s']:.3f} s")
    print("topics")
    width = max([len(t["name"]) for t in info["topics"]] + [5])
    for t in info["topics"]:
        print(f"  {t['name']:<{width}}  {t['count']:>7}  {t['type']}")
    print(f"scan      {info['scan_topic'] or 'none (no sensor_msgs/LaserScan topic)'}")
    print(f"odometry  {info['odom_source'] or 'none (no Odometry topic, no odom->base transform)'}")
    if "scanner" in info:
        s = info["scanner"]
        read = f" (read from {info['laser_lines']} laser lines)" if "laser_lines" in info else ""
        print(f"scanner   {info['scans']} scans{read} of {s['beams']} beams, field of view {s['fov_deg']}° "
              f"(from {s['angle_min_deg']}° in {s['angle_increment_deg']}° steps), "
              f"range {s['range_min_m']}–{s['range_max_m']} m, mount {s['base_to_laser']}")


def _info(args: argparse.Namespace) -> int:
    from mcnkit.io.open import open_log

    with open_log(args.log, scan_topic=args.scan_topic, odom=args.odom) as log:
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
        description="Show a log's format, time span, topics (type and count), the detected scan and odometry "
        "sources, and the scanner (beams, field of view, range). Reads ROS1 .bag, ROS2 bag folders "
        "(sqlite3/mcap), .mcap (ROS1 or ROS2 profile) and CARMEN/DP-SLAM logs.",
    )
    p.add_argument("log", type=Path, help="a log file or a ROS2 bag folder")
    _add_source_options(p)
    p.add_argument("--json", action="store_true", help="print JSON instead of text")
    p.set_defaults(func=_info)


def _convert(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from mcnkit.io.open import open_log
    from mcnkit.io.writers import infer_format, write_log
    from mcnkit.outputs import Output, check_outputs

    check_outputs([args.input], [Output(args.output, folder=None)], overwrite=args.overwrite)
    with open_log(args.input, scan_topic=args.scan_topic, odom=args.odom) as log:
        log.check_frames()
        total = next((t.count for t in log.topics if t.name == log.scan_topic), None)
        frames = list(tqdm(log.frames(), total=total, unit="scan", desc="reading", disable=args.quiet))
        content = LogContent(frames, ground_truth=log.ground_truth(), ground_truth_map=log.ground_truth_map())
    fmt = args.format or infer_format(args.output)
    out = write_log(args.output, content, fmt, overwrite=args.overwrite)
    extra = " + ground truth" if content.ground_truth is not None else ""
    print(f"wrote {out} ({fmt}): {len(frames)} scans with odometry, /tf, /tf_static{extra}")
    return 0


def add_convert_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Registers ``mcnkit convert``."""
    p = sub.add_parser(
        "convert", help="rewrite a log as ROS1 bag, ROS2 bag (sqlite3/mcap) or MCAP",
        description="Read frames (LaserScan + odometry), the ground-truth trajectory and map when present, and "
        "write them as LaserScan, Odometry, /tf, /tf_static (+ ground truth). Lossless: read back, the frames "
        "are identical (float32 ranges, nanosecond stamps).",
    )
    p.add_argument("input", type=Path, help="any log open_log reads")
    p.add_argument("output", type=Path, help="output file (.bag, .mcap) or folder (ROS2 bag)")
    p.add_argument("--format", choices=[*FORMATS, "mcap-ros1"],
                   help="output format (default from OUTPUT: .bag → ros1, .mcap → mcap, else ros2-mcap)")
    p.add_argument("--overwrite", action="store_true", help="replace OUTPUT if it exists")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_source_options(p)
    p.set_defaults(func=_convert)
