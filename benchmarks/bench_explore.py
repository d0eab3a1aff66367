"""Benchmark of exploration: the ``mcn`` planner (frontiers scored by K sampled completions) against the nearest
frontier (Yamauchi 1997), on the same houses with the same seeds.

Every (house, planner) runs :class:`mcnkit.explore.loop.Explorer` as ``mcnkit explore`` does (same simulator,
lidar, odometry noise, SLAM and stopping rule; ``--stop-coverage`` ends a run once that share of the reachable free
space is seen, to save time), with the house's index (plus ``--seed-offset``) as its seed, so both planners start
from the same pose with the same noise streams.  Per run: the path length to 50/80/90/95 % coverage, the coverage at fixed path budgets,
F (free positive) of the final SLAM map and of its mean completion on the house's window (both planners' maps
completed by the same model), the CPU of every planning step.

Houses: the first ``--houses`` of Experiment 2's HouseExpo test list (the official test list shuffled with seed 0,
as the pair builder does, invalid plans skipped) and ``--procedural`` procedural apartments (a domain the nets were
not trained on).  ``--study`` instead runs the scoring variants (gain, trade-off, window margin) on houses of the
official *training* list that no net was trained on (the end of its shuffled order), where the defaults were
chosen: the test houses are not used to choose anything.

Reported: per domain, the mean path to 90 % coverage of both planners over the houses both finished, the mean
per-house difference with its 95 % t-interval, the relative saving ``1 − mean(mcn) / mean(frontier)`` with a paired
bootstrap 95 % interval, the houses one finished and the other did not, the coverage at each budget, map F, CPU per
planning step (mean, 95th percentile, max) and the wall time.  Writes ``benchmarks/results/explore.json`` (or
``explore_study.json``; ``--json`` elsewhere) and, beside it, a plot of the mean coverage against path length
(``explore_coverage.png``: the JSON's name with ``_coverage.png``).  ``--seed-offset`` runs the same houses on other
seeds.

    .venv/bin/python -m benchmarks.bench_explore [--houses 50] [--procedural 20] [--model NAME|PATH] [--jobs N]
    .venv/bin/python -m benchmarks.bench_explore --study [--study-houses 12] [--variants NAME ...]
    .venv/bin/python -m benchmarks.bench_explore --gain finish_share=0.9 --json /tmp/explore_pockets.json
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.common import RESULTS, data_dir
from mcnkit.app.commands.explore import DEFAULT_MODEL

GRID_STEP_M = 0.5
"""Spacing of the path lengths at which every run's coverage curve is kept (for the mean curves)."""
LEVEL = "0.9"
"""The coverage level of the headline figure."""


@dataclass(frozen=True)
class Task:
    """One run: a plan, a planner (and its scoring), a seed."""

    spec: str
    domain: str
    planner: str
    seed: int
    model: str
    variant: str = "default"
    gain: dict[str, Any] = field(default_factory=dict)
    explore: dict[str, Any] = field(default_factory=dict)
    window_probe: tuple[float, ...] = ()
    """Window margins [m] at which every planning step's map is also completed and scored (the window study)."""


TRUTH = "truth"
"""``--model truth``: the ``mcn`` planner's completion is the true plan (one sample; the cells the map knows keep
their label): what the scoring reaches with a perfect predictor.  Map F is then scored with ``sampler-explore``."""

_NETS: dict[str, Any] = {}
_RASTERS: dict[str, Any] = {}


def _net(model: str) -> Any:
    if model not in _NETS:
        from mcnkit.mcn import load_model

        _NETS[model] = load_model(model)
    return _NETS[model]


def truth_planner(raster: Any, gain: Any, range_m: float, generator: Any) -> Any:
    """An ``mcn`` planner whose completion of the map is the plan itself (see :data:`TRUTH`): the SLAM map's frame
    is the plan's (the robot starts at its true pose), so the plan pooled onto the window is what a perfect
    predictor would draw, up to the map's drift."""
    from mcnkit.explore.planners import McnPlanner, PlanningView
    from mcnkit.explore.predict import Prediction, choose_window
    from mcnkit.grid import pool_to_window
    from mcnkit.types import FREE, OCCUPIED, UNKNOWN, TernaryMap

    truth = TernaryMap(np.where(raster.free, FREE, OCCUPIED).astype(np.float32), raster.grid)

    class TruthPlanner(McnPlanner):
        def prediction(self, view: PlanningView) -> Prediction:
            lineage = view.lineage
            window = choose_window(lineage.seen_bounds_m(), self.config, 64, lineage.resolution_m, view.pose[:2])
            partial = lineage.pooled(window).astype(np.float32)
            plan = pool_to_window(truth, window, outside=OCCUPIED)
            return Prediction(window, partial, np.where(partial == UNKNOWN, plan, partial)[None].astype(np.float32))

    return TruthPlanner(None, gain, range_m, generator)  # type: ignore[arg-type]


def run_task(task: Task) -> dict[str, Any]:
    """Runs one exploration and returns its row (the curve on the path grid included)."""
    import torch

    from mcnkit.explore.config import ExploreConfig, GainConfig
    from mcnkit.explore.loop import Explorer, seed_streams
    from mcnkit.explore.metrics import coverage_at, coverage_curve, final_map_f, summarize
    from mcnkit.explore.planners import FrontierPlanner, McnPlanner, Planner
    from mcnkit.sim import SimConfig, plan_raster

    torch.set_num_threads(1)
    if task.spec not in _RASTERS:  # a study runs several variants on one house in a row
        _RASTERS.clear()
        _RASTERS[task.spec] = plan_raster(task.spec)
    raster = _RASTERS[task.spec]
    cfg, gain = ExploreConfig(**task.explore), GainConfig(**task.gain)
    planner: Planner = FrontierPlanner()
    net_model = "sampler-explore" if task.model == TRUTH else task.model
    if task.planner == "mcn":
        generator = torch.Generator().manual_seed(seed_streams(task.seed)[2])
        range_m = SimConfig().lidar.range_max_m
        planner = (truth_planner(raster, gain, range_m, generator) if task.model == TRUTH
                   else McnPlanner(_net(task.model), gain, range_m, generator))
    t0 = time.perf_counter()
    explorer = Explorer(raster, planner, cfg, seed=task.seed)
    probes: list[list[float]] = []
    while not explorer.done:
        record = explorer.step()
        if task.window_probe and record.decision is not None and explorer.lineage is not None:
            probes.append(window_probe(explorer, _net(net_model), task.window_probe, gain.samples))
    f_slam, f_done = final_map_f(explorer, _net(net_model), gain.samples, torch.Generator().manual_seed(task.seed))
    summary = summarize(explorer, f_slam, f_done)
    curve = coverage_curve(explorer.records)
    grid = np.arange(0.0, cfg.budget_m + 1e-9, GRID_STEP_M)
    return {**summary.as_dict(), "domain": task.domain, "variant": task.variant, "wall_s": time.perf_counter() - t0,
            "plan_cpu_s": [round(p.cpu_s, 4) for p in explorer.plans],
            "curve": [round(coverage_at(curve, float(b)), 4) for b in grid],
            "window_probe": {"margins_m": list(task.window_probe), "per_step": probes}}


def window_probe(explorer: Any, net: Any, margins: tuple[float, ...], samples: int) -> list[float]:
    """For each window margin: the IoU of free space on the cells unknown in the map, the samples against the
    plan (mean over the samples; exterior cells are walls), and the share of the house's unseen free area that
    the window holds, as ``[iou_0, share_0, iou_1, share_1, ...]``."""
    import torch

    from mcnkit.explore.config import GainConfig
    from mcnkit.explore.predict import choose_window, complete_on
    from mcnkit.grid import pool_to_window
    from mcnkit.types import FREE, OCCUPIED, UNKNOWN, TernaryMap

    raster, lineage = explorer.raster, explorer.lineage
    truth_map = TernaryMap(np.where(raster.free, FREE, OCCUPIED).astype(np.float32), raster.grid)
    unseen = raster.free & explorer.reachable & ~explorer.seen
    unseen_m2 = max(float(unseen.sum()) * raster.grid.resolution_m**2, 1e-9)
    out: list[float] = []
    for margin in margins:
        window = choose_window(lineage.seen_bounds_m(), GainConfig(window_margin_m=margin), 64, lineage.resolution_m)
        partial = lineage.pooled(window).astype(np.float32)
        truth = pool_to_window(truth_map, window, outside=OCCUPIED)
        drawn, _ = complete_on(net, partial, samples, torch.Generator().manual_seed(len(out)))
        unknown = partial == UNKNOWN
        pred_free, true_free = (drawn == FREE) & unknown, (truth == FREE) & unknown
        union = (pred_free | true_free).sum(axis=(1, 2))
        iou = np.where(union > 0, (pred_free & true_free).sum(axis=(1, 2)) / np.maximum(union, 1), np.nan)
        rc = np.argwhere(unseen)
        cells = window.world_to_cell(raster.grid.cell_to_world(rc))
        inside = float(window.contains(cells).sum()) * raster.grid.resolution_m**2
        out += [float(np.nanmean(iou)) if np.isfinite(iou).any() else float("nan"), inside / unseen_m2]
    return out


def test_house_ids(source: Path, splits: Path, n: int, seed: int = 0) -> list[str]:
    """Experiment 2's houses: the first ``n`` valid plans of the official test list shuffled with ``seed``."""
    from mcnkit.datasets.houseexpo import iter_plans, read_split

    rng = np.random.default_rng(seed)
    rng.permutation(read_split(splits / "map_id_train.txt"))  # the pair builder shuffles the training list first
    order = rng.permutation(read_split(splits / "map_id_test.txt")).tolist()
    return _first_valid(source, order, n, iter_plans)


def study_house_ids(source: Path, splits: Path, n: int, seed: int = 0) -> list[str]:
    """Training-list houses no net was trained on: the last ``n`` valid plans of the shuffled official training
    list (the nets' 16 000 training and 200 validation pairs come from its start)."""
    from mcnkit.datasets.houseexpo import iter_plans, read_split

    order = np.random.default_rng(seed).permutation(read_split(splits / "map_id_train.txt")).tolist()
    return _first_valid(source, order[::-1], n, iter_plans)


def _first_valid(source: Path, order: list[str], n: int, iter_plans: Any) -> list[str]:
    found: list[str] = []
    pos = 0
    while len(found) < n and pos < len(order):
        chunk = order[pos : pos + 2 * n]
        pos += len(chunk)
        valid = {p.id for p in iter_plans(source, chunk)}
        found += [i for i in chunk if i in valid][: n - len(found)]
    return found


def paired(rows: list[dict[str, Any]], other: str, level: str = LEVEL, seed: int = 0) -> dict[str, Any]:
    """Path to ``level`` coverage of ``other`` (a planner or study variant) against ``frontier`` over the same
    houses: means over the houses both finished, the per-house difference with its 95 % t-interval, the relative
    saving with a paired bootstrap 95 % interval, and the houses only one of them finished."""
    by = {(_name(r), r["map"]): r for r in rows}
    houses = sorted({m for (_, m) in by})
    a = np.array([by[("frontier", h)]["path_to_coverage_m"][level] if ("frontier", h) in by else None
                  for h in houses], float)
    b = np.array([by[(other, h)]["path_to_coverage_m"][level] if (other, h) in by else None for h in houses], float)
    both = np.isfinite(a) & np.isfinite(b)
    out: dict[str, Any] = {"houses": len(houses), "both_finished": int(both.sum()),
                           "only_frontier_finished": [h for h, x, y in zip(houses, a, b, strict=True)
                                                      if np.isfinite(x) and not np.isfinite(y)],
                           "only_other_finished": [h for h, x, y in zip(houses, a, b, strict=True)
                                                   if not np.isfinite(x) and np.isfinite(y)]}
    if both.sum() < 2:
        return out
    from scipy import stats

    x, y = a[both], b[both]
    d = y - x
    half = float(stats.t.ppf(0.975, len(d) - 1) * d.std(ddof=1) / np.sqrt(len(d)))
    idx = np.random.default_rng(seed).integers(0, len(d), (10_000, len(d)))
    boot = 1.0 - y[idx].mean(axis=1) / x[idx].mean(axis=1)
    out.update({"mean_frontier_m": float(x.mean()), "mean_other_m": float(y.mean()),
                "mean_difference_m": float(d.mean()),
                "difference_ci95_m": [float(d.mean() - half), float(d.mean() + half)],
                "saving": float(1.0 - y.mean() / x.mean()),
                "saving_ci95": [float(np.percentile(boot, 2.5)), float(np.percentile(boot, 97.5))],
                "houses_other_shorter": int((d < 0).sum())})
    return out


def _name(row: dict[str, Any]) -> str:
    """A run's planner, or its study variant."""
    return str(row["planner"] if row["variant"] == "default" else row["variant"])


def aggregate(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per variant (planner): mean coverage at each budget, mean map F, planning CPU."""
    out: dict[str, Any] = {}
    for name in sorted({_name(r) for r in rows}):
        sel = [r for r in rows if _name(r) == name]
        cpu = np.concatenate([np.asarray(r["plan_cpu_s"], float) for r in sel]) if sel else np.zeros(1)
        budgets = sel[0]["coverage_at_m"].keys()
        out[name] = {
            "runs": len(sel),
            "coverage_at_m": {b: float(np.mean([r["coverage_at_m"][b] for r in sel])) for b in budgets},
            "final_coverage": float(np.mean([r["coverage"] for r in sel])),
            "f_slam": float(np.mean([r["f_slam"] for r in sel])),
            "f_completed": float(np.mean([r["f_completed"] for r in sel])),
            "plan_cpu_s": {"mean": float(cpu.mean()), "p95": float(np.percentile(cpu, 95)), "max": float(cpu.max()),
                           "steps": int(cpu.size)},
            "run_cpu_s_mean": float(np.mean([r["cpu_s"] for r in sel])),
        }
    return out


def plot(rows: list[dict[str, Any]], path: Path, budget_m: float) -> None:
    """Mean coverage against path length, per domain and planner."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    domains = sorted({r["domain"] for r in rows})
    fig, axes = plt.subplots(1, len(domains), figsize=(5.5 * len(domains), 4), squeeze=False)
    grid = np.arange(0.0, budget_m + 1e-9, GRID_STEP_M)
    for ax, domain in zip(axes[0], domains, strict=True):
        for name, color in (("frontier", "tab:blue"), ("mcn", "tab:red")):
            curves = np.array([r["curve"] for r in rows if r["domain"] == domain and r["planner"] == name
                               and r["variant"] == "default"])
            if len(curves):
                ax.plot(grid[: curves.shape[1]], curves.mean(axis=0), color=color, label=f"{name} ({len(curves)})")
        ax.axhline(0.9, color="grey", lw=0.8, ls=":")
        ax.set(title=domain, xlabel="path length [m]", ylabel="mean coverage of the reachable free space",
               xlim=(0, budget_m), ylim=(0, 1.01))
        ax.legend(loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


STUDY_VARIANTS: dict[str, tuple[str, str | None, dict[str, Any], dict[str, Any]]] = {
    "unknown, ratio": ("mcn", None, {"gain": "unknown"}, {}),
    "unknown, ratio, goal kept": ("mcn", None, {"gain": "unknown", "commit": True}, {}),
    "unknown, ratio, margin 1 m": ("mcn", None, {"gain": "unknown", "window_margin_m": 1.0}, {}),
    "unknown, exp λ=0.1": ("mcn", None, {"gain": "unknown", "tradeoff": "exp", "cost_lambda_per_m": 0.1}, {}),
    "disagreement, ratio": ("mcn", None, {"gain": "disagreement"}, {}),
    "observed (no prediction), ratio": ("mcn", None, {"gain": "observed"}, {}),
    "frontier, goal re-chosen every step": ("frontier", None, {}, {"commit_m": 0.0}),
    "unknown, ratio, finished pockets twice": ("mcn", None, {"gain": "unknown", "finish_share": 0.9}, {}),
    "consensus walls, ratio": ("mcn", None, {"gain": "consensus"}, {}),
    "unknown, tour": ("mcn", None, {"gain": "unknown", "tradeoff": "tour"}, {}),
    "observed (no prediction), tour": ("mcn", None, {"gain": "observed", "tradeoff": "tour"}, {}),
    "unknown, regret": ("mcn", None, {"gain": "unknown", "tradeoff": "regret"}, {}),
    "open (samples' free area, known walls), ratio": ("mcn", None, {"gain": "open"}, {}),
    "observed (no prediction), finished pockets twice": ("mcn", None, {"gain": "observed", "finish_share": 0.9}, {}),
    "unknown, ratio, 50 % samples": ("mcn", None, {"gain": "unknown", "sample_share": 0.5}, {}),
    "unknown, ratio, keep +25 %": ("mcn", None, {"gain": "unknown", "keep_bonus": 0.25}, {}),
    "unknown, ratio, same noise": ("mcn", None, {"gain": "unknown", "same_noise": True}, {}),
    "unknown, ratio, same noise, keep +25 %": ("mcn", None, {"gain": "unknown", "same_noise": True,
                                                           "keep_bonus": 0.25}, {}),
    "unknown, ratio, local 2.5 m": ("mcn", None, {"gain": "unknown", "local_m": 2.5}, {}),
    "unknown, ratio, local 4 m": ("mcn", None, {"gain": "unknown", "local_m": 4.0}, {}),
    "unknown, ratio, K = 8": ("mcn", None, {"gain": "unknown", "samples": 8}, {}),
    "unknown, ratio, K = 64": ("mcn", None, {"gain": "unknown", "samples": 64}, {}),
    "unknown, ratio, empty goal let go": ("mcn", None, {"gain": "unknown"}, {"release_empty": True}),
    "unknown, nearest worth 1 m²": ("mcn", None, {"gain": "unknown", "tradeoff": "nearest"}, {}),
    "free, ratio": ("mcn", None, {"gain": "free"}, {}),
    "unknown, ratio, window and seen map only": ("mcn", None, {"gain": "unknown", "beyond_reach": False}, {}),
    "unknown, ratio, cost floor 0.25 m": ("mcn", None, {"gain": "unknown", "cost_floor_m": 0.25}, {}),
    "unknown, ratio, cost floor 0.5 m": ("mcn", None, {"gain": "unknown", "cost_floor_m": 0.5}, {}),
    "unknown, ratio, cost floor 2 m": ("mcn", None, {"gain": "unknown", "cost_floor_m": 2.0}, {}),
    "unknown, ratio, cost floor 4 m": ("mcn", None, {"gain": "unknown", "cost_floor_m": 4.0}, {}),
    "true plan: unknown, ratio": ("mcn", TRUTH, {"gain": "unknown"}, {}),
    "true plan: free, ratio": ("mcn", TRUTH, {"gain": "free"}, {}),
    "true plan: unknown, nearest worth 1 m²": ("mcn", TRUTH, {"gain": "unknown", "tradeoff": "nearest"}, {}),
}
"""The variants ``--study`` measures: name -> (planner; model, or None for ``--model``; GainConfig fields and
ExploreConfig fields over the defaults).  ``--study-models`` adds ``unknown, ratio`` and ``disagreement, ratio``
for each further model."""
WINDOW_MARGINS_M = (0.0, 1.0, 2.0, 4.0, 8.0)
"""The window margins the study scores at every planning step of the ``unknown, ratio`` runs."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--houses", type=int, default=50, help="HouseExpo test houses (Experiment 2's, first N)")
    ap.add_argument("--procedural", type=int, default=20, help="procedural apartments (seeds 1..N)")
    ap.add_argument("--model", default=DEFAULT_MODEL,
                    help=f"completion model (name or checkpoint path; default {DEFAULT_MODEL}); '{TRUTH}': the true plan, a "
                         "perfect predictor")
    ap.add_argument("--stop-coverage", type=float, default=0.95, help="end a run at this coverage")
    ap.add_argument("--budget-m", type=float, default=120.0, help="path budget of a run [m]")
    ap.add_argument("--jobs", type=int, default=1, help="runs in parallel (processes)")
    ap.add_argument("--study", action="store_true", help="the scoring variants on unused training-list houses")
    ap.add_argument("--study-houses", type=int, default=6, help="houses of the study")
    ap.add_argument("--study-models", nargs="*", default=[], help="further models the study compares")
    ap.add_argument("--variants", nargs="+", default=None, metavar="NAME",
                    help="the study's variants to run, by name (default: all of STUDY_VARIANTS); the frontier "
                         "baseline always runs")
    ap.add_argument("--data", default=None, help="shared data folder (default $MCNKIT_SHARED_DATA or ../shared/data)")
    ap.add_argument("--json", type=Path, default=None, help="output JSON (default results/explore[_study].json)")
    ap.add_argument("--seed-offset", type=int, default=0,
                    help="added to every run's seed, to measure the same houses on other start poses and noise "
                         "(default 0: a house's seed is its index)")
    ap.add_argument("--gain", action="append", default=[], metavar="FIELD=VALUE",
                    help="a GainConfig field of the mcn runs, e.g. --gain finish_share=0.9 (repeatable; default: none, "
                         "the defaults)")
    ap.add_argument("--explore", action="append", default=[], metavar="FIELD=VALUE",
                    help="an ExploreConfig field of the mcn runs (the frontier runs keep the defaults), e.g. --explore "
                         "release_empty=true (repeatable; default: none)")
    args = ap.parse_args()
    if args.variants and not args.study:
        ap.error("--variants chooses among the --study's variants; the test benchmark runs frontier and mcn")
    if (args.gain or args.explore) and args.study:
        ap.error("--gain and --explore set the mcn runs of the test benchmark; a --study's variants set their own "
                 "(STUDY_VARIANTS)")
    from mcnkit.explore.config import ExploreConfig, GainConfig

    mcn_gain = _config_options(ap, "--gain", GainConfig, args.gain)
    mcn_loop = _config_options(ap, "--explore", ExploreConfig, args.explore)
    t_start = time.perf_counter()
    from mcnkit.datasets.houseexpo import houseexpo_source

    shared = data_dir(args.data)
    source = houseexpo_source(None) or shared / "houseexpo" / "json.tar.gz"
    explore = {"stop_coverage": args.stop_coverage, "budget_m": args.budget_m}
    tasks: list[Task] = []
    variants = dict(STUDY_VARIANTS)
    for model in args.study_models:
        tag = Path(model).name
        variants |= {f"{tag}: unknown, ratio": ("mcn", model, {"gain": "unknown"}, {}),
                     f"{tag}: disagreement, ratio": ("mcn", model, {"gain": "disagreement"}, {})}
    if args.variants:
        unknown_names = [v for v in args.variants if v not in variants]
        if unknown_names:
            ap.error(f"--variants {' '.join(unknown_names)!r}: not a variant; the variants are "
                     + "; ".join(repr(v) for v in variants))
        variants = {v: variants[v] for v in args.variants}
    if args.study:
        ids = study_house_ids(source, shared / "houseexpo", args.study_houses)
        for k, i in enumerate(ids):
            seed = k + args.seed_offset
            tasks.append(Task(f"houseexpo:{i}", "houseexpo-train", "frontier", seed, args.model, explore=explore))
            tasks += [Task(f"houseexpo:{i}", "houseexpo-train", planner, seed, model or args.model, name, gain,
                           explore | loop, WINDOW_MARGINS_M if name == "unknown, ratio" else ())
                      for name, (planner, model, gain, loop) in variants.items()]
    else:
        ids = test_house_ids(source, shared / "houseexpo", args.houses)
        specs = [(f"houseexpo:{i}", "houseexpo-test") for i in ids]
        specs += [(f"procedural:{s}", "procedural") for s in range(1, args.procedural + 1)]
        for k, (spec, domain) in enumerate(specs):
            tasks += [Task(spec, domain, p, k + args.seed_offset, args.model, gain=mcn_gain if p == "mcn" else {},
                           explore=explore | mcn_loop if p == "mcn" else explore)
                      for p in ("frontier", "mcn")]
    rows: list[dict[str, Any]] = []
    if args.jobs > 1:
        import multiprocessing

        with ProcessPoolExecutor(args.jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
            for row in pool.map(run_task, tasks):
                rows.append(row)
                _print_row(row)
    else:
        for task in tasks:
            rows.append(run_task(task))
            _print_row(rows[-1])
    results: dict[str, Any] = {"benchmark": "bench_explore", "model": args.model, "explore": explore,
                               "explore_mcn": mcn_loop, "gain": mcn_gain,
                               "study": args.study, "seed_offset": args.seed_offset, "wall_s": None, "domains": {}}
    for domain in sorted({r["domain"] for r in rows}):
        sel = [r for r in rows if r["domain"] == domain]
        comparisons = {v: paired(sel, v) for v in (["mcn"] if not args.study else list(variants))}
        results["domains"][domain] = {"houses": sorted({r["map"] for r in sel}), "paired": comparisons,
                                      "aggregate": aggregate(sel), "window": window_table(sel)}
        _print_domain(domain, results["domains"][domain])
    results["wall_s"] = time.perf_counter() - t_start
    results["runs"] = rows
    out = args.json or RESULTS / ("explore_study.json" if args.study else "explore.json")
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(results, indent=1) + "\n")
    if not args.study:
        plot(rows, out.with_name(f"{out.stem}_coverage.png"), args.budget_m)
    print(f"wall time {results['wall_s'] / 60:.1f} min; wrote {out}")


def window_table(rows: list[dict[str, Any]]) -> dict[str, dict[str, float]]:
    """Per window margin, over every probed planning step: mean IoU of free space on the unknown cells, and the
    mean share of the house's unseen free area inside the window."""
    steps = [(r["window_probe"]["margins_m"], s) for r in rows if r.get("window_probe", {}).get("per_step")
             for s in r["window_probe"]["per_step"]]
    if not steps:
        return {}
    margins, values = steps[0][0], np.array([s for _, s in steps], float)
    return {f"{m:g}": {"iou_free_unknown": float(np.nanmean(values[:, 2 * j])),
                       "unseen_share_in_window": float(np.nanmean(values[:, 2 * j + 1])), "steps": len(values)}
            for j, m in enumerate(margins)}


def _config_options(ap: argparse.ArgumentParser, flag: str, cls: type, items: list[str]) -> dict[str, Any]:
    """``FIELD=VALUE`` strings as fields of the dataclass ``cls`` (values typed like the defaults); an unknown field
    or a value that does not parse ends with an error naming ``flag``."""
    from dataclasses import fields

    defaults = cls()
    types = {f.name: type(getattr(defaults, f.name)) for f in fields(cls)}
    out: dict[str, Any] = {}
    for item in items:
        name, _, value = item.partition("=")
        if name not in types or not value:
            ap.error(f"{flag} {item}: expected FIELD=VALUE with FIELD one of {', '.join(sorted(types))}")
        kind = types[name]
        try:
            out[name] = value.lower() in ("1", "true", "yes") if kind is bool else kind(value)
        except (TypeError, ValueError):
            ap.error(f"{flag} {item}: {value!r} is not a {kind.__name__}")
    try:
        cls(**out)
    except ValueError as err:
        ap.error(f"{flag}: {err}")
    return out


def _print_row(r: dict[str, Any]) -> None:
    p90 = r["path_to_coverage_m"][LEVEL]
    print(f"{r['map'][:30]:30s} {r['planner']:8s} {r['variant'][:34]:34s} {r['stop_reason']:8s} 90%: "
          f"{'   —' if p90 is None else f'{p90:5.1f}'} m  path {r['path_length_m']:5.1f} m  cov {r['coverage']:.3f}  "
          f"F {r['f_slam']:.3f}/{r['f_completed']:.3f}  plan CPU {1000 * np.mean(r['plan_cpu_s'] or [0]):.0f} ms",
          flush=True)


def _print_domain(domain: str, d: dict[str, Any]) -> None:
    print(f"\n== {domain}: {len(d['houses'])} houses")
    for name, p in d["paired"].items():
        if "saving" not in p:
            print(f"  {name}: too few houses finished by both ({p['both_finished']})")
            continue
        (lo, hi), (dlo, dhi) = p["saving_ci95"], p["difference_ci95_m"]
        print(f"  {name}: path to 90 % coverage {p['mean_frontier_m']:.1f} m (frontier) vs {p['mean_other_m']:.1f} m "
              f"over the {p['both_finished']} houses both finished: saving {100 * p['saving']:.1f} % (95 % CI "
              f"{100 * lo:.1f} to {100 * hi:.1f} %), difference {p['mean_difference_m']:.1f} m (95 % CI {dlo:.1f} to "
              f"{dhi:.1f}); shorter in {p['houses_other_shorter']}; not finished where frontier finished: "
              f"{len(p['only_frontier_finished'])}, finished where frontier did not: {len(p['only_other_finished'])}")
    for margin, v in d.get("window", {}).items():
        print(f"  window margin {margin} m: IoU of free space on unknown cells {v['iou_free_unknown']:.3f}, share of "
              f"the unseen free area inside the window {v['unseen_share_in_window']:.2f} ({v['steps']} steps)")
    for name, a in d["aggregate"].items():
        cov = ", ".join(f"{b} m {v:.2f}" for b, v in a["coverage_at_m"].items())
        print(f"  {name[:34]:34s} coverage at {cov}; F map {a['f_slam']:.3f}, completed {a['f_completed']:.3f}; "
              f"CPU per planning step {1000 * a['plan_cpu_s']['mean']:.0f} ms (p95 {1000 * a['plan_cpu_s']['p95']:.0f}, "
              f"max {1000 * a['plan_cpu_s']['max']:.0f})")


if __name__ == "__main__":
    main()
