"""How often is a sparse log placed without odometry, with and without counting unseen returns as unknown?

A lidar-only run on a log that keeps one scan per metre is decided by a few ambiguous scans, so three seeds say
little.  This runs the documented ``mcnkit slam LOG`` (30 particles, 0.05 m) with ``--slam.motion.odometry ignore`` on each log for every seed and every
``--slam.motion.unseen-explains`` value given, scores ``trajectory.tum`` by ATE against the log's reference, and
counts the runs under ``--placed-m`` (0.3 m).  Logs not in the shared data (the other Radish corrected logs of
github.com/acschaefer/ple, ``data/carmen``) are given by path with ``--extra``.

Printed and written to ``benchmarks/results/lidar_unseen_seeds.{md,json}`` (``--out`` elsewhere).

    .venv/bin/python -m benchmarks.studies.lidar_unseen_seeds --seeds 3 4 5 6 7 8 9 --jobs 2 \\
        --extra /path/seattle-corrected.log.gz /path/belgioioso-corrected.log.gz
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from benchmarks.common import RESULTS, SLAM_ENV, data_dir, slam_command

DEFAULT_LOGS = ("reallab/radish/aces-corrected.log.gz", "reallab/radish/fhw-corrected.log.gz",
                "reallab/intel/intel-corrected.log.gz", "reallab/radish/freiburg-101-corrected.log.gz")
"""The sparse logs of the shared data (about one scan per metre or per turn)."""


def _name(log: Path) -> str:
    return log.name.removesuffix(".gz").removesuffix(".log").removesuffix("-corrected")


def run_one(log: Path, seed: int, value: float, work: Path) -> float:
    """ATE RMSE [m] of one lidar-only run."""
    from mcnkit.io import open_log
    from mcnkit.metrics import absolute_trajectory_error, read_tum

    out = work / f"{_name(log)}_{seed}_{value:g}"
    options = ("--slam.motion.odometry", "ignore", "--slam.motion.unseen-explains", str(value), "--overwrite")
    subprocess.run(slam_command(log, seed, out, options), check=True, capture_output=True, env=SLAM_ENV)
    with open_log(log) as reader:
        reference = reader.ground_truth()
    return float(absolute_trajectory_error(read_tum(out / "trajectory.tum"), reference, match="order").rmse_m)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[3, 4, 5, 6, 7, 8, 9], help="filter seeds (default 3-9)")
    ap.add_argument("--values", type=float, nargs="+", default=[0.0, 0.5],
                    help="--slam.motion.unseen-explains values to compare (default 0 0.5)")
    ap.add_argument("--extra", type=Path, nargs="*", default=[], help="more logs with a reference, by path")
    ap.add_argument("--placed-m", type=float, default=0.3, help="a run under this ATE counts as placed (default 0.3)")
    ap.add_argument("--jobs", type=int, default=2, help="runs at once (default 2)")
    ap.add_argument("--data", default=None, help="shared data folder (default $MCNKIT_SHARED_DATA or ../shared/data)")
    ap.add_argument("--out", type=Path, default=RESULTS / "lidar_unseen_seeds", help="output stem (.md, .json)")
    args = ap.parse_args()
    for p in args.extra:
        if not p.is_file():
            ap.error(f"--extra {p}: no such file")
    logs = [data_dir(args.data) / rel for rel in DEFAULT_LOGS] + list(args.extra)
    jobs = [(log, seed, value) for log in logs for value in args.values for seed in args.seeds]
    with tempfile.TemporaryDirectory() as tmp, ThreadPoolExecutor(args.jobs) as pool:
        ates = list(pool.map(lambda j: run_one(*j, Path(tmp)), jobs))
    table: dict[str, dict[str, list[float]]] = {}
    for (log, _seed, value), ate in zip(jobs, ates, strict=True):
        table.setdefault(_name(log), {}).setdefault(f"{value:g}", []).append(ate)
    lines = [f"# Lidar-only runs placed, by `--slam.motion.unseen-explains` (seeds {' '.join(map(str, args.seeds))})",
             "", f"ATE RMSE (m) of `mcnkit slam LOG --slam.motion.odometry ignore --seed S`; placed: under "
             f"{args.placed_m} m.", "", "| log | " + " | ".join(f"unseen {v:g}" for v in args.values) + " |",
             "|---|" + "---|" * len(args.values)]
    totals = {f"{v:g}": 0 for v in args.values}
    for name, by_value in table.items():
        cells = []
        for v, runs in by_value.items():
            placed = sum(a < args.placed_m for a in runs)
            totals[v] += placed
            cells.append(" / ".join(f"{a:.3f}" if a < 10 else f"{a:.1f}" for a in runs) + f" ({placed} placed)")
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    lines += ["", "Placed in all: " + ", ".join(f"unseen {v}: {n} of {len(logs) * len(args.seeds)}"
                                               for v, n in totals.items()) + "."]
    text = "\n".join(lines) + "\n"
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.with_suffix(".md").write_text(text)
    args.out.with_suffix(".json").write_text(json.dumps({"seeds": args.seeds, "placed_m": args.placed_m,
                                                         "ate_m": table, "placed": totals}, indent=1))
    print(f"wrote {args.out.with_suffix('.md')}")


if __name__ == "__main__":
    main()
