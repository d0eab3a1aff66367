"""Which steps does a log's reference take otherwise than its scans and its wheels measure them?

A Radish corrected log is the output of a particle-filter SLAM run (its ``NEFF`` lines, one per scan, are the filter's
effective sample size), so ATE against it also measures that run's choices where the log's scans leave the motion open.
This study finds where those choices lie. Each scan is matched with the next
(:func:`mcnkit.slam.scanrelations.scan_relations`, searched around the reference and the odometry alike, so neither
is favoured). A step whose match pins the translation in both directions is *pinned*. A straight drive whose match is
dropped (a corridor's axis left free, too little overlap) is *free*. Straight drives are defined as in
``corridor_consistency``: an odometry step over 0.5 m that turns less than 1.15°.

For each trajectory (the reference and any runs given), the forward steps are summed over the pinned and over the free
straight drives, each sum as a ratio to the odometry's. Where the scans pin a step, their own ratio is the wheels'
scale as the laser measures it. A trajectory whose free ratio differs from its pinned ratio by more than that has
lengthened (or shortened) the stretches where the scans have nothing to say. Turns are compared the same way, on the
pinned steps that turn more than 5° (left and right apart).

Then a what-if: the whole-log graph is started at the reference
(:func:`benchmarks.studies.graph_at_reference.solve_at_reference`: the nodes a default run updates at) and solved
twice, once with the log's odometry and once with the odometry's free straight steps lengthened by the reference's
free ratio over its pinned ratio. The drop in ATE is how much of the graph's distance from the reference that extra
length accounts for.

Printed and written to ``benchmarks/results/NAME_reference_steps.{md,json}``.

    .venv/bin/python -m benchmarks.studies.reference_steps LOG [--traj RUN/trajectory.tum ...] [--out STEM]
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
from typing import TYPE_CHECKING

from benchmarks.common import RESULTS
from benchmarks.studies.corridor_consistency import STRAIGHT_MAX_TURN_RAD, STRAIGHT_MIN_STEP_M
from benchmarks.studies.graph_at_reference import read_with_reference, solve_at_reference

if TYPE_CHECKING:
    import numpy as np

TURN_MIN_RAD = math.radians(5.0)
"""A turning step is an odometry step that turns more than this."""


def _ratio(num: np.ndarray, den: np.ndarray) -> float:
    """``sum(num) / sum(den)``, NaN where ``den`` sums to zero (no such steps)."""
    total = float(den.sum())
    return float(num.sum()) / total if total else float("nan")


def _row(step: np.ndarray, odo: np.ndarray, masks: dict[str, np.ndarray]) -> dict[str, float]:
    """A trajectory's steps (N-1, 3) against the odometry's: forward length ratios on the pinned and the free straight
    drives, turn ratios on the pinned left and right turns."""
    return {"forward_pinned": _ratio(step[masks["pinned"], 0], odo[masks["pinned"], 0]),
            "forward_free": _ratio(step[masks["free"], 0], odo[masks["free"], 0]),
            "turn_left": _ratio(step[masks["left"], 2], odo[masks["left"], 2]),
            "turn_right": _ratio(step[masks["right"], 2], odo[masks["right"], 2])}


def _study(log: Path, trajectories: dict[str, Path]) -> dict:
    """The step table and the what-if for one log (see the module)."""
    import numpy as np
    from tqdm import tqdm

    from mcnkit.geometry import compose, relative
    from mcnkit.metrics import read_tum
    from mcnkit.slam.scanrelations import scan_relations, scan_returns, sequential_pairs

    frames, truth = read_with_reference(log)
    n = len(frames)
    reference = truth.poses
    odometry = np.array([f.odom.as_array() for f in frames])
    known = np.array([f.odom_known for f in frames[1:]], bool)
    relations = scan_relations(scan_returns([f.scan for f in frames]), np.arange(n, dtype=np.int64),
                               sequential_pairs(n, (1,)), [reference, odometry],
                               progress=lambda rows: tqdm(rows, desc=f"{log.name}: matching each scan with the next",
                                                          unit="pair", leave=False))
    matched = np.full((n - 1, 3), np.nan)
    matched[relations.t1_ns] = relations.delta
    pinned = np.isfinite(matched[:, 0])
    odo = relative(odometry[:-1], odometry[1:])
    straight = known & (odo[:, 0] > STRAIGHT_MIN_STEP_M) & (np.abs(odo[:, 2]) < STRAIGHT_MAX_TURN_RAD)
    masks = {"pinned": straight & pinned, "free": straight & ~pinned,
             "left": known & pinned & (odo[:, 2] > TURN_MIN_RAD), "right": known & pinned & (odo[:, 2] < -TURN_MIN_RAD)}
    out: dict = {"scans": n, "straight_steps": int(straight.sum()),
                 "steps": {key: int(m.sum()) for key, m in masks.items()},
                 "odometry_m": {"pinned": float(odo[masks["pinned"], 0].sum()),
                                "free": float(odo[masks["free"], 0].sum())},
                 "rows": {}}
    no_free = {**masks, "free": np.zeros_like(masks["free"])}  # the scans measure no free step: NaN there
    out["rows"]["the scans (matches)"] = _row(np.nan_to_num(matched), odo, no_free)
    out["rows"]["reference"] = _row(relative(reference[:-1], reference[1:]), odo, masks)
    for label, path in trajectories.items():
        poses = read_tum(path).poses
        if len(poses) != n:
            raise SystemExit(f"--traj {path}: {len(poses)} poses, the log has {n} scans (one pose per scan needed)")
        out["rows"][label] = _row(relative(poses[:-1], poses[1:]), odo, masks)
    ref = out["rows"]["reference"]
    out["what_if"] = None
    if not masks["free"].any():
        return out  # no free straight drive: nothing to lengthen
    factor = ref["forward_free"] / ref["forward_pinned"]
    lengthened = odo.copy()
    lengthened[masks["free"], 0] *= factor
    chain = np.empty_like(odometry)
    chain[0] = odometry[0]
    for k in range(n - 1):
        chain[k + 1] = compose(chain[k], lengthened[k])
    out["what_if"] = {
        "free_factor": factor,
        "graph_with_odometry_ate_m": solve_at_reference(frames, reference, odometry,
                                                        reference_steps=False)["with_odometry"]["ate_m"],
        "graph_with_free_steps_lengthened_ate_m": solve_at_reference(frames, reference, chain,
                                                                     reference_steps=False)["with_odometry"]["ate_m"]}
    return out


def _table(name: str, command: str, r: dict) -> str:
    """The study's markdown."""
    s, m = r["steps"], r["odometry_m"]
    lines = [f"# {name}: the reference's steps against the scans' and the wheels'", "", f"`{command}`", "",
             f"{r['scans']} scans; {r['straight_steps']} straight drives (odometry step over {STRAIGHT_MIN_STEP_M} m, "
             f"turn under {math.degrees(STRAIGHT_MAX_TURN_RAD):.2f}°): {s['pinned']} pinned by the match with the next "
             f"scan ({m['pinned']:.1f} m by the odometry), {s['free']} free ({m['free']:.1f} m); {s['left']} / "
             f"{s['right']} pinned steps turn more than {math.degrees(TURN_MIN_RAD):.0f}° left / right.", "",
             "Each cell: the trajectory's summed forward step (or turn) over the odometry's, on the same steps.", "",
             "| trajectory | forward, pinned | forward, free | free over pinned | turns left | turns right |",
             "|---|---|---|---|---|---|"]
    for label, row in r["rows"].items():
        over = row["forward_free"] / row["forward_pinned"]
        cells = [f"{row['forward_pinned']:.5f}", "–" if math.isnan(row["forward_free"]) else f"{row['forward_free']:.5f}",
                 "–" if math.isnan(over) else f"{over:.5f}", f"{row['turn_left']:.5f}", f"{row['turn_right']:.5f}"]
        lines.append(f"| {label} | " + " | ".join(cells) + " |")
    w = r["what_if"]
    if w is None:
        return "\n".join([*lines, "", "No free straight drive: no what-if."]) + "\n"
    lines += ["", "The whole-log graph started at the reference (`graph_at_reference`'s nodes), ATE of its solution "
              "against the reference:", "",
              "| odometry given to the graph | ATE (m) |", "|---|---|",
              f"| the log's | {w['graph_with_odometry_ate_m']:.3f} |",
              f"| the log's, its free straight steps × {w['free_factor']:.5f} (the reference's free over pinned) | "
              f"{w['graph_with_free_steps_lengthened_ate_m']:.3f} |"]
    return "\n".join(lines) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("log", type=Path, help="a log with one reference pose per scan (a Radish corrected log)")
    parser.add_argument("--traj", type=Path, nargs="+", default=[], metavar="TUM",
                        help="runs' trajectories of the log, one pose per scan (a run's trajectory.tum), labelled by "
                             "their folder and file name")
    parser.add_argument("--out", type=Path, default=None,
                        help="output stem (default benchmarks/results/NAME_reference_steps, NAME from the log's file)")
    args = parser.parse_args()
    if not args.log.exists():
        parser.error(f"log {args.log}: no such file")
    for path in args.traj:
        if not path.is_file():
            parser.error(f"--traj {path}: no such file")
    name = args.log.name.split(".")[0].removesuffix("-corrected")
    out = args.out or RESULTS / f"{name}_reference_steps"
    result = _study(args.log, {f"{p.parent.name}/{p.name}": p for p in args.traj})
    command = (f"python -m benchmarks.studies.reference_steps {args.log.name}"
               + (f" --traj {' '.join(f'{p.parent.name}/{p.name}' for p in args.traj)}" if args.traj else ""))
    text = _table(name, command, result)
    print(text)
    out.parent.mkdir(parents=True, exist_ok=True)
    Path(f"{out}.md").write_text(text)
    Path(f"{out}.json").write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
