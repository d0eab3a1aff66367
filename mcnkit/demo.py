"""``mcnkit demo``: the whole pipeline that exists, on embedded data (no download).

1. simulate a robot exploring a procedurally generated apartment (lidar + drifting odometry + ground truth);
2. write it as a ROS2-profile MCAP log and show ``mcnkit info`` of it;
3. run grid FastSLAM on the log and write the trajectory, the map and a summary;
4. score the SLAM trajectory and the raw odometry against the ground truth (ATE).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from mcnkit.io import open_log
from mcnkit.io.cli import _print_info, describe
from mcnkit.metrics import absolute_trajectory_error, read_tum
from mcnkit.sim import SimConfig, plan_raster, simulate, write_sim_log
from mcnkit.slam.cli import run_slam

__all__ = ["add_demo_parser", "run_demo"]


def run_demo(args: argparse.Namespace) -> int:
    """Runs the demo into ``args.out``."""
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    print(f"[1/4] simulating a robot in procedural apartment #{args.apartment} (seed {args.seed})")
    raster = plan_raster(f"procedural:{args.apartment}", 0.05, None)
    result = simulate(raster, SimConfig(max_duration_s=args.duration_s), args.seed)
    log_path = write_sim_log(result, out / "apartment.mcap", "mcap", overwrite=True)
    print(f"[2/4] wrote {log_path}")
    with open_log(log_path) as log:
        _print_info(describe(log))
    print("[3/4] grid FastSLAM")
    slam_out = out / "slam"
    code = run_slam(argparse.Namespace(log=log_path, particles=args.particles, resolution=0.05, seed=args.seed,
                                       out=slam_out, no_progress=False))
    if code:
        return code
    truth = result.ground_truth
    ate_slam = absolute_trajectory_error(read_tum(slam_out / "trajectory.tum"), truth)
    ate_odom = absolute_trajectory_error(result.odometry, truth)
    report: dict[str, Any] = {"scans": len(result.frames), "ate_slam_m": ate_slam.rmse_m,
                              "ate_odometry_m": ate_odom.rmse_m}
    (out / "demo.json").write_text(json.dumps(report, indent=2) + "\n")
    print(f"[4/4] trajectory error against ground truth (ATE RMSE): SLAM {ate_slam.rmse_m:.3f} m, "
          f"odometry alone {ate_odom.rmse_m:.3f} m")
    print(f"map: {slam_out / 'map.png'}   trajectory: {slam_out / 'trajectory.tum'}   log: {log_path}")
    return 0


def add_demo_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Registers ``mcnkit demo``."""
    p = sub.add_parser("demo", help="simulate an apartment, read the log, run SLAM on it (no dataset needed)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=Path("recordings/demo"), help="output folder (default recordings/demo)")
    p.add_argument("--apartment", type=int, default=3, help="procedural apartment number (default 3)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the robot run and the filter")
    p.add_argument("--particles", type=int, default=30, help="SLAM particles (default 30)")
    p.add_argument("--duration-s", type=float, default=120.0, help="simulated seconds at most (default 120)")
    p.set_defaults(func=run_demo)
