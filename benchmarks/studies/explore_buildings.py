"""Exploring real buildings: the frontier planner and ``mcn`` on the maps ``mcnkit slam`` makes of the real logs.

The exploration benchmark runs on HouseExpo houses and procedural apartments; users explore their own buildings
(``mcnkit explore --map image:FILE``), larger than any house the nets were trained on, with corridors, clutter and
walls as a lidar saw them.  This study gives each building of ``../shared/data/reallab`` (the Radish corrected logs,
Intel, MIT CSAIL; not the outdoor Freiburg campus) to both planners as a floor plan: the map of ``mcnkit slam LOG
--particles 30 --resolution 0.05 --seed 0`` (made once into ``--maps``, reused when there), whose free cells are the
plan (its unknown grey is not free, so the plan is what the real robot saw).  Every (building, seed, planner) runs as
``bench_explore`` runs a house (same simulator, SLAM, stopping rule, ``mcn`` with ``mcnkit explore``'s default model at its default K samples) with a
larger path budget.

Reported per building and seed: the path to 50 / 80 / 90 % coverage of the reachable free space and the coverage at
100 / 200 / 300 m (read off each run's coverage curve); over all runs, the paired saving at 90 % coverage where both
planners got there, and the runs only one of them finished.  Writes ``explore_buildings.json``, ``.md`` and a plot of
coverage against path length per building (``explore_buildings.png``) into ``benchmarks/results/``; every run is also
written as it ends to ``runs.jsonl`` in ``--maps`` (a study cut short keeps them):

    .venv/bin/python -m benchmarks.studies.explore_buildings --maps /tmp/building-maps --jobs 2
    .venv/bin/python -m benchmarks.studies.explore_buildings --only intel aces --seeds 0 --budget-m 200
"""

from __future__ import annotations

import argparse
import json
import subprocess
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.bench_explore import DEFAULT_MODEL, GRID_STEP_M, Task, paired, run_task
from benchmarks.common import BUILDINGS, RESULTS, SLAM_ENV, data_dir, slam_command

INDOOR = [name for name in BUILDINGS if name != "campus"]
"""The buildings explored: every real log's building but the Freiburg campus (outdoors, 2 km of paths)."""
READ_AT_M = (100.0, 200.0, 300.0)
"""Path lengths at which the coverage is reported [m]."""
LEVELS = ("0.5", "0.8", "0.9")


def make_map(name: str, data: Path, maps: Path) -> Path:
    """The building's floor plan: ``maps/NAME/map.pgm`` (with its ``map.yaml``), made by ``mcnkit slam`` when it
    is not there yet."""
    out = maps / name
    plan = out / "map.pgm"
    if not plan.is_file():
        log = data / BUILDINGS[name][0]
        done = subprocess.run(slam_command(log, 0, out, ["--overwrite"]), env=SLAM_ENV, capture_output=True, text=True)
        if done.returncode != 0 or not plan.is_file():
            raise SystemExit(f"mcnkit slam {log} failed: {done.stderr.strip().splitlines()[-1:]}")
    return plan


def coverage_read(row: dict[str, Any], at_m: float) -> float:
    """A run's coverage at a path length, off its curve (its last value once the run has ended)."""
    curve = row["curve"]
    k = min(int(round(at_m / GRID_STEP_M)), len(curve) - 1)
    return float(curve[k])


def table(rows: list[dict[str, Any]]) -> str:
    """The markdown table: one line per building and seed, both planners side by side."""
    def fmt(x: float | None) -> str:
        return "–" if x is None else f"{x:.1f}"

    by = {(r["building"], r["seed"], r["planner"]): r for r in rows}
    lines = ["| building | seed | path to 50 / 80 / 90 % (m), frontier | mcn | coverage at "
             + " / ".join(f"{a:.0f}" for a in READ_AT_M) + " m, frontier | mcn |", "|---|---|---|---|---|---|"]
    for b, s in sorted({(r["building"], r["seed"]) for r in rows}):
        f, m = by.get((b, s, "frontier")), by.get((b, s, "mcn"))
        if f is None or m is None:
            continue
        paths = [" / ".join(fmt(x["path_to_coverage_m"][lv]) for lv in LEVELS) for x in (f, m)]
        cover = [" / ".join(f"{100 * coverage_read(x, a):.0f} %" for a in READ_AT_M) for x in (f, m)]
        lines.append(f"| {b} | {s} | {paths[0]} | {paths[1]} | {cover[0]} | {cover[1]} |")
    return "\n".join(lines)


def plot(rows: list[dict[str, Any]], path: Path, budget_m: float) -> None:
    """Coverage against path length, one panel per building, every seed's curve of both planners."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = sorted({r["building"] for r in rows})
    cols = min(4, len(names))
    fig, axes = plt.subplots((len(names) + cols - 1) // cols, cols, figsize=(3.6 * cols, 3.0 * ((len(names) + cols - 1) // cols)),
                             squeeze=False)
    grid = np.arange(0.0, budget_m + 1e-9, GRID_STEP_M)
    for ax, name in zip(axes.flat, names, strict=False):
        for planner, color in (("frontier", "tab:blue"), ("mcn", "tab:red")):
            for k, r in enumerate(x for x in rows if x["building"] == name and x["planner"] == planner):
                ax.plot(grid[: len(r["curve"])], r["curve"], color=color, lw=1.2, alpha=0.85,
                        label=planner if k == 0 else None)
        ax.axhline(0.9, color="grey", lw=0.8, ls=":")
        ax.set(title=name, xlim=(0, budget_m), ylim=(0, 1.01))
        ax.set_xlabel("path length [m]", fontsize=8)
        ax.set_ylabel("coverage", fontsize=8)
        ax.legend(loc="lower right", fontsize=7)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_plans(pool: ProcessPoolExecutor, domain: str, plans: dict[str, str], seeds: list[int], model: str,
              explore: dict[str, Any], stream_path: Path, t0: float) -> list[dict[str, Any]]:
    """Both planners on every plan (name -> map spec) and seed, as ``bench_explore`` runs a house (with ``explore``
    over its settings); each run, as it ends, printed and written to ``stream_path`` (JSON lines)."""
    futures = {pool.submit(run_task, Task(spec, domain, planner, seed, model, explore=explore)): name
               for name, spec in plans.items() for seed in seeds for planner in ("frontier", "mcn")}
    rows = []
    with stream_path.open("w") as stream:
        for done in as_completed(futures):
            row = done.result()
            row.pop("window_probe", None)
            row["building"] = futures[done]
            row["map"] = f"{row['building']}:{row['seed']}"  # paired() pairs runs by map: a building and seed
            rows.append(row)
            stream.write(json.dumps(row) + "\n")
            stream.flush()
            print(f"{row['building']:15s} seed {row['seed']} {row['planner']:8s} coverage {row['coverage']:.3f} "
                  f"path {row['path_length_m']:.1f} m, to 90 %: {row['path_to_coverage_m']['0.9']} "
                  f"({time.perf_counter() - t0:.0f} s)", flush=True)
    return rows


def write_report(rows: list[dict[str, Any]], out: Path, budget_m: float, header: dict[str, Any], t0: float) -> None:
    """Writes the study's JSON report (``header``, the paired saving at 90 %, the mean coverage at ``READ_AT_M``,
    the wall time since ``t0`` and every run), its table (``.md``) and plot (``.png``) beside it, and prints them."""
    summary = paired(rows, "mcn")
    report = {**header, "paired_90": summary,
              "coverage_at_m": {p: {f"{a:.0f}": float(np.mean([coverage_read(r, a) for r in rows if r["planner"] == p]))
                                    for a in READ_AT_M} for p in ("frontier", "mcn")},
              "wall_s": time.perf_counter() - t0, "runs": rows}
    out.write_text(json.dumps(report, indent=1))
    md = table(rows)
    out.with_suffix(".md").write_text(md + "\n")
    plot(rows, out.with_suffix(".png"), budget_m)
    print(md)
    print(f"mean coverage at {', '.join(f'{a:.0f}' for a in READ_AT_M)} m: " + "; ".join(
        f"{p} " + " / ".join(f"{100 * v:.0f} %" for v in report["coverage_at_m"][p].values()) for p in report["coverage_at_m"]))
    if "saving" in summary:
        print(f"path to 90 %, {summary['both_finished']} runs both finished: frontier {summary['mean_frontier_m']:.1f} m, "
              f"mcn {summary['mean_other_m']:.1f} m, saving {100 * summary['saving']:.1f} % "
              f"(95 % CI {100 * summary['saving_ci95'][0]:.1f} to {100 * summary['saving_ci95'][1]:.1f} %)")
    print(f"only frontier reached 90 %: {summary['only_frontier_finished']}; only mcn: {summary['only_other_finished']}")
    print(f"wall {report['wall_s']:.0f} s -> {out}")


def add_run_options(ap: argparse.ArgumentParser, seeds: list[int], report: str) -> None:
    """The options of a study's runs and report: ``--seeds`` (default ``seeds``), ``--budget-m``,
    ``--stop-coverage``, ``--model``, ``--jobs``, ``--out`` (default ``benchmarks/results/REPORT``)."""
    ap.add_argument("--seeds", nargs="+", type=int, default=seeds, help="exploration seeds: start pose and noise "
                                                                        f"(default {' '.join(map(str, seeds))})")
    ap.add_argument("--budget-m", type=float, default=300.0, help="path budget of a run [m] (default 300)")
    ap.add_argument("--stop-coverage", type=float, default=0.95, help="end a run at this coverage (default 0.95)")
    ap.add_argument("--model", default=DEFAULT_MODEL, help=f"completion model of mcn (default {DEFAULT_MODEL})")
    ap.add_argument("--jobs", type=int, default=1, help="runs in parallel (processes; default 1)")
    ap.add_argument("--out", type=Path, default=RESULTS / report,
                    help=f"the JSON report; the table (.md) and plot (.png) go beside it (default "
                         f"benchmarks/results/{report})")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", type=Path, default=Path("/tmp/mcnkit-building-maps"),
                    help="where the buildings' SLAM maps are made and reused (default /tmp/mcnkit-building-maps)")
    ap.add_argument("--only", nargs="+", choices=INDOOR, help="a subset of the buildings (default: all of them)")
    ap.add_argument("--data", default=None, help="the shared data folder (default: $MCNKIT_SHARED_DATA, else "
                                                 "../shared/data)")
    add_run_options(ap, [0, 1], "explore_buildings.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    names = list(args.only or INDOOR)
    data = data_dir(args.data)
    args.maps.mkdir(parents=True, exist_ok=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with ProcessPoolExecutor(max(1, args.jobs)) as pool:
        plans = dict(zip(names, pool.map(make_map, names, [data] * len(names), [args.maps] * len(names)), strict=True))
        print(f"maps ready ({time.perf_counter() - t0:.0f} s): {', '.join(str(p) for p in plans.values())}", flush=True)
        rows = run_plans(pool, "buildings", {n: f"image:{plans[n]}" for n in names}, args.seeds, args.model,
                         {"budget_m": args.budget_m, "stop_coverage": args.stop_coverage}, args.maps / "runs.jsonl", t0)
    write_report(rows, args.out, args.budget_m, {"study": "explore_buildings", "budget_m": args.budget_m,
                                                 "stop_coverage": args.stop_coverage, "model": args.model,
                                                 "seeds": args.seeds}, t0)

if __name__ == "__main__":
    main()
