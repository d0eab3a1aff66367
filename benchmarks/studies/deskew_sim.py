"""What deskewing is worth: simulated runs with a spinning 360° scanner whose beams are measured one after another.

The simulator drives a robot through procedural apartments (a domain that needs no data), turning at up to
``--turn-rate`` rad/s, and its scanner spins at the scan rate: beam i of a scan is cast from where the robot is
``i / n`` of a scan period after the scan's stamp (poses interpolated between the frames), as an RPLIDAR or an LD19
measures it, and the scan says so in ``time_increment``.  The same frames are mapped by :class:`FastSlam` with
``matching.deskew`` on and off, and, for the ceiling, frames cast with every beam from the stamp's pose (no skew at
all).  Scored by the ATE RMSE of the trajectory against the simulator's truth (rigid alignment).

    .venv/bin/python -m benchmarks.studies.deskew_sim [--plans 0 1 2 3 4 5] [--turn-rate 1.9] [--json FILE]

Prints the table and writes ``benchmarks/results/deskew_sim.{json,md}``.
"""

from __future__ import annotations

import argparse
import time
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, save_report
from mcnkit.geometry import compose, relative
from mcnkit.metrics import absolute_trajectory_error
from mcnkit.sim import LidarConfig, PlanRaster, SimConfig, add_range_noise, cast_rays, plan_raster, simulate
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.slam.config import MatchingConfig
from mcnkit.types import Frame, LidarSpec, Scan, Trajectory

SCAN_HZ = 8.0  # an RPLIDAR A1's default
LIDAR = LidarConfig(n_beams=720, fov_deg=360.0, range_min_m=0.15, range_max_m=12.0)


@dataclass(frozen=True)
class Run:
    """One plan: its frames and the ATE RMSE (m) of the three mappings."""

    plan: str
    frames: int
    path_m: float
    fastest_turn_rad_s: float
    ate_swept_deskewed_m: float
    ate_swept_as_logged_m: float
    ate_unswept_m: float


def swept_ranges(sim_truth: np.ndarray, raster: PlanRaster, spec: LidarSpec, rng: np.random.Generator) -> np.ndarray:
    """(F, B) ranges of a scanner spinning once per frame: beam i from the pose ``i / B`` of the way to the next
    frame's (the last frame's beams all from its own pose)."""
    n = spec.n_beams
    nxt = np.concatenate([sim_truth[1:], sim_truth[-1:]])
    frac = np.arange(n) / n
    out = np.empty((len(sim_truth), n), np.float32)
    one_beam = LidarSpec(0.0, 1.0, 1, spec.range_min_m, spec.range_max_m)
    for k in range(len(sim_truth)):
        step = relative(sim_truth[k], nxt[k])
        at = compose(sim_truth[k], frac[:, None] * step[None, :])  # the base at each beam's time
        laser = compose(at, spec.base_to_laser.as_array())
        laser[:, 2] += spec.angles_rad
        out[k] = cast_rays(raster.free, raster.grid, laser, one_beam)[:, 0]
    add_range_noise(out, LIDAR, rng)
    return out


def _ate(frames: list[Frame], truth: Trajectory, deskew: bool) -> float:
    slam = FastSlam(SlamConfig(matching=MatchingConfig(deskew=deskew)), np.random.default_rng(0))
    for f in frames:
        slam.step(f)
    return absolute_trajectory_error(slam.trajectory(), truth).rmse_m


def run_plan(seed: int, turn_rate: float, duration_s: float) -> Run:
    raster = plan_raster(f"procedural:{seed}")
    config = SimConfig(scan_rate_hz=SCAN_HZ, turn_rate_rad_s=turn_rate, max_duration_s=duration_s, lidar=LIDAR)
    sim = simulate(raster, config, seed=seed)
    truth = sim.ground_truth.poses
    spec = replace(sim.frames[0].scan.spec, time_increment_s=1.0 / SCAN_HZ / LIDAR.n_beams)
    swept = swept_ranges(truth, raster, spec, np.random.default_rng(seed + 1000))
    frames = [Frame(f.stamp_ns, Scan(r, spec), f.odom) for f, r in zip(sim.frames, swept, strict=True)]
    steps = relative(truth[:-1], truth[1:])
    return Run(
        f"procedural:{seed}", len(frames), float(np.hypot(steps[:, 0], steps[:, 1]).sum()),
        float(np.abs(steps[:, 2]).max() * SCAN_HZ), _ate(frames, sim.ground_truth, True),
        _ate(frames, sim.ground_truth, False), _ate(sim.frames, sim.ground_truth, False))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--plans", type=int, nargs="+", default=list(range(6)), help="procedural plan seeds (default 0-5)")
    ap.add_argument("--turn-rate", type=float, default=1.9,
                    help="the robot's fastest turn, rad/s (default 1.9: a TurtleBot 4's)")
    ap.add_argument("--duration-s", type=float, default=150.0, help="simulated seconds per plan at most (default 150)")
    ap.add_argument("--json", default=str(RESULTS / "deskew_sim.json"),
                    help="where the report goes, with a .md beside it (default benchmarks/results/deskew_sim.json)")
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    runs = []
    for seed in args.plans:
        runs.append(run_plan(seed, args.turn_rate, args.duration_s))
        r = runs[-1]
        print(f"  {r.plan}: {r.frames} frames, {r.path_m:.0f} m, ATE deskewed {r.ate_swept_deskewed_m:.3f} m, as logged "
              f"{r.ate_swept_as_logged_m:.3f} m, unswept {r.ate_unswept_m:.3f} m", flush=True)
    lines = [f"Procedural apartments, a 360° scanner of {LIDAR.n_beams} beams spinning at {SCAN_HZ:g} Hz, the robot "
             f"turning at up to {args.turn_rate:g} rad/s; ATE RMSE (m) of FastSlam's trajectory.", "",
             "| plan | frames | path (m) | swept, deskewed | swept, as logged | every beam from the stamp's pose |",
             "|---|---|---|---|---|---|"]
    lines += [f"| {r.plan} | {r.frames} | {r.path_m:.0f} | {r.ate_swept_deskewed_m:.3f} | {r.ate_swept_as_logged_m:.3f} | "
              f"{r.ate_unswept_m:.3f} |" for r in runs]
    mean = {k: float(np.mean([getattr(r, k) for r in runs]))
            for k in ("ate_swept_deskewed_m", "ate_swept_as_logged_m", "ate_unswept_m")}
    lines.append(f"| mean | | | {mean['ate_swept_deskewed_m']:.3f} | {mean['ate_swept_as_logged_m']:.3f} | "
                 f"{mean['ate_unswept_m']:.3f} |")
    ok = mean["ate_swept_deskewed_m"] < mean["ate_swept_as_logged_m"]
    lines.append(f"\n{time.perf_counter() - t0:.0f} s wall.")
    return save_report(Path(args.json), {"runs": [asdict(r) for r in runs], "mean": mean,
                                         "verdict": {"ok": ok}}, "\n".join(lines))


if __name__ == "__main__":
    raise SystemExit(main())
