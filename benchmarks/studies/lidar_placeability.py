"""Which scans can a matcher place without odometry?  Measured on the reference's own map.

For every scan of a building, the map of the scans before it is built from the *reference* poses (the best map the
log can give: no SLAM error in it), and the scan is searched for on that map as the lidar-only tracking searches
for it (:func:`mcnkit.slam.correlative.match_scan`, the wide search's likelihood field: 0.1 m cells, σ 0.15 m),
around its true pose, over ± ``--window-m`` and the log's heading reach (twice the largest turn between two scans of
the reference, at most ±180°).  Each scan is then

* **placed**: no pose farther than 0.3 m or 5° from the truth explains the scan within 5 % as well as the truth
  (score: mean likelihood of the scan's points, one per field cell; the truth's score is its best within 0.1 m and
  1°);
* **ambiguous**: a pose that far explains it about as well, at least 95 % but less than ``1 / wide.jump_ratio``
  (1.25) times as well: only a motion prior can tell them apart (a corridor's axis, look-alike rooms);
* **misplaced**: a pose that far explains it 1.25 times better than the truth or more: with hits-only scoring,
  even a motion prior that knew the true motion would be outvoted (new territory the scan sees while a wrong pose
  lays it onto known walls).

Beside them, what the motion prior can do: the steps a constant-step prior (the true step before) misses by more
than 0.5 m or 15°, and the ambiguous scans among them, which neither the map nor such a prior places.

Printed and written to ``benchmarks/results/lidar_placeability.{md,json}``.  A building whose misplaced scans
come in a run no prior bridges cannot be mapped without odometry by this kind of matcher.

    .venv/bin/python -m benchmarks.studies.lidar_placeability [--only intel aces] [--data DIR]
    .venv/bin/python -m benchmarks.studies.lidar_placeability --only intel --compare RUN/trajectory.tum --out /tmp/p
"""

from __future__ import annotations

import argparse
import json
import math
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from benchmarks.common import BUILDINGS, RESULTS, data_dir
from mcnkit.geometry import compose, relative, wrap_angle
from mcnkit.io import open_log
from mcnkit.metrics import read_tum
from mcnkit.slam.correlative import likelihood_grid, match_scan, thin_points
from mcnkit.slam.scanmatch import beam_points

FAR_M, FAR_RAD, NEAR_RATIO, JUMP = 0.3, math.radians(5.0), 0.95, 1.25
PRIOR_MISS_M, PRIOR_MISS_RAD = 0.5, math.radians(15.0)
FIELD_RES_M, FIELD_SIGMA_M, MAP_RADIUS_M = 0.1, 0.15, 20.0


@dataclass(frozen=True)
class Placeability:
    """One building's counts."""

    building: str
    scans: int
    placed: int
    longest_misplaced_run: int
    reach_rad: float
    misplaced_scans: list[int]
    ambiguous_scans: list[int]
    prior_misses: int
    """Steps a constant-step prior misses by more than PRIOR_MISS_M or PRIOR_MISS_RAD (the true step against the
    one before it)."""
    ambiguous_after_miss: int
    """Ambiguous scans whose step the prior misses that far: neither the map nor the prior places them."""

    @property
    def ambiguous(self) -> int:
        """How many scans are ambiguous."""
        return len(self.ambiguous_scans)

    @property
    def misplaced(self) -> int:
        """How many scans are misplaced."""
        return len(self.misplaced_scans)

    def label(self, scan: int) -> str:
        """``placed``, ``ambiguous`` or ``misplaced``: what the study found for scan number ``scan``."""
        return "ambiguous" if scan in self.ambiguous_scans else "misplaced" if scan in self.misplaced_scans else "placed"


def _far_best(grid: object, scan: np.ndarray, truth: np.ndarray, window_m: float, reach_rad: float) -> float:
    """The best score of a pose farther than FAR_M or FAR_RAD from ``truth``: four boxes around it over every
    heading, and the centre box over the headings beyond FAR_RAD."""
    w = window_m
    best = 0.0
    for box in ((-w, -FAR_M, -w, w), (FAR_M, w, -w, w), (-FAR_M, FAR_M, -w, -FAR_M), (-FAR_M, FAR_M, FAR_M, w)):
        best = max(best, match_scan(grid, scan, truth, box, reach_rad).score)  # type: ignore[arg-type]
    half = 0.5 * (reach_rad - FAR_RAD)
    if half > 0:
        for sign in (-1.0, 1.0):
            centre = truth + np.array([0.0, 0.0, sign * (FAR_RAD + half)])
            best = max(best, match_scan(grid, scan, centre, (-FAR_M, FAR_M, -FAR_M, FAR_M), half).score)  # type: ignore[arg-type]
    return best


def building(name: str, log: str, window_m: float) -> Placeability:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with open_log(log) as reader:
            frames = list(reader.frames())
            ref = reader.ground_truth()
    if ref is None or len(ref) != len(frames):
        raise SystemExit(f"{name}: needs one reference pose per scan")
    poses = ref.poses
    steps = relative(poses[:-1], poses[1:])
    reach_rad = float(min(math.pi, 2.0 * np.abs(steps[:, 2]).max()))
    spec = frames[0].scan.spec
    rmax = spec.range_max_m - 0.01
    laser = spec.base_to_laser.as_array()
    world = []
    for f, p in zip(frames, poses, strict=True):
        end, _ = beam_points(f.scan.ranges_m, spec.angles_rad, laser, rmax, rmax, 0.0)
        world.append(thin_points(compose(p, np.c_[end, np.zeros(len(end))])[:, :2], 0.5 * FIELD_RES_M))
    labels = []
    for k in range(1, len(frames)):
        centre = poses[k, :2]
        reach = MAP_RADIUS_M + window_m + 2.0
        close = np.flatnonzero(np.hypot(*(poses[:k, :2] - centre).T) <= reach + rmax)
        near = [world[j][np.hypot(world[j][:, 0] - centre[0], world[j][:, 1] - centre[1]) <= reach] for j in close]
        pts = np.concatenate(near) if near else np.zeros((0, 2))
        end, _ = beam_points(frames[k].scan.ranges_m, spec.angles_rad, laser, rmax, rmax, 0.0)
        scan = thin_points(end, FIELD_RES_M)
        scan = scan[np.hypot(scan[:, 0], scan[:, 1]) <= MAP_RADIUS_M]
        if len(pts) < 20 or len(scan) < 20:
            labels.append("placed")
            continue
        grid = likelihood_grid(pts, FIELD_RES_M, FIELD_SIGMA_M, FIELD_RES_M, depth=5)
        true_score = match_scan(grid, scan, poses[k], 0.1, math.radians(1.0)).score
        far = _far_best(grid, scan, poses[k], window_m, reach_rad)
        labels.append("misplaced" if far >= JUMP * true_score else "ambiguous" if far >= NEAR_RATIO * true_score
                      else "placed")
    run = longest = 0
    for label in labels:
        run = run + 1 if label == "misplaced" else 0
        longest = max(longest, run)
    mis = [k + 1 for k, label in enumerate(labels) if label == "misplaced"]
    amb = [k + 1 for k, label in enumerate(labels) if label == "ambiguous"]
    miss_step = steps[1:] - steps[:-1]  # step k+1 against step k: what a constant-step prior gets wrong
    miss_step[:, 2] = wrap_angle(miss_step[:, 2])
    missed = np.r_[False, False, (np.hypot(miss_step[:, 0], miss_step[:, 1]) > PRIOR_MISS_M)
                   | (np.abs(miss_step[:, 2]) > PRIOR_MISS_RAD)]  # per scan index
    return Placeability(name, len(frames), labels.count("placed"), longest, reach_rad, mis, amb, int(missed.sum()),
                        int(missed[amb].sum()) if amb else 0)


def wrong_steps(run: np.ndarray, reference: np.ndarray, row: Placeability, most: int = 10) -> list[str]:
    """The first ``most`` steps of a run's trajectory (K, 3) that differ from the reference's (K, 3) by more than
    FAR_M or FAR_RAD, each with the reference's step, the step before it and the study's label of its scan."""
    if len(run) != len(reference):
        raise SystemExit(f"--compare: {len(run)} poses against {len(reference)} reference poses (one per scan needed)")
    ref_steps, run_steps = relative(reference[:-1], reference[1:]), relative(run[:-1], run[1:])
    err = run_steps - ref_steps
    err[:, 2] = wrap_angle(err[:, 2])
    bad = np.flatnonzero((np.hypot(err[:, 0], err[:, 1]) > FAR_M) | (np.abs(err[:, 2]) > FAR_RAD))
    out = []
    for k in bad[:most]:
        before = ref_steps[k - 1] if k else np.zeros(3)
        out.append(f"scan {k + 1} ({row.label(int(k) + 1)}): off by {np.hypot(*err[k, :2]):.2f} m "
                   f"{math.degrees(abs(err[k, 2])):.1f}°; reference step {np.hypot(*ref_steps[k, :2]):.2f} m "
                   f"{math.degrees(ref_steps[k, 2]):+.1f}°, the step before {np.hypot(*before[:2]):.2f} m "
                   f"{math.degrees(before[2]):+.1f}°")
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", nargs="+", choices=[b for b in BUILDINGS if b != "mit-csail"])
    parser.add_argument("--extra", nargs="+", default=[], metavar="LOG", help="more logs with one reference pose per scan")
    parser.add_argument("--data", help="the shared data folder (default: $MCNKIT_SHARED_DATA, else ../shared/data)")
    parser.add_argument("--window-m", type=float, default=2.0, help="± search window in x and y (the lidar-only default)")
    parser.add_argument("--out", default=str(RESULTS / "lidar_placeability"), help="output stem (.md and .json)")
    parser.add_argument("--compare", type=Path, metavar="TUM",
                        help="a run's trajectory.tum of the one building --only names: also print its first steps "
                             "that the reference's differ from, with the study's label of each scan")
    args = parser.parse_args()
    if args.compare is not None and (args.extra or not args.only or len(args.only) != 1):
        parser.error("--compare needs exactly one building in --only (and no --extra)")
    if args.compare is not None and not args.compare.exists():
        parser.error(f"--compare {args.compare}: no such file")
    data = data_dir(args.data)
    logs = [(n, str(data / BUILDINGS[n][0])) for n in (args.only or [b for b in BUILDINGS if b != "mit-csail"])]
    logs += [(p.split("/")[-1].split(".")[0].removesuffix("-corrected"), p) for p in args.extra]
    rows = []
    lines = ["| building | scans | placed | ambiguous | misplaced | longest misplaced run | heading reach | first misplaced "
             "| prior misses | ambiguous after a miss |", "|---|---|---|---|---|---|---|---|---|---|"]
    for name, log in logs:
        row = building(name, log, args.window_m)
        rows.append(row)
        line = (f"| {name} | {row.scans} | {row.placed} | {row.ambiguous} | {row.misplaced} | {row.longest_misplaced_run}"
                f" | ±{math.degrees(row.reach_rad):.0f}° | {', '.join(map(str, row.misplaced_scans[:8]))} "
                f"| {row.prior_misses} | {row.ambiguous_after_miss} |")
        lines.append(line)
        print(line, flush=True)
        if args.compare is not None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                with open_log(log) as reader:
                    ref = reader.ground_truth()
            assert ref is not None  # building() already required it
            print("\n".join(wrong_steps(read_tum(args.compare).poses, ref.poses, row)))
    table = "\n".join(lines)
    text = ("# Which scans a matcher can place without odometry (`benchmarks/studies/lidar_placeability.py`)\n\n"
            "Each scan searched for on the map of the scans before it, built from the reference poses "
            f"(± {args.window_m} m, the log's heading reach): *placed* when no pose farther than {FAR_M} m / "
            f"{math.degrees(FAR_RAD):.0f}° from the truth explains it within {100 * (1 - NEAR_RATIO):.0f} % as well, "
            f"*ambiguous* when one explains it {100 * NEAR_RATIO:.0f}-{100 * JUMP:.0f} % as well (a motion prior "
            f"decides), *misplaced* when one explains it ≥ {JUMP}× better (no prior outvotes it). *Prior misses*: "
            f"steps a constant-step prior (the step before) misses by more than {PRIOR_MISS_M} m or "
            f"{math.degrees(PRIOR_MISS_RAD):.0f}°; *ambiguous after a miss*: ambiguous scans among them, which "
            "neither the map nor that prior places.\n\n" + table + "\n")
    with open(args.out + ".md", "w") as fh:
        fh.write(text)
    with open(args.out + ".json", "w") as fh:
        json.dump({"window_m": args.window_m,
                   "rows": [asdict(r) | {"ambiguous": r.ambiguous, "misplaced": r.misplaced} for r in rows]}, fh,
                  indent=2)
        fh.write("\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
