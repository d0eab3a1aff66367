"""``mcnkit simulate``: a robot with a lidar on a floor plan, written as a log.

The subparser's ``func`` takes the parsed arguments and returns an exit code: 0 on success, 2 with one line on
stderr on bad input.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from typing import Literal

import numpy as np

from mcnkit.app.exits import fail
from mcnkit.app.options import add_options

__all__ = ["SimulateOptions", "add_simulate_parser", "cmd_simulate"]


def cmd_simulate(args: argparse.Namespace) -> int:
    """``mcnkit simulate --map SPEC --out PATH``: simulate a robot on a plan and write the log."""
    from mcnkit.io.errors import LogError
    from mcnkit.sim import LidarConfig, SimConfig, plan_raster, simulate, write_sim_log

    try:
        lidar = LidarConfig(
            n_beams=args.beams,
            fov_deg=args.fov_deg,
            range_max_m=args.range_max,
            noise_std_m=args.range_noise,
            dropout_prob=args.dropout,
        )
        cfg = SimConfig(resolution_m=args.resolution, max_duration_s=args.duration, lidar=lidar)
        if args.odometry_noise != 1.0:
            odo = cfg.odometry
            scaled = {f.name: getattr(odo, f.name) * args.odometry_noise for f in dataclasses.fields(odo)}
            cfg = dataclasses.replace(cfg, odometry=dataclasses.replace(odo, **scaled))
        raster = plan_raster(args.map, args.resolution, args.houseexpo)
        result = simulate(raster, cfg, args.seed)
        path = write_sim_log(result, args.out, args.format, overwrite=args.overwrite)
    except (OSError, ValueError, LogError) as exc:
        return fail("simulate", exc)
    gt = result.ground_truth.poses
    odo_end = result.odometry.poses[-1]
    print(
        f"wrote {path}: {len(result.frames)} scans, {np.hypot(*np.diff(gt[:, :2], axis=0).T).sum():.1f} m driven, "
        f"odometry drift at the end {np.hypot(*(gt[-1, :2] - odo_end[:2])):.2f} m"
    )
    return 0


@dataclass(frozen=True, kw_only=True)
class SimulateOptions:
    """``mcnkit simulate --map SPEC --out PATH``."""

    map: str
    """houseexpo:ID, procedural:SEED or image:FILE (a PNG/PGM occupancy image, dark = wall, light = free; a ROS
    map_server .yaml beside it gives its resolution and origin)"""
    out: str
    """FILE.bag, FILE.mcap or a directory (rosbag2)"""
    format: Literal["ros1", "ros2-sqlite3", "ros2-mcap", "mcap"] | None = None
    """log format (default: from --out: .bag → ros1, .mcap → mcap, a folder → ros2-mcap)"""
    seed: int = 0
    """seed of the robot's path and of the sensor noise"""
    beams: int = 360
    """lidar beams per scan"""
    fov_deg: float = 360.0
    """lidar field of view in degrees"""
    range_max: float = 8.0
    """lidar range in metres"""
    range_noise: float = 0.01
    """range noise std (m)"""
    dropout: float = 0.0
    """probability that a beam returns nothing"""
    odometry_noise: float = 1.0
    """scale of the odometry noise (0 = perfect)"""
    duration: float = 600.0
    """simulated seconds at most"""
    resolution: float = 0.05
    """ground-truth raster resolution (m); for image:FILE without a .yaml, the image's pixel size"""
    houseexpo: str | None = None
    """json.tar.gz or json/ folder (default: the installed one)"""
    overwrite: bool = False
    """replace --out if it exists"""


def add_simulate_parser(subparsers: argparse._SubParsersAction) -> None:
    """Adds ``mcnkit simulate``."""
    p = subparsers.add_parser("simulate", help="simulate a robot with a lidar on a floor plan and write a log")
    add_options(p, SimulateOptions)
    p.set_defaults(func=cmd_simulate)
