"""``mcnkit convert``: rewrite a robot log in another format."""

from __future__ import annotations

import argparse
from pathlib import Path

from mcnkit.app.commands.info import add_source_options
from mcnkit.io.content import FORMATS, LogContent

__all__ = ["add_convert_parser"]


def _convert(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from mcnkit.app.outputs import Output, check_outputs
    from mcnkit.io.open import open_log
    from mcnkit.io.writers import infer_format, write_log

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
    add_source_options(p)
    p.set_defaults(func=_convert)
