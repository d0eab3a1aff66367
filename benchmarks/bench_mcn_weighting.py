"""Does weighting particles by the *completed* map help localization?  (beyond the paper)

``McnConfig.completion_weight = λ > 0`` adds, at every filter update, ``λ · Σ log(ε + (1 − 2ε) p_occ)`` to each
particle's log-weight, over the scan's end points that fall in cells unknown in that particle's map, with
``p_occ`` its own completion (U-net, previous update) — see :mod:`mcnkit.mcn`.  This script runs MCN-SLAM with
λ = 0 (plain gmapping weights) and with the given λ on the same simulated logs and filter seeds, and compares
the trajectory error (ATE RMSE of the ``tracked`` trajectory against the simulator's ground truth).

Logs: HouseExpo test plans and procedural apartments simulated with the default sensor and odometry noise, and
the same with the odometry noise multiplied by ``--noise-scale`` (a harder case for the filter).

Writes ``benchmarks/results/mcn_weighting.json``.

    .venv/bin/python -m benchmarks.bench_mcn_weighting [--houseexpo 3] [--procedural 2] [--seeds 0 1 2] [--weights 0 1]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np
import torch

from benchmarks.common import ROOT
from mcnkit.app.drive import drive
from mcnkit.datasets import read_split
from mcnkit.mcn import McnConfig, McnSlam, load_model
from mcnkit.metrics import absolute_trajectory_error
from mcnkit.sim import SimConfig, plan_raster, simulate
from mcnkit.slam import SlamConfig

HOUSEEXPO = ROOT.parent / "shared" / "data" / "houseexpo"


def _maps(n_houseexpo: int, n_procedural: int) -> list[str]:
    from mcnkit.datasets.houseexpo import iter_plans

    wanted = read_split(HOUSEEXPO / "map_id_test.txt")[: n_houseexpo * 3]
    ids = [p.id for p in iter_plans(HOUSEEXPO / "json.tar.gz", wanted)][:n_houseexpo]
    return [f"houseexpo:{i}" for i in ids] + [f"procedural:{k}" for k in range(n_procedural)]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--houseexpo", type=int, default=3)
    ap.add_argument("--procedural", type=int, default=2)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="filter seeds per log")
    ap.add_argument("--weights", type=float, nargs="+", default=[0.0, 1.0], help="λ values (0 = without)")
    ap.add_argument("--noise-scale", type=float, default=3.0, help="odometry noise factor of the harder logs")
    ap.add_argument("--particles", type=int, default=30)
    ap.add_argument("--duration-s", type=float, default=120.0)
    ap.add_argument("--json", type=Path, default=ROOT / "benchmarks" / "results" / "mcn_weighting.json")
    a = ap.parse_args()
    torch.set_num_threads(1)
    net = load_model("unet")
    rows = []
    for k, spec in enumerate(_maps(a.houseexpo, a.procedural)):
        raster = plan_raster(spec, 0.05, HOUSEEXPO / "json.tar.gz" if spec.startswith("houseexpo") else None)
        for scale in (1.0, a.noise_scale):
            base = SimConfig(max_duration_s=a.duration_s)
            noise = base.odometry
            noisy = dataclasses.replace(noise, **{f.name: getattr(noise, f.name) * scale
                                                  for f in dataclasses.fields(noise)
                                                  if isinstance(getattr(noise, f.name), float)})
            sim = simulate(raster, dataclasses.replace(base, odometry=noisy), seed=k)
            for seed in a.seeds:
                for lam in a.weights:
                    t0 = time.process_time()
                    mcn = McnSlam(SlamConfig(n_particles=a.particles), net,
                                  McnConfig(samples=1, ranks=1, full_map_every=0, completion_weight=lam),
                                  np.random.default_rng(seed), generator=torch.Generator().manual_seed(seed))
                    drive(sim.frames, mcn)
                    ate = absolute_trajectory_error(mcn.slam.trajectory(), sim.ground_truth).rmse_m
                    row = {"map": spec, "odometry_noise_scale": scale, "seed": seed, "completion_weight": lam,
                           "ate_m": ate, "cpu_s": time.process_time() - t0, "scans": len(sim.frames)}
                    rows.append(row)
                    print(f"{spec[:24]:24s} noise x{scale:g} seed {seed} λ={lam:g}: ATE {ate:.4f} m "
                          f"({row['cpu_s']:.1f} s)", flush=True)
    summary = []
    for scale in (1.0, a.noise_scale):
        base_rows = {(r["map"], r["seed"]): r["ate_m"] for r in rows
                     if r["odometry_noise_scale"] == scale and r["completion_weight"] == 0.0}
        for lam in a.weights:
            sel = [r for r in rows if r["odometry_noise_scale"] == scale and r["completion_weight"] == lam]
            ates = np.array([r["ate_m"] for r in sel])
            diff = np.array([r["ate_m"] - base_rows[(r["map"], r["seed"])] for r in sel if (r["map"], r["seed"]) in base_rows])
            better = int((diff < 0).sum())
            entry = {"odometry_noise_scale": scale, "completion_weight": lam, "n_runs": len(sel),
                     "mean_ate_m": float(ates.mean()), "median_ate_m": float(np.median(ates)),
                     "mean_change_vs_without_m": float(diff.mean()) if len(diff) else 0.0,
                     "ci95_change_m": float(1.96 * diff.std(ddof=1) / np.sqrt(len(diff))) if len(diff) > 1 else 0.0,
                     "runs_better_than_without": better, "mean_cpu_s": float(np.mean([r["cpu_s"] for r in sel]))}
            summary.append(entry)
            print(f"noise x{scale:g} λ={lam:g}: mean ATE {entry['mean_ate_m']:.4f} m (median {entry['median_ate_m']:.4f}),"
                  f" change vs λ=0 {entry['mean_change_vs_without_m']:+.4f} ± {entry['ci95_change_m']:.4f} m, "
                  f"better in {better}/{len(diff)} runs, {entry['mean_cpu_s']:.1f} s CPU per run")
    a.json.parent.mkdir(parents=True, exist_ok=True)
    a.json.write_text(json.dumps({"benchmark": "bench_mcn_weighting", "summary": summary, "runs": rows}, indent=2) + "\n")
    print(f"wrote {a.json}")


if __name__ == "__main__":
    main()
