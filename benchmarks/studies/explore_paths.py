"""Where do two scorings part ways?  The paths of the frontier planner and of ``mcn`` under several gains, drawn on one
house side by side.

Runs :class:`mcnkit.explore.loop.Explorer` as ``bench_explore`` does (same seed per house, the same stopping rule,
``--stop-coverage`` 0.9 by default, so every panel ends where the headline figure is read) with the frontier planner
and with ``mcn`` under each ``--gains`` kind, and draws the true paths on the plan, coloured by time, each goal marked
with the path length at which it was chosen.  One row of panels, a PNG:

    .venv/bin/python -m benchmarks.studies.explore_paths houseexpo:02fa369fcb387eca76c0635507e0ed15 --seed 34 \\
        --gains unknown observed --png benchmarks/results/explore_paths_02fa.png

(house 02fa… is the 35th HouseExpo test house of ``bench_explore``, whose seed is its index, 34).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import numpy as np

from mcnkit.app.commands.explore import DEFAULT_MODEL


def run(spec: str, seed: int, gain: str | None, stop_coverage: float, model: str) -> dict[str, Any]:
    """One exploration: ``gain`` None is the frontier planner.  The true path, the goals (where, at what path
    length), the path length and coverage at the end."""
    import torch

    from mcnkit.explore.config import ExploreConfig, GainConfig
    from mcnkit.explore.loop import Explorer, seed_streams
    from mcnkit.explore.planners import FrontierPlanner, McnPlanner, Planner
    from mcnkit.mcn import load_model
    from mcnkit.sim import SimConfig, plan_raster

    torch.set_num_threads(1)
    raster = plan_raster(spec)
    planner: Planner = FrontierPlanner()
    if gain is not None:
        planner = McnPlanner(load_model(model), GainConfig(gain=gain),  # type: ignore[arg-type]
                             SimConfig().lidar.range_max_m, torch.Generator().manual_seed(seed_streams(seed)[2]))
    explorer = Explorer(raster, planner, ExploreConfig(stop_coverage=stop_coverage), seed=seed)
    path, goals = [explorer.truth[:2].copy()], []
    while not explorer.done:
        record = explorer.step()
        path.append(explorer.truth[:2].copy())
        d = record.decision
        if d is not None and d.goal_xy_m is not None and not d.kept:
            goals.append((explorer.path_length_m, d.goal_xy_m.copy()))
    return {"raster": raster, "path": np.array(path), "goals": goals, "length_m": explorer.path_length_m,
            "coverage": explorer.coverage, "stop": explorer.stop_reason}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("map", help="a plan: houseexpo:ID (the full 32-hex id), procedural:SEED or image:FILE")
    ap.add_argument("--seed", type=int, default=0, help="the run's seed (bench_explore uses the house's index; "
                                                        "default 0)")
    ap.add_argument("--gains", nargs="+", default=["unknown", "observed"],
                    help="mcn gain kinds to draw beside the frontier planner (default: unknown observed)")
    ap.add_argument("--stop-coverage", type=float, default=0.9, help="end each run at this coverage (default 0.9)")
    ap.add_argument("--model", default=DEFAULT_MODEL, help=f"completion model (default {DEFAULT_MODEL})")
    ap.add_argument("--png", type=Path, required=True, help="the figure to write")
    args = ap.parse_args()
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    panels = [("frontier", None)] + [(f"mcn, gain {g}", g) for g in args.gains]
    fig, axes = plt.subplots(1, len(panels), figsize=(6 * len(panels), 5.5), squeeze=False)
    for ax, (title, gain) in zip(axes[0], panels, strict=True):
        r = run(args.map, args.seed, gain, args.stop_coverage, args.model)
        g = r["raster"].grid
        extent = (g.origin_x_m, g.origin_x_m + g.width * g.resolution_m,
                  g.origin_y_m, g.origin_y_m + g.height * g.resolution_m)
        ax.imshow(r["raster"].free, origin="lower", extent=extent, cmap="gray")
        ax.scatter(*r["path"].T, c=np.arange(len(r["path"])), s=2, cmap="viridis")
        ax.plot(*r["path"][0], "w^", markersize=8)
        for length_m, xy in r["goals"]:
            ax.annotate(f"{length_m:.0f}", xy, fontsize=7, color="red")
        ax.set_title(f"{title}: {r['length_m']:.1f} m to {100 * r['coverage']:.0f} % ({r['stop']})", fontsize=10)
        ax.set_xticks([])
        ax.set_yticks([])
        print(f"{title:24s} {r['length_m']:6.1f} m  coverage {r['coverage']:.3f}  {r['stop']}")
    fig.suptitle(f"{args.map[:26]}, seed {args.seed}: true paths (dark = early), goals marked with the path length "
                 f"at which they were chosen [m]", fontsize=10)
    fig.tight_layout()
    args.png.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.png, dpi=80)
    print(f"wrote {args.png}")


if __name__ == "__main__":
    main()
