"""``mcnkit convert``: rewrite a robot log in another format."""

from __future__ import annotations

import argparse
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from mcnkit.app.commands.info import SourceOptions
from mcnkit.app.options import add_options
from mcnkit.io.content import BAG_COMPRESSIONS, FORMATS, LogContent

if TYPE_CHECKING:
    from mcnkit.types import Frame

__all__ = ["ConvertOptions", "add_convert_parser"]


@dataclass(frozen=True, kw_only=True)
class ConvertOptions(SourceOptions):
    """``mcnkit convert INPUT OUTPUT [--format F]``."""

    input: Path
    """any log open_log reads"""
    output: Path
    """output file (.bag, .mcap) or folder (ROS2 bag)"""
    format: str | None = None
    """output format (default from OUTPUT: .bag → ros1, .mcap → mcap, else ros2-mcap)"""
    compression: str | None = None
    """a ROS2 bag folder's own zstd compression, of each bag file (file) or of each message (message), as ros2 bag
    record --compression-mode writes it (default none)"""
    overwrite: bool = False
    """replace OUTPUT if it exists"""
    quiet: bool = False
    """no progress bar"""


def _convert(args: argparse.Namespace) -> int:
    from tqdm import tqdm

    from mcnkit.app.outputs import Output, check_outputs
    from mcnkit.io.open import open_log
    from mcnkit.io.writers import infer_format, write_log

    check_outputs([args.input], [Output(args.output, folder=None)], overwrite=args.overwrite)
    fmt = args.format or infer_format(args.output)
    with open_log(args.input, scan_topic=args.scan_topic, odom=args.odom, odometry=args.odometry) as log:
        log.check_frames()
        total = next((t.count for t in log.topics if t.name == log.scan_topic), None)
        written = 0

        def frames() -> Iterator[Frame]:  # streamed to the writer: a log of any length in the memory of one chunk
            nonlocal written
            for frame in tqdm(log.frames(), total=total, unit="scan", desc="converting", disable=args.quiet):
                written += 1
                yield frame

        content = LogContent(frames(), ground_truth=log.ground_truth(), ground_truth_map=log.ground_truth_map(),
                             odometry=not log.lidar_only)
        out = write_log(args.output, content, fmt, overwrite=args.overwrite, compression=args.compression)
    extra = " + ground truth" if content.ground_truth is not None else ""
    odometry = "with odometry, /tf" if content.odometry else "without odometry (lidar-only)"
    packed = f", {args.compression}-compressed" if args.compression else ""
    print(f"wrote {out} ({fmt}{packed}): {written} scans {odometry}, /tf_static{extra}")
    return 0


def add_convert_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Registers ``mcnkit convert``."""
    p = sub.add_parser(
        "convert", help="rewrite a log as ROS1 bag, ROS2 bag (sqlite3/mcap) or MCAP",
        description="Read frames (LaserScan + odometry), the ground-truth trajectory and map when present, and "
        "write them as LaserScan, Odometry, /tf, /tf_static (+ ground truth). Lossless: read back, the frames "
        "are identical (float32 ranges, nanosecond stamps).",
    )
    add_options(p, ConvertOptions, positional=("input", "output"), choices={"format": (*FORMATS, "mcap-ros1"),
                                                                        "compression": BAG_COMPRESSIONS})
    p.set_defaults(func=_convert)
