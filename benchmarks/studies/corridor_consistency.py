"""Is a log's reference a fair judge of a few tenths of a metre?  ATE against it, beside how well each trajectory
agrees with the log's own scans.

For one log with a reference (a Radish corrected log, e.g. the MIT Infinite Corridor of the public acschaefer/ple
repository, not in ``../shared``): runs the documented ``mcnkit slam`` at each seed, then scores every run and the
reference itself with ``mcnkit eval consistency`` (relations the scans measure: sequential pairs for the local shape,
revisits for the global one; lower agrees better) and the runs' ATE against the reference and against each other,
every trajectory paired with the scans by order (one pose per scan).
Where the runs agree with the scans as well as the reference does or better, yet differ from it and from each other
by more than a target, that target measures the reference's choices along directions the scans leave open (a
corridor's axis), not the SLAM.

Printed and written to ``benchmarks/results/NAME_consistency.{md,json}``, with ``NAME_consistency.png``: the reference
path with its scan numbers, and each run's distance from the reference scan by scan (after the rigid alignment of
the ATE): where along the log the runs part from it and from each other.

    .venv/bin/python -m benchmarks.studies.corridor_consistency /path/infinite-corridor-corrected.log.gz [--seeds 0 1 2]
"""

from __future__ import annotations

import argparse
import itertools
import json
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

from benchmarks.common import RESULTS, SLAM_ENV, slam_command


def _run(cmd: list[str], what: str) -> str:
    """Runs one mcnkit command; its stdout, or exits with one line naming ``what`` failed and why."""
    proc = subprocess.run(cmd, env=SLAM_ENV, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{what} failed: {(proc.stderr.strip().splitlines() or ['no message'])[-1]}")
    return proc.stdout


def _plot(tracks: dict, path: Path, name: str) -> None:
    """The reference path (scan numbers every 100 scans) and each run's distance from it, scan by scan."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from mcnkit.metrics import align_rigid_2d

    ref = tracks["reference"].poses[:, :2]
    fig, (ax_map, ax_err) = plt.subplots(1, 2, figsize=(14, 6), gridspec_kw={"width_ratios": [1, 1.3]})
    ax_map.plot(ref[:, 0], ref[:, 1], "k-", lw=0.6)
    for i in range(0, len(ref), 100):
        ax_map.annotate(str(i), ref[i], fontsize=7, color="tab:red")
    ax_map.set(aspect="equal", title=f"{name}: the reference, scan numbers", xlabel="x (m)", ylabel="y (m)")
    for label, track in tracks.items():
        if label == "reference":
            continue
        est = track.poses[:, :2]
        n = min(len(est), len(ref))  # paired by order, as the ATE is
        err = np.hypot(*(align_rigid_2d(est[:n], ref[:n]) - ref[:n]).T)
        ax_err.plot(np.arange(n), err, lw=0.8, label=f"{label} (ATE {np.sqrt(np.mean(err**2)):.2f} m)")
    ax_err.set(title="distance from the reference after the rigid alignment", xlabel="scan", ylabel="m")
    ax_err.grid(alpha=0.3)
    ax_err.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("log", type=Path, help="a log with one reference pose per scan (a Radish corrected log)")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="seeds of the runs (default 0 1 2)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output stem (default benchmarks/results/NAME_consistency, NAME from the log's file name)")
    args = parser.parse_args()
    if not args.log.exists():
        parser.error(f"log {args.log}: no such file")
    from mcnkit.metrics import absolute_trajectory_error, read_tum

    name = args.log.name.split(".")[0].removesuffix("-corrected")
    out = args.out or RESULTS / f"{name}_consistency"
    with tempfile.TemporaryDirectory() as tmp_dir:
        tmp = Path(tmp_dir)
        ref = tmp / "reference.tum"
        _run([sys.executable, "-m", "mcnkit.app.main", "eval", "groundtruth", str(args.log), str(ref)],
             f"mcnkit eval groundtruth {args.log}")
        runs = {}
        for seed in args.seeds:
            print(f"{name}: mcnkit slam seed {seed}", flush=True)
            _run(slam_command(args.log, seed, tmp / f"seed{seed}"), f"mcnkit slam {args.log} --seed {seed}")
            runs[f"seed {seed}"] = tmp / f"seed{seed}" / "trajectory.tum"
        named = {"reference": ref, **runs}
        scored = json.loads(_run([sys.executable, "-m", "mcnkit.app.main", "eval", "consistency", str(args.log),
                                  *map(str, named.values()), "--match", "order", "--no-progress", "--json"],
                                 f"mcnkit eval consistency {args.log}"))["trajectories"]
        consistency = {label: scored[str(path)] for label, path in named.items()}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tracks = {label: read_tum(path) for label, path in named.items()}
        ate = {f"{a} vs {b}": absolute_trajectory_error(tracks[b], tracks[a], match="order").rmse_m
               for a, b in itertools.combinations(named, 2)}
    _plot(tracks, Path(f"{out}.png"), name)
    lines = [f"# {name}: ATE against the reference beside agreement with the log's own scans",
             "", "`python -m benchmarks.studies.corridor_consistency LOG` (mean relation error, lower = agrees better)",
             "", "| trajectory | ATE vs reference (m) | sequential (m / deg) | revisits (m / deg) |", "|---|---|---|---|"]
    for label in named:
        c = consistency[label]
        a = "–" if label == "reference" else f"{ate[f'reference vs {label}']:.3f}"
        lines.append(f"| {label} | {a} | {c['sequential']['translation_mean_m']:.4f} / "
                     f"{c['sequential']['rotation_mean_deg']:.3f} | {c['revisits']['translation_mean_m']:.4f} / "
                     f"{c['revisits']['rotation_mean_deg']:.3f} |")
    lines += ["", "ATE between the runs themselves (m): " + ", ".join(
        f"{k} {v:.3f}" for k, v in ate.items() if not k.startswith("reference"))]
    text = "\n".join(lines) + "\n"
    print(text)
    Path(f"{out}.md").write_text(text)
    Path(f"{out}.json").write_text(json.dumps({"log": args.log.name, "seeds": args.seeds, "ate_m": ate,
                                                    "consistency": consistency}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
