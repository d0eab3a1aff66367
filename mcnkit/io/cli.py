"""``mcnkit info`` and ``mcnkit convert``: look inside a robot log, and rewrite it in another format."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from mcnkit.io.content import FORMATS, LogContent
from mcnkit.io.info import describe, print_info

__all__ = ["add_convert_parser", "add_info_parser"]


def _add_source_options(p: argparse.ArgumentParser) -> None:
    p.add_argument("--scan-topic", help="LaserScan topic to use (default: /scan, else the busiest LaserScan topic)")
    p.add_argument("--odom", help="Odometry topic, or tf:ODOM_FRAME->BASE_FRAME (default: detected)")


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
