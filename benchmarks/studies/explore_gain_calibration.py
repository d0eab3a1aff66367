"""How well do the samples' expected gains predict what a scan would really see?  At every planning step of the
``mcn`` planner, each viewpoint's gain from the K samples against its gain from the true plan.

Runs the default ``mcn`` planner as ``bench_explore --study`` does (the same training-list houses no net was trained
on, the same seeds, ``--stop-coverage`` 0.95 and the 120 m budget, so the paths are those of the study's default
rows), and at every planning step also scores the same viewpoints with the true plan as the completion (the
``--model truth`` planner of ``bench_explore``: the unknown area a scan from there would see, inside the window and
past it).  Prints and writes (JSON, and a PNG of the binned gains):

* how often the samples choose the viewpoint the true gains would (both by gain / (path cost + 1 m)), and what the
  samples' choice loses on the true ratio when they do not (its *regret*: 1 − true ratio of the choice / the best
  true ratio);
* the rank correlation of the two gains over all viewpoints;
* the samples' gain against the true one by path cost and by the samples' gain (a calibration curve: a bias that
  grows with cost or with gain would change the ratio's choices, a uniform one would not);
* how the choices fare when the samples' gain is replaced by its calibrated value, the mean true gain of the
  viewpoints the samples gave as much (the curve of the figure, fitted on the same steps): whether correcting the
  samples' bias on average brings their choices closer to the true plan's.

    .venv/bin/python -m benchmarks.studies.explore_gain_calibration --houses 52 --jobs 2 \\
        --json benchmarks/results/explore_gain_calibration.json
"""

from __future__ import annotations

import argparse
import itertools
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

COST_BINS_M = (0.0, 2.0, 5.0, 10.0, 20.0, np.inf)
GAIN_BINS_M2 = (0.0, 2.0, 5.0, 10.0, 20.0, 40.0, np.inf)


def run(spec: str, seed: int, model: str) -> dict[str, Any]:
    """One exploration with the default ``mcn`` planner; per planning step, every viewpoint's gains (the samples'
    and the true plan's, each whole and inside the window), path cost, and the index chosen."""
    import torch

    from benchmarks.bench_explore import truth_planner
    from mcnkit.explore.config import ExploreConfig, GainConfig
    from mcnkit.explore.frontiers import Viewpoints
    from mcnkit.explore.loop import Explorer, seed_streams
    from mcnkit.explore.paths import CostField
    from mcnkit.explore.planners import McnPlanner, PlanningView
    from mcnkit.mcn import load_model
    from mcnkit.sim import SimConfig, plan_raster

    torch.set_num_threads(1)
    raster = plan_raster(spec)
    gain = GainConfig()
    range_m = SimConfig().lidar.range_max_m
    truth = truth_planner(raster, gain, range_m, torch.Generator().manual_seed(0))
    steps: list[dict[str, list[float] | int]] = []

    class Recorded(McnPlanner):
        def score(self, view: PlanningView, points: Viewpoints, field: CostField) -> Any:
            g, s, pred = super().score(view, points, field)
            if len(points) and pred is not None:
                g_true, _, pred_true = truth.score(view, points, field)
                steps.append({"gain": g.tolist(), "gain_in": self.window_gains(pred, points.xy_m).tolist(),
                              "true": g_true.tolist(), "true_in": self.window_gains(pred_true, points.xy_m).tolist(),
                              "cost_m": points.cost_m.tolist(), "choice": int(np.argmax(s))})
            return g, s, pred

    planner = Recorded(load_model(model), gain, range_m, torch.Generator().manual_seed(seed_streams(seed)[2]))
    explorer = Explorer(raster, planner, ExploreConfig(stop_coverage=0.95, budget_m=120.0), seed=seed)
    while not explorer.done:
        explorer.step()
    return {"map": spec, "seed": seed, "path_length_m": explorer.path_length_m, "steps": steps}


def _run(args: tuple[str, int, str]) -> dict[str, Any]:
    return run(*args)


def analyse(rows: list[dict[str, Any]], cost_floor_m: float) -> dict[str, Any]:
    """The figures of the module docstring, from :func:`run`'s rows."""
    from scipy.stats import spearmanr

    cols: dict[str, list[np.ndarray]] = {k: [] for k in ("gain", "gain_in", "true", "true_in", "cost_m")}
    for r in rows:
        for s in r["steps"]:
            for k in cols:
                cols[k].append(np.asarray(s[k], np.float64))
    g, g_in, t, t_in, c = (np.concatenate(cols[k]) for k in ("gain", "gain_in", "true", "true_in", "cost_m"))
    # E[true gain | samples' gain]: the binned means, linear between them (the calibration curve of the figure)
    edges = np.asarray(GAIN_BINS_M2)
    which = np.digitize(g, edges[1:-1])
    knots_x = np.array([0.0] + [g[which == b].mean() for b in range(len(edges) - 1) if (which == b).any()])
    knots_y = np.array([0.0] + [t[which == b].mean() for b in range(len(edges) - 1) if (which == b).any()])

    def choices(score_of: Any) -> tuple[np.ndarray, np.ndarray]:
        """Per step with two viewpoints or more: chosen as the true ratio would, and the regret on it."""
        same, regret = [], []
        for r in rows:
            for s in r["steps"]:
                gain, true, cost = (np.asarray(s[k], np.float64) for k in ("gain", "true", "cost_m"))
                if len(gain) < 2:
                    continue
                true_ratio = true / (cost + cost_floor_m)
                best, choice = int(np.argmax(true_ratio)), int(np.argmax(score_of(gain) / (cost + cost_floor_m)))
                same.append(choice == best)
                regret.append(1.0 - true_ratio[choice] / max(true_ratio[best], 1e-12))
        return np.asarray(same), np.asarray(regret)

    same, regret = choices(lambda gain: gain)
    slope = (knots_y[-1] - knots_y[-2]) / max(knots_x[-1] - knots_x[-2], 1e-9)  # past the last knot: its segment's
    same_cal, regret_cal = choices(lambda gain: np.where(gain > knots_x[-1], knots_y[-1] + slope * (gain - knots_x[-1]),
                                                         np.interp(gain, knots_x, knots_y)))

    def bins(key: np.ndarray, edges: tuple[float, ...]) -> list[dict[str, float]]:
        out = []
        for lo, hi in itertools.pairwise(edges):
            m = (key >= lo) & (key < hi)
            if m.any():
                out.append({"from": lo, "to": hi if np.isfinite(hi) else None, "viewpoints": int(m.sum()),
                            "samples_m2": float(g[m].mean()), "true_m2": float(t[m].mean()),
                            "samples_over_true": float(g[m].sum() / max(t[m].sum(), 1e-9))})
        return out

    return {
        "runs": len(rows), "planning_steps": len(same), "viewpoints": int(len(g)),
        "choice_as_true": float(np.mean(same)), "regret_mean": float(regret.mean()),
        "regret_median": float(np.median(regret)), "regret_over_10pct": float(np.mean(regret > 0.1)),
        "calibrated": {"choice_as_true": float(np.mean(same_cal)), "regret_mean": float(regret_cal.mean()),
                       "regret_over_10pct": float(np.mean(regret_cal > 0.1))},
        "spearman": float(spearmanr(g, t).statistic),
        "samples_over_true": float(g.sum() / t.sum()),
        "inside_samples_over_true": float(g_in.sum() / t_in.sum()),
        "beyond_samples_over_true": float((g - g_in).sum() / max((t - t_in).sum(), 1e-9)),
        "by_cost_m": bins(c, COST_BINS_M), "by_samples_gain_m2": bins(g, GAIN_BINS_M2),
    }


def plot(rows: list[dict[str, Any]], summary: dict[str, Any], path: Path) -> None:
    """Two panels: the true gain against the samples' (binned means, the diagonal), and the samples' share of the
    true gain by path cost."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.5))
    gb = summary["by_samples_gain_m2"]
    a.plot([x["samples_m2"] for x in gb], [x["true_m2"] for x in gb], "o-", label="true gain, mean per bin")
    top = max(x["samples_m2"] for x in gb)
    a.plot([0, top], [0, top], "k--", lw=1, label="samples = true")
    a.set_xlabel("samples' expected gain [m²] (bin mean)")
    a.set_ylabel("true plan's gain [m²]")
    a.legend(fontsize=8)
    a.set_title(f"Spearman {summary['spearman']:.2f} over {summary['viewpoints']} viewpoints", fontsize=10)
    cb = summary["by_cost_m"]
    labels = [f"{x['from']:g}-{x['to']:g}" if x["to"] is not None else f"≥{x['from']:g}" for x in cb]
    b.bar(labels, [x["samples_over_true"] for x in cb])
    b.axhline(1.0, color="k", ls="--", lw=1)
    b.set_xlabel("path cost to the viewpoint [m]")
    b.set_ylabel("samples' gain / true gain")
    b.set_title(f"choice as the true plan's in {100 * summary['choice_as_true']:.0f} % of "
                f"{summary['planning_steps']} steps", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)


def main() -> None:
    from benchmarks.bench_explore import study_house_ids
    from benchmarks.common import data_dir
    from mcnkit.app.commands.explore import DEFAULT_MODEL
    from mcnkit.datasets.houseexpo import houseexpo_source
    from mcnkit.explore.config import GainConfig

    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--houses", type=int, default=52, help="training-list houses of bench_explore --study (default 52)")
    ap.add_argument("--seed-offset", type=int, default=0, help="added to each house's seed, its index (default 0)")
    ap.add_argument("--model", default=DEFAULT_MODEL, help=f"completion model (default {DEFAULT_MODEL})")
    ap.add_argument("--jobs", type=int, default=1, help="runs at once, one process each (default 1)")
    ap.add_argument("--data", type=Path, default=None,
                    help="shared data folder (default $MCNKIT_SHARED_DATA or ../shared/data)")
    ap.add_argument("--json", type=Path, default=Path("benchmarks/results/explore_gain_calibration.json"),
                    help="output JSON; the figure is written beside it as .png "
                         "(default benchmarks/results/explore_gain_calibration.json)")
    args = ap.parse_args()
    t0 = time.perf_counter()
    shared = data_dir(args.data)
    source = houseexpo_source(None) or shared / "houseexpo" / "json.tar.gz"
    ids = study_house_ids(source, shared / "houseexpo", args.houses)
    tasks = [(f"houseexpo:{i}", k + args.seed_offset, args.model) for k, i in enumerate(ids)]
    rows: list[dict[str, Any]] = []
    if args.jobs > 1:
        import multiprocessing

        with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            for row in pool.map(_run, tasks):
                rows.append(row)
                print(f"{row['map'][:18]}… seed {row['seed']}: {len(row['steps'])} steps, "
                      f"{row['path_length_m']:.1f} m")
    else:
        for task in tasks:
            rows.append(run(*task))
            print(f"{rows[-1]['map'][:18]}… seed {rows[-1]['seed']}: {len(rows[-1]['steps'])} steps")
    summary = analyse(rows, GainConfig().cost_floor_m)
    print(f"{summary['planning_steps']} planning steps, {summary['viewpoints']} viewpoints on {len(rows)} houses")
    print(f"the samples choose the viewpoint the true plan would in {100 * summary['choice_as_true']:.1f} % of the "
          f"steps; regret on the true ratio: mean {100 * summary['regret_mean']:.1f} %, median "
          f"{100 * summary['regret_median']:.1f} %, over 10 % in {100 * summary['regret_over_10pct']:.1f} % of the "
          "steps")
    cal = summary["calibrated"]
    print(f"with the samples' gain calibrated (E[true | samples' gain], the binned means): the true plan's choice in "
          f"{100 * cal['choice_as_true']:.1f} % of the steps; regret mean {100 * cal['regret_mean']:.1f} %, over 10 % "
          f"in {100 * cal['regret_over_10pct']:.1f} %")
    print(f"Spearman of samples' and true gains {summary['spearman']:.3f}; samples / true: all "
          f"{summary['samples_over_true']:.2f}, inside the window {summary['inside_samples_over_true']:.2f}, past it "
          f"{summary['beyond_samples_over_true']:.2f}")
    for title, key, unit in (("path cost", "by_cost_m", "m"), ("samples' gain", "by_samples_gain_m2", "m²")):
        for x in summary[key]:
            span = f"{x['from']:g}-{x['to']:g}" if x["to"] is not None else f"≥ {x['from']:g}"
            print(f"  {title} {span} {unit}: {x['viewpoints']:5d} viewpoints, samples "
                  f"{x['samples_m2']:5.1f} m², true {x['true_m2']:5.1f} m², ratio {x['samples_over_true']:.2f}")
    summary["wall_s"] = time.perf_counter() - t0
    summary["model"] = args.model
    summary["seed_offset"] = args.seed_offset
    summary["path_length_m"] = {r["map"]: r["path_length_m"] for r in rows}
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps(summary, indent=1) + "\n")
    plot(rows, summary, args.json.with_suffix(".png"))
    print(f"wall time {summary['wall_s'] / 60:.1f} min; wrote {args.json} and {args.json.with_suffix('.png')}")


if __name__ == "__main__":
    main()
