"""``mcnkit simulate``: a robot with a lidar on a floor plan, written as a log.

The subparser's ``func`` takes the parsed arguments and returns an exit code: 0 on success, 2 with one line on
stderr on bad input.
"""

from __future__ import annotations

import argparse
import dataclasses

import numpy as np

from mcnkit.app.exits import fail

__all__ = ["add_simulate_parser", "cmd_simulate"]


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


def add_simulate_parser(subparsers: argparse._SubParsersAction) -> None:
    """Adds ``mcnkit simulate``."""
    p = subparsers.add_parser("simulate", help="simulate a robot with a lidar on a floor plan and write a log")
    p.add_argument("--map", required=True, help="houseexpo:ID or procedural:SEED")
    p.add_argument("--out", required=True, help="FILE.bag, FILE.mcap or a directory (rosbag2)")
    p.add_argument("--format", choices=["ros1", "ros2-sqlite3", "ros2-mcap", "mcap"],
                   help="log format (default: from --out: .bag → ros1, .mcap → mcap, a folder → ros2-mcap)")
    p.add_argument("--seed", type=int, default=0, help="seed of the robot's path and of the sensor noise (default 0)")
    p.add_argument("--beams", type=int, default=360, help="lidar beams per scan (default 360)")
    p.add_argument("--fov-deg", type=float, default=360.0, help="lidar field of view in degrees (default 360)")
    p.add_argument("--range-max", type=float, default=8.0, help="lidar range in metres (default 8)")
    p.add_argument("--range-noise", type=float, default=0.01, help="range noise std (m)")
    p.add_argument("--dropout", type=float, default=0.0, help="probability that a beam returns nothing")
    p.add_argument("--odometry-noise", type=float, default=1.0, help="scale of the odometry noise (0 = perfect)")
    p.add_argument("--duration", type=float, default=600.0, help="simulated seconds at most (default 600)")
    p.add_argument("--resolution", type=float, default=0.05, help="ground-truth raster resolution (m)")
    p.add_argument("--houseexpo", help="json.tar.gz or json/ folder (default: the installed one)")
    p.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    p.set_defaults(func=cmd_simulate)
