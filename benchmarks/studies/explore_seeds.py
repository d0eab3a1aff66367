"""How much of the exploration benchmark's saving is the draw of start poses and noise?  ``bench_explore`` runs on
other seed sets, pooled.

``bench_explore`` gives each house one seed (its index); ``--seed-offset N`` runs the same houses from other start
poses with other sensor, odometry, filter and sampler noise.  This study reads several such JSON reports and prints,
per domain, each seed set's saving at 90 % coverage (``1 − mean(mcn) / mean(frontier)`` over the runs both
finished) and the pooled saving over all of them, with a 95 % interval from a bootstrap that resamples *houses*
(each with all its seed sets: the runs of one house are not independent), the runs where ``mcn`` is shorter and
the runs only the frontier planner finished.  Written to ``--out`` as JSON.

    .venv/bin/python -m benchmarks.bench_explore --jobs 2 --seed-offset 100 --json benchmarks/results/explore_seed100.json
    .venv/bin/python -m benchmarks.studies.explore_seeds benchmarks/results/explore.json \\
        benchmarks/results/explore_seed100.json benchmarks/results/explore_seed200.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks.bench_explore import LEVEL
from benchmarks.common import RESULTS


def pooled(reports: list[dict[str, Any]], domain: str, level: str = LEVEL, seed: int = 0) -> dict[str, Any]:
    """Per seed set and pooled saving of ``mcn`` against ``frontier`` on one domain (see the module); the reports
    without a run of that domain (``bench_explore --procedural 0``) are left out."""
    sets: list[dict[str, tuple[float, float]]] = []
    offsets: list[int] = []
    unfinished = 0
    for report in reports:
        if not any(r["domain"] == domain for r in report["runs"]):
            continue
        offsets.append(report.get("seed_offset", 0))
        by = {(r["planner"], r["map"]): r["path_to_coverage_m"][level] for r in report["runs"]
              if r["domain"] == domain and r.get("variant", "default") == "default"}
        pairs = {}
        for (planner, house), value in by.items():
            if planner != "frontier":
                continue
            other = by.get(("mcn", house))
            if value is not None and other is not None:
                pairs[house] = (float(value), float(other))
            elif value is not None:
                unfinished += 1
        sets.append(pairs)
    houses = sorted(set().union(*sets))
    frontier = np.array([[s.get(h, (np.nan, np.nan))[0] for s in sets] for h in houses])
    mcn = np.array([[s.get(h, (np.nan, np.nan))[1] for s in sets] for h in houses])
    idx = np.random.default_rng(seed).integers(0, len(houses), (10_000, len(houses)))
    boot = 1.0 - np.nanmean(mcn[idx].reshape(len(idx), -1), axis=1) / np.nanmean(frontier[idx].reshape(len(idx), -1),
                                                                                  axis=1)
    return {"domain": domain, "houses": len(houses), "seed_sets": len(sets),
            "seed_offsets": offsets,
            "saving_per_set": [float(1.0 - np.nanmean(mcn[:, j]) / np.nanmean(frontier[:, j]))
                               for j in range(len(sets))],
            "runs_both_finished": int(np.isfinite(mcn - frontier).sum()),
            "saving": float(1.0 - np.nanmean(mcn) / np.nanmean(frontier)),
            "saving_ci95": [float(np.percentile(boot, 2.5)), float(np.percentile(boot, 97.5))],
            "runs_mcn_shorter": int(np.nansum(mcn < frontier)), "runs_only_frontier_finished": unfinished}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("reports", nargs="+", type=Path, help="bench_explore JSON reports, one per seed set")
    ap.add_argument("--out", type=Path, default=RESULTS / "explore_seeds.json",
                    help="the pooled report (default benchmarks/results/explore_seeds.json)")
    args = ap.parse_args()
    reports = []
    for path in args.reports:
        try:
            report = json.loads(path.read_text())
        except (OSError, ValueError) as err:
            ap.error(f"{path}: not a readable JSON report ({type(err).__name__})")
        if not isinstance(report, dict) or not isinstance(report.get("runs"), list):
            ap.error(f"{path}: not a bench_explore report (no 'runs')")
        reports.append(report)
    domains = sorted({r["domain"] for report in reports for r in report["runs"]})
    summaries = {d: pooled(reports, d) for d in domains}
    out = {"reports": [str(p) for p in args.reports],
           "seed_offsets": [report.get("seed_offset", 0) for report in reports], "domains": summaries}
    for d, s in summaries.items():
        per_set = " / ".join(f"{100 * x:.1f}" for x in s["saving_per_set"])
        print(f"{d}: saving per seed set {per_set} %; pooled {100 * s['saving']:.1f} % (95 % CI "
              f"{100 * s['saving_ci95'][0]:.1f} to {100 * s['saving_ci95'][1]:.1f} %, houses resampled) over "
              f"{s['runs_both_finished']} runs both finished; mcn shorter in {s['runs_mcn_shorter']}; only frontier "
              f"finished: {s['runs_only_frontier_finished']}")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
