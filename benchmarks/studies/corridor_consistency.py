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

The log's odometry is scored too, and every trajectory's steps are compared with the odometry's on the straight
drives (odometry step over 0.5 m, turn under 1.15°): the spread of the forward step about the odometry's, and the
roughness of the forward step (the spread of its change from one step to the next). A robot's wheels measure the
forward motion of a straight drive smoothly; a scan matcher in a corridor leaves it to whatever weak feature it
meets, so a trajectory rougher than the odometry carries that matcher's choices along the axis.

Printed and written to ``benchmarks/results/NAME_consistency.{md,json}``, with ``NAME_consistency.png``: the reference
path with its scan numbers, and each run's distance from the reference scan by scan (after the rigid alignment of
the ATE): where along the log the runs part from it and from each other.

    .venv/bin/python -m benchmarks.studies.corridor_consistency /path/infinite-corridor-corrected.log.gz [--seeds 0 1 2]
        [--jobs 2]    (default: seeds 0 to 9, one run at a time)
"""

from __future__ import annotations

import argparse
import itertools
import json
import subprocess
import sys
import tempfile
import warnings
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import TYPE_CHECKING

from benchmarks.common import RESULTS, SLAM_ENV, slam_command

if TYPE_CHECKING:
    import numpy as np


def _run(cmd: list[str], what: str) -> str:
    """Runs one mcnkit command; its stdout, or exits with one line naming ``what`` failed and why."""
    proc = subprocess.run(cmd, env=SLAM_ENV, capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"{what} failed: {(proc.stderr.strip().splitlines() or ['no message'])[-1]}")
    return proc.stdout


STRAIGHT_MIN_STEP_M = 0.5
"""A straight drive is an odometry step longer than this that turns less than ``STRAIGHT_MAX_TURN_RAD``."""
STRAIGHT_MAX_TURN_RAD = 0.02
"""The most a straight drive's odometry step turns (1.15°): there the wheels measure the forward motion best."""


def _odometry(log: Path, path: Path) -> None:
    """Writes the log's odometry, one pose per scan, as a TUM file at ``path``."""
    import numpy as np

    from mcnkit.io import open_log
    from mcnkit.metrics import Trajectory, write_tum

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the reader's notes on stamps: `mcnkit info` prints them
        with open_log(log) as reader:
            frames = list(reader.frames())
    write_tum(path, Trajectory(np.array([f.stamp_ns for f in frames], np.int64),
                               np.array([f.odom.as_array() for f in frames], np.float64)))


def _step_noise(poses: np.ndarray, odometry: np.ndarray) -> dict[str, float]:
    """On the odometry's straight drives, the spread (mm) of a trajectory's forward step about the odometry's and
    the roughness of its forward step (the spread of the change between consecutive straight steps, mm); both
    trajectories (N, 3) paired by order."""
    import numpy as np

    from mcnkit.geometry import relative

    n = min(len(poses), len(odometry))
    step, odo = relative(poses[: n - 1], poses[1:n]), relative(odometry[: n - 1], odometry[1:n])
    straight = (odo[:, 0] > STRAIGHT_MIN_STEP_M) & (np.abs(odo[:, 2]) < STRAIGHT_MAX_TURN_RAD)
    both = straight[1:] & straight[:-1]
    return {"straight_steps": int(straight.sum()),
            "forward_vs_odometry_std_mm": float(np.std((step[:, 0] - odo[:, 0])[straight]) * 1000),
            "forward_roughness_mm": float(np.std(np.diff(step[:, 0])[both]) * 1000)}


def _common_shape_ate(reference: np.ndarray, runs: list[np.ndarray]) -> float:
    """ATE (m) of the runs' mean path against the reference: every run (N, 3) aligned onto the reference (N, 3) by
    the rigid fit of the ATE, the positions averaged scan by scan, the mean aligned and scored again."""
    import numpy as np

    from mcnkit.metrics import align_rigid_2d

    n = min(len(reference), *(len(r) for r in runs))
    ref = reference[:n, :2]
    mean = np.mean([align_rigid_2d(r[:n, :2], ref) for r in runs], axis=0)
    return float(np.sqrt(np.mean(np.sum((align_rigid_2d(mean, ref) - ref) ** 2, axis=1))))


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
    parser.add_argument("--seeds", type=int, nargs="+", default=list(range(10)),
                        help="seeds of the runs (default 0 to 9)")
    parser.add_argument("--jobs", type=int, default=1, help="runs at a time (default 1; each run is one process)")
    parser.add_argument("--out", type=Path, default=None,
                        help="output stem (default benchmarks/results/NAME_consistency, NAME from the log's file name)")
    parser.add_argument("--slam-option", action="append", default=[], metavar="FLAG",
                        help="a flag passed on to every mcnkit slam run, repeatable; give it with '=' "
                             "(--slam-option=--slam.offline.whole-graph)")
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
        odometry = tmp / "odometry.tum"
        _odometry(args.log, odometry)

        def run(seed: int) -> Path:
            _run(slam_command(args.log, seed, tmp / f"seed{seed}", args.slam_option),
                 f"mcnkit slam {args.log} --seed {seed}")
            return tmp / f"seed{seed}" / "trajectory.tum"

        print(f"{name}: mcnkit slam at seeds {' '.join(map(str, args.seeds))}, {max(1, args.jobs)} at a time",
              flush=True)
        runs = {}
        with ThreadPoolExecutor(max(1, args.jobs)) as pool:
            for seed, path in zip(args.seeds, pool.map(run, args.seeds), strict=True):
                runs[f"seed {seed}"] = path
                print(f"{name}: seed {seed} done", flush=True)
        named = {"reference": ref, "odometry": odometry, **runs}
        scored = json.loads(_run([sys.executable, "-m", "mcnkit.app.main", "eval", "consistency", str(args.log),
                                  *map(str, named.values()), "--match", "order", "--no-progress", "--json"],
                                 f"mcnkit eval consistency {args.log}"))["trajectories"]
        consistency = {label: scored[str(path)] for label, path in named.items()}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tracks = {label: read_tum(path) for label, path in named.items()}
        ate = {f"{a} vs {b}": absolute_trajectory_error(tracks[b], tracks[a], match="order").rmse_m
               for a, b in itertools.combinations(named, 2)}
        steps = {label: _step_noise(track.poses, tracks["odometry"].poses) for label, track in tracks.items()}
        common = _common_shape_ate(tracks["reference"].poses, [tracks[label].poses for label in runs])
    _plot({k: v for k, v in tracks.items() if k != "odometry"}, Path(f"{out}.png"), name)
    lines = [f"# {name}: ATE against the reference beside agreement with the log's own scans",
             "", f"`python -m benchmarks.studies.corridor_consistency LOG --seeds {' '.join(map(str, args.seeds))}"
             f"{''.join(f' --slam-option={o}' for o in args.slam_option)}` "
             "(mean relation error, lower = agrees better; steps: on the odometry's "
             f"{steps['reference']['straight_steps']} straight drives, the forward step's spread about the odometry's "
             "and its roughness)",
             "", "| trajectory | ATE vs reference (m) | sequential (m / deg) | revisits (m / deg) | forward step vs "
             "odometry (mm) | forward roughness (mm) |", "|---|---|---|---|---|---|"]
    for label in named:
        c, st = consistency[label], steps[label]
        a = "–" if label == "reference" else f"{ate[f'reference vs {label}']:.3f}"
        rel = " | ".join(f"{c[k]['translation_mean_m']:.4f} / {c[k]['rotation_mean_deg']:.3f}"
                         if c[k]["translation_mean_m"] is not None else "–" for k in ("sequential", "revisits"))
        vs = "–" if label == "odometry" else f"{st['forward_vs_odometry_std_mm']:.1f}"
        lines.append(f"| {label} | {a} | {rel} | {vs} | {st['forward_roughness_mm']:.1f} |")
    to_ref = [ate[f"reference vs {label}"] for label in runs]
    between = sorted(ate[f"{a} vs {b}"] for a, b in itertools.combinations(runs, 2))
    lines += ["", f"Runs against the reference: mean {sum(to_ref) / len(to_ref):.3f} m, worst {max(to_ref):.3f} m, "
              f"{sum(v <= 0.30 for v in to_ref)} of {len(to_ref)} within 0.30 m."]
    lines.append(f"The runs' mean path (each run aligned onto the reference, the positions averaged scan by scan): "
                 f"{common:.3f} m from the reference, what is left once the runs' own scatter averages out.")
    if between:
        lines.append(f"ATE between the runs themselves ({len(between)} pairs): least {between[0]:.3f} m, median "
                     f"{between[len(between) // 2]:.3f} m, most {between[-1]:.3f} m.")
    text = "\n".join(lines) + "\n"
    print(text)
    Path(f"{out}.md").write_text(text)
    Path(f"{out}.json").write_text(json.dumps({"log": args.log.name, "seeds": args.seeds,
                                                    "slam_options": args.slam_option, "ate_m": ate,
                                                    "consistency": consistency, "steps": steps,
                                                    "mean_path_ate_m": common}, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
