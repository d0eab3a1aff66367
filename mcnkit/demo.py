"""``mcnkit demo``: the whole pipeline that exists, on embedded data (no download).

1. simulate a robot exploring a procedurally generated apartment (lidar + drifting odometry + ground truth);
2. write it as a ROS2-profile MCAP log and show ``mcnkit info`` of it;
3. run grid FastSLAM on the log, recording every step to a Rerun file (``demo.rrd``), and write the
   trajectory (TUM) and the map (PGM/YAML/PNG);
4. score the SLAM trajectory and the raw odometry against the ground truth (ATE).
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from tqdm import tqdm

from mcnkit.io import open_log
from mcnkit.io.cli import describe, print_info
from mcnkit.metrics import absolute_trajectory_error, write_tum
from mcnkit.sim import SimConfig, plan_raster, simulate, write_sim_log
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.slam.cli import write_map
from mcnkit.types import TernaryMap
from mcnkit.viz import RerunLogger

__all__ = ["DemoResult", "add_demo_parser", "run_demo"]


@dataclass(frozen=True)
class DemoResult:
    """Where the demo wrote its files and how well SLAM did."""

    log_path: Path
    rrd_path: Path
    map_png: Path
    scans: int
    ate_slam_m: float
    ate_odometry_m: float
    wall_s: float


def run_demo(out: Path, rrd: Path, *, apartment: int = 3, seed: int = 0, particles: int = 30,
             duration_s: float = 120.0, progress: bool = True) -> DemoResult:
    """Simulates, records and scores one run (see the module docstring)."""
    t0 = time.perf_counter()
    out.mkdir(parents=True, exist_ok=True)
    print(f"[1/4] simulating a robot in procedural apartment #{apartment} (seed {seed})")
    raster = plan_raster(f"procedural:{apartment}", 0.05, None)
    sim = simulate(raster, SimConfig(max_duration_s=duration_s), seed)
    log_path = write_sim_log(sim, out / "apartment.mcap", "mcap", overwrite=True)
    print(f"[2/4] wrote {log_path}")
    with open_log(log_path) as log:
        print_info(describe(log))
        frames = list(log.frames())
    print(f"[3/4] grid FastSLAM with {particles} particles, recording every step to {rrd}")
    slam = FastSlam(SlamConfig(n_particles=particles), np.random.default_rng(seed))
    with RerunLogger(rrd, recording_id=f"demo-apartment{apartment}-seed{seed}") as viz:
        viz.log_ground_truth(TernaryMap(np.where(raster.free, 0.0, 1.0).astype(np.float32), raster.grid))
        for frame in tqdm(frames, unit="scan", disable=not progress):
            step = slam.step(frame)
            viz.log_slam_step(frame, step, slam.trajectory().poses[:, :2] if step.updated else None)
            if step.updated:
                viz.log_map("/world/map/estimate", slam.best_ternary(), mask=True)
    write_tum(out / "trajectory.tum", slam.trajectory())
    write_map(slam.best_map(), out)
    ate_slam = absolute_trajectory_error(slam.trajectory(), sim.ground_truth)
    ate_odom = absolute_trajectory_error(sim.odometry, sim.ground_truth)
    result = DemoResult(log_path, rrd, out / "map.png", len(frames), ate_slam.rmse_m, ate_odom.rmse_m,
                        time.perf_counter() - t0)
    (out / "demo.json").write_text(json.dumps({k: str(v) if isinstance(v, Path) else v
                                               for k, v in result.__dict__.items()}, indent=2) + "\n")
    print(f"[4/4] trajectory error against ground truth (ATE RMSE): SLAM {ate_slam.rmse_m:.3f} m, "
          f"odometry alone {ate_odom.rmse_m:.3f} m ({len(frames)} scans, {slam.n_updates} filter updates, "
          f"{result.wall_s:.1f} s)")
    return result


def _main(args: argparse.Namespace) -> int:
    result = run_demo(args.out, args.rrd, apartment=args.apartment, seed=args.seed, particles=args.particles,
                      duration_s=args.duration_s)
    print(f"\nrecording: {result.rrd_path}   map: {result.map_png}   log: {result.log_path}")
    print(f"watch it:  .venv/bin/rerun {result.rrd_path}        (or open it in notebooks/01_quickstart.ipynb)")
    return 0


def add_demo_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Registers ``mcnkit demo``."""
    p = sub.add_parser("demo", help="simulate an apartment, run SLAM on its log, record it for Rerun (no dataset)",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", type=Path, default=Path("recordings/demo"), help="output folder (default recordings/demo)")
    p.add_argument("--rrd", type=Path, default=Path("recordings/demo.rrd"), help="the Rerun recording")
    p.add_argument("--apartment", type=int, default=3, help="procedural apartment number (default 3)")
    p.add_argument("--seed", type=int, default=0, help="random seed of the robot run and the filter")
    p.add_argument("--particles", type=int, default=30, help="SLAM particles (default 30)")
    p.add_argument("--duration-s", type=float, default=120.0, help="simulated seconds at most (default 120)")
    p.set_defaults(func=_main)
