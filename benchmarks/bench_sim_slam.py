"""SLAM on simulated logs: does the map's known part agree with the floor plan it was driven in?

For HouseExpo test plans and procedural apartments: simulate a run (``mcnkit.sim``), write it as a bag, read it
back with ``open_log``, run FastSLAM (30 particles, 0.05 m) and compare the best map with the ground-truth
raster on the cells the SLAM map knows (K).  The simulated odometry starts at the true start pose, so both
maps share a frame; the SLAM map is looked up in the ground truth cell by cell (same resolution).

Per class c ∈ {free, occupied}, on K: IoU_c = |S_c ∩ G_c| / |S_c ∪ G_c|.  Walls are where exact cell scores are
unfair (a beam ending on a wall surface that lies on a cell boundary marks either neighbour), so the occupied
class is also scored with a one-cell tolerance: an occupied SLAM cell counts as right when the ground truth is
occupied within one cell, and a ground-truth wall cell in K counts as found when SLAM has an occupied cell
within one cell.  The target is IoU ≥ 0.9 on the known cells.

    .venv/bin/python -m benchmarks.bench_sim_slam [--houseexpo 5] [--procedural 3] [--json benchmarks/results/sim_slam.json]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import ndimage

from mcnkit.app.drive import drive
from mcnkit.datasets import read_split
from mcnkit.io import open_log
from mcnkit.metrics import absolute_trajectory_error
from mcnkit.sim import SimConfig, plan_raster, simulate, write_sim_log
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.types import GridSpec

HOUSEEXPO = Path(__file__).resolve().parents[2] / "shared" / "data" / "houseexpo"


def map_agreement(slam_ternary: np.ndarray, slam_spec: GridSpec, gt_free: np.ndarray, gt_spec: GridSpec) -> dict[str, float]:
    """IoU of free and occupied on the SLAM map's known cells (exact, and occupied with a 1-cell tolerance)."""
    rows, cols = np.indices(slam_ternary.shape)
    xy = slam_spec.cell_to_world(np.stack([rows, cols], axis=-1))
    rc = gt_spec.world_to_cell(xy)
    inside = gt_spec.contains(rc)
    gt_occ = np.ones(slam_ternary.shape, bool)  # outside the raster = exterior = occupied
    gt_occ[inside] = ~gt_free[rc[inside][:, 0], rc[inside][:, 1]]
    known = slam_ternary != 0.5
    s_occ, s_free = known & (slam_ternary == 1.0), known & (slam_ternary == 0.0)
    g_occ, g_free = known & gt_occ, known & ~gt_occ
    iou_free = (s_free & g_free).sum() / max((s_free | g_free).sum(), 1)
    iou_occ = (s_occ & g_occ).sum() / max((s_occ | g_occ).sum(), 1)
    near_gt_wall = ndimage.binary_dilation(gt_occ, np.ones((3, 3), bool))
    near_slam_wall = ndimage.binary_dilation(s_occ, np.ones((3, 3), bool))
    # ground-truth wall cells in K that face free space (the wall surface a lidar can see)
    g_surface = g_occ & ndimage.binary_dilation(~gt_occ, np.ones((3, 3), bool))
    tp = 0.5 * ((s_occ & near_gt_wall).sum() + (g_surface & near_slam_wall).sum())
    iou_occ_tol = tp / max(s_occ.sum() + g_surface.sum() - tp, 1)
    return {
        "known_cells": int(known.sum()),
        "agreement": float(((s_free & g_free) | (s_occ & g_occ)).sum() / max(known.sum(), 1)),
        "iou_free": float(iou_free),
        "iou_occupied": float(iou_occ),
        "iou_occupied_tol1": float(iou_occ_tol),
        "miou": float((iou_free + iou_occ) / 2),
        "miou_tol1": float((iou_free + iou_occ_tol) / 2),
    }


def run_one(spec: str, tmp: Path, seed: int) -> dict[str, object]:
    raster = plan_raster(spec, 0.05, HOUSEEXPO / "json.tar.gz" if spec.startswith("houseexpo") else None)
    sim = simulate(raster, SimConfig(), seed)
    path = write_sim_log(sim, tmp / f"{spec.replace(':', '_')}.bag", overwrite=True)
    t0 = time.process_time()
    slam = FastSlam(SlamConfig(n_particles=30), np.random.default_rng(seed))
    with open_log(path) as log:
        drive(log.frames(), slam)
    cpu = time.process_time() - t0
    ternary = slam.best_ternary()
    assert ternary.spec is not None
    scores = map_agreement(ternary.image, ternary.spec, raster.free, raster.grid)
    ate = absolute_trajectory_error(slam.trajectory(), sim.ground_truth).rmse_m
    ate_odom = absolute_trajectory_error(sim.odometry, sim.ground_truth).rmse_m
    return {"map": spec, "scans": len(sim.frames), "slam_cpu_s": round(cpu, 1), "ate_m": ate,
            "ate_odometry_m": ate_odom, **scores}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--houseexpo", type=int, default=5, help="HouseExpo test plans (first N of the official list)")
    ap.add_argument("--procedural", type=int, default=3, help="procedural apartments")
    ap.add_argument("--json", type=Path, default=Path("benchmarks/results/sim_slam.json"),
                    help="JSON report (default benchmarks/results/sim_slam.json)")
    args = ap.parse_args()
    from mcnkit.datasets.houseexpo import iter_plans

    wanted = read_split(HOUSEEXPO / "map_id_test.txt")[: args.houseexpo * 3]
    ids = [p.id for p in iter_plans(HOUSEEXPO / "json.tar.gz", wanted)][: args.houseexpo]
    specs = [f"houseexpo:{i}" for i in ids] + [f"procedural:{k}" for k in range(args.procedural)]
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, spec in enumerate(specs):
            row = run_one(spec, Path(tmp), seed=k)
            rows.append(row)
            print(f"{spec[:28]:28s} scans {row['scans']:5d}  ATE {row['ate_m']:.3f} m (odometry {row['ate_odometry_m']:.3f})  "
                  f"agreement {row['agreement']:.3f}  IoU free {row['iou_free']:.3f}  occupied {row['iou_occupied']:.3f} "
                  f"(±1 cell {row['iou_occupied_tol1']:.3f})  mIoU {row['miou']:.3f} / ±1 cell {row['miou_tol1']:.3f}")
    mean = {k: float(np.mean([r[k] for r in rows])) for k in  # type: ignore[misc]
            ("agreement", "iou_free", "iou_occupied", "iou_occupied_tol1", "miou", "miou_tol1", "ate_m")}
    print("mean: " + ", ".join(f"{k} {v:.3f}" for k, v in mean.items()))
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"benchmark": "bench_sim_slam", "runs": rows, "mean": mean}, indent=2))
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
