"""Where do a log's own scans put the whole-log graph when it starts at the reference?

``--slam.offline.whole-graph`` (:func:`mcnkit.slam.wholegraph.whole_log_graph`) solves a run again as one pose
graph of scan matches and odometry, one node per filter update.  This study starts that graph, with its default
settings and the scans a default run updates at as its nodes (after 1 m of driving or 0.5 rad of turning by the
odometry, as :class:`mcnkit.slam.config.UpdatesConfig` says), at the log's *reference* poses instead of a run's, and
solves it twice:

* **with the odometry**: what ``mcnkit slam`` gives the graph;
* **with the reference's own steps in place of the odometry** (every step linked, stated as precise as odometry):
  the graph is then handed the reference's step lengths and turns, and only the scan matches (neighbours and
  revisits) can move it.

The ATE of each solution (its nodes) against the reference is how far the graph's optimum nearest the reference
lies from it.  Where that exceeds a target, starting a run closer to the reference cannot help: the scan matches
(and the odometry) themselves disagree with the reference by that much, and either they or the reference carry a
systematic error (a single log cannot say which; on a building whose walls come out thinner on the reference, it is
the matches).  Where it is small, a run that misses the reference misses it by starting too far away.  Beside it, the
odometry steps the graph keeps, of the steps it links: a step the rest of the graph contradicts (χ² above 9) is
dropped, the reference's own steps too.

Printed and written to ``benchmarks/results/graph_at_reference.{md,json}``.

    .venv/bin/python -m benchmarks.studies.graph_at_reference [--only aces intel] [--extra LOG ...] [--data DIR]
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

from benchmarks.common import BUILDINGS, RESULTS, data_dir

if TYPE_CHECKING:
    import numpy as np

    from mcnkit.types import Frame, Trajectory

OUT = RESULTS / "graph_at_reference"
"""Output stem (``.md`` and ``.json``)."""


def read_with_reference(log: Path) -> tuple[list[Frame], Trajectory]:
    """A log's frames and its reference trajectory; exits with one line where the reference is not one pose per scan."""
    from mcnkit.io import open_log

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reader's notes on stamps: `mcnkit info` prints them
        with open_log(log) as reader:
            frames = list(reader.frames())
            truth = reader.ground_truth()
    if truth is None or len(truth.poses) != len(frames):
        raise SystemExit(f"{log}: needs one reference pose per scan ({len(frames)} scans, "
                         f"{0 if truth is None else len(truth.poses)} reference poses)")
    return frames, truth


def solve_at_reference(frames: list[Frame], reference: np.ndarray, odometry: np.ndarray, *,
                       reference_steps: bool = True) -> dict:
    """The whole-log graph started at the reference poses (N, 3), on the scans a default run updates at, solved with
    the odometry chain ``odometry`` (N, 3; one pose per scan, the log's or a stand-in) and, with ``reference_steps``,
    again with the reference's own steps in its place: each solution's ATE against the reference (m), the graph's
    edge counts and CPU seconds."""
    import numpy as np

    from mcnkit.geometry import relative
    from mcnkit.metrics import align_rigid_2d
    from mcnkit.slam.config import OfflineConfig, UpdatesConfig
    from mcnkit.slam.wholegraph import WholeGraphScans, odometry_links, whole_log_graph

    known = np.array([f.odom_known for f in frames[1:]], bool)
    step = relative(odometry[:-1], odometry[1:])
    step[~known] = relative(reference[:-1], reference[1:])[~known]  # where the filter finds the motion itself
    nodes, linear_m, angular_rad, updates = [0], 0.0, 0.0, UpdatesConfig()
    for k in range(1, len(frames)):
        linear_m += float(np.hypot(*step[k - 1, :2]))
        angular_rad += abs(float(step[k - 1, 2]))
        if linear_m >= updates.linear_m or angular_rad >= updates.angular_rad:
            nodes.append(k)
            linear_m = angular_rad = 0.0
    at = np.asarray(nodes)
    odom_links = odometry_links(at, np.r_[False, known])
    ref = reference[at]
    spec = frames[0].scan.spec
    config = OfflineConfig()
    scans = WholeGraphScans([frames[k].scan.ranges_m for k in at], spec.angles_rad, spec.base_to_laser.as_array(),
                            min(spec.range_max_m - 0.01, config.max_range_m))  # as `mcnkit slam` hands them over

    def ate(poses: np.ndarray) -> float:
        return float(np.sqrt(np.mean(np.sum((align_rigid_2d(poses[:, :2], ref[:, :2]) - ref[:, :2]) ** 2, axis=1))))

    out: dict = {"scans": len(frames), "nodes": len(at), "odometry_links": int(odom_links.sum())}
    variants = [("with_odometry", odometry[at], odom_links)]
    if reference_steps:
        variants.append(("with_reference_steps", ref, np.ones(len(at) - 1, bool)))
    for key, steps, links in variants:
        start = time.process_time()
        solved, stats = whole_log_graph(ref, scans, steps, links, config)
        out[key] = {"ate_m": ate(solved), "cpu_s": time.process_time() - start, "step_edges": stats.step_edges,
                    "revisit_edges": stats.revisit_edges, "odometry_edges": stats.odometry_edges}
    return out


def _solve(log: Path) -> dict:
    """Both solutions for one log, with the log's own odometry (:func:`solve_at_reference`)."""
    import numpy as np

    frames, truth = read_with_reference(log)
    return solve_at_reference(frames, truth.poses, np.array([f.odom.as_array() for f in frames]))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    with_poses = [name for name, (_, relations) in BUILDINGS.items() if relations is None]
    parser.add_argument("--only", nargs="+", choices=with_poses,
                        help="a subset of the buildings with reference poses (default: all of them; with --extra: "
                             "none but those logs)")
    parser.add_argument("--extra", type=Path, nargs="+", default=[], metavar="LOG",
                        help="more logs with one reference pose per scan, named by their file (e.g. the MIT Infinite "
                             "Corridor of github.com/acschaefer/ple, data/carmen)")
    parser.add_argument("--data", help="the shared data folder (default: $MCNKIT_SHARED_DATA, else ../shared/data)")
    parser.add_argument("--out", type=Path, default=OUT,
                        help=f"output stem (default {OUT.relative_to(RESULTS.parents[1])})")
    args = parser.parse_args()
    data = data_dir(args.data)
    logs = {name: data / BUILDINGS[name][0] for name in (args.only or ([] if args.extra else with_poses))}
    for log in args.extra:
        if not log.exists():
            parser.error(f"--extra {log}: no such file")
        logs[log.name.split(".")[0].removesuffix("-corrected")] = log
    results = {}
    for name, log in logs.items():
        results[name] = _solve(log)
        r = results[name]
        print(f"{name:>20}: with odometry {r['with_odometry']['ate_m']:.3f} m, with the reference's steps "
              f"{r['with_reference_steps']['ate_m']:.3f} m", flush=True)
    lines = ["# The whole-log graph started at the reference", "",
             "`python -m benchmarks.studies.graph_at_reference"
             + (f" --only {' '.join(args.only)}" if args.only else "")
             + (f" --extra {' '.join(p.name for p in args.extra)}" if args.extra else "")
             + "`: the nodes a default run updates at, `OfflineConfig` defaults; ATE RMSE (m) of the solution's "
             "nodes against the reference it started from.", "",
             "| log | scans / nodes | with its odometry | with the reference's steps as odometry | "
             "step / revisit edges | odometry edges kept, of the links | CPU s |",
             "|---|---|---|---|---|---|---|"]
    for name, r in results.items():
        a, b = r["with_odometry"], r["with_reference_steps"]
        lines.append(f"| {name} | {r['scans']} / {r['nodes']} | {a['ate_m']:.3f} | {b['ate_m']:.3f} | "
                     f"{a['step_edges']} / {a['revisit_edges']} | {a['odometry_edges']} / {b['odometry_edges']} of "
                     f"{r['odometry_links']} | {a['cpu_s']:.0f} / {b['cpu_s']:.0f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{args.out}.md").write_text(text)
    Path(f"{args.out}.json").write_text(json.dumps(results, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
