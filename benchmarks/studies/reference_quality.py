"""How far is a Radish "corrected" reference from the truth?  Measured where independent ground truth exists.

The building benchmark scores ATE against the corrected poses of Radish logs, and those poses are
themselves the output of a SLAM system.  One building has both: MIT CSAIL.  ``../shared/data`` holds its full log
(``mit-csail.clf``, 1,988 scans) with the 1,172 ground-truth relations of Kümmerle et al. 2009 (122 of them
between scans more than 30 s apart: revisits); the public repository acschaefer/ple holds a corrected log of the
same run (``data/carmen/csail-corrected.log.gz``: the 406 scans its SLAM kept, with their corrected poses and
stamps printed without sub-second digits).  Not in ``../shared``; get it with::

    curl -LO https://github.com/acschaefer/ple/raw/master/data/carmen/csail-corrected.log.gz

This script matches each corrected scan to the full log's scan with the same ranges (to the centimetre), which
gives every corrected pose its original stamp, then, for ``mcnkit slam`` on the full log (the documented command,
each seed):

- its relations error over all relations and over the revisits alone (the independent ground truth);
- the relations error of the *corrected reference* on the relations whose two ends are both among its scans, and
  that of ``mcnkit slam`` on the same relations;
- the ATE RMSE of ``mcnkit slam`` against the corrected reference, the figure the building benchmark would report.

Read it so: a trajectory that meets the independent ground truth to a few centimetres, revisits included, and still
lies 0.2 m (ATE) from the corrected reference says that the corrected reference is off by about that much.

    .venv/bin/python -m benchmarks.studies.reference_quality --corrected csail-corrected.log.gz [--seeds 0 1 2]

Prints a table and writes ``benchmarks/results/reference_quality.{md,json}``.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import warnings
from pathlib import Path

import numpy as np

from benchmarks.common import ROOT, SLAM_ENV, data_dir, slam_command
from mcnkit.io import open_log
from mcnkit.metrics import Relations, absolute_trajectory_error, read_relations, read_tum, relations_error
from mcnkit.types import Trajectory

OUT = ROOT / "benchmarks" / "results"
REVISIT_S = 30.0
"""Relations between scans further apart in time than this are revisits (the robot came back)."""


def _key(ranges: np.ndarray) -> bytes:
    return np.round(np.asarray(ranges, np.float64), 2).tobytes()


def corrected_with_stamps(corrected: Path, full: Path) -> Trajectory:
    """The corrected log's poses, each stamped with the stamp of the full log's scan that has the same ranges."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the corrected log's stamps are rebuilt (six significant digits)
        with open_log(full) as reader:
            stamp_of = {_key(f.scan.ranges_m): f.stamp_ns for f in reader.frames()}
        with open_log(corrected) as reader:
            keys = [_key(f.scan.ranges_m) for f in reader.frames()]
            gt = reader.ground_truth()
    if gt is None:
        raise SystemExit(f"{corrected}: no corrected poses in this log")
    stamps = np.array([stamp_of.get(k, -1) for k in keys], dtype=np.int64)
    found = stamps >= 0
    if found.sum() < 0.9 * len(stamps) or len(np.unique(stamps[found])) < found.sum():
        raise SystemExit(f"{corrected}: only {int(found.sum())} of {len(stamps)} scans found (uniquely) in {full}: "
                         "not a corrected log of the same run")
    order = np.argsort(stamps[found])
    return Trajectory(stamps[found][order], gt.poses[found][order])


def _subset(rel: Relations, keep: np.ndarray) -> Relations:
    return Relations(rel.t1_ns[keep], rel.t2_ns[keep], rel.delta[keep])


def _on_stamps(rel: Relations, stamps_ns: np.ndarray, tolerance_s: float = 0.005) -> np.ndarray:
    """Relations whose two ends are both within ``tolerance_s`` of one of ``stamps_ns`` (sorted)."""
    def near(t: np.ndarray) -> np.ndarray:
        i = np.clip(np.searchsorted(stamps_ns, t), 1, len(stamps_ns) - 1)
        return np.minimum(np.abs(stamps_ns[i] - t), np.abs(stamps_ns[i - 1] - t)) <= tolerance_s * 1e9
    return near(rel.t1_ns) & near(rel.t2_ns)


def one(seed: int, full: Path, rel: Relations, ref: Trajectory) -> dict[str, float | int]:
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run(slam_command(full, seed, Path(tmp) / "out"), check=True, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, env=SLAM_ENV)
        est = read_tum(Path(tmp) / "out" / "trajectory.tum")
    revisit = np.abs(rel.t2_ns - rel.t1_ns) > REVISIT_S * 1e9
    shared = _on_stamps(rel, ref.stamps_ns)
    ours_all = relations_error(est, rel)
    ours_revisits = relations_error(est, _subset(rel, revisit))
    ours_shared = relations_error(est, _subset(rel, shared))
    ref_shared = relations_error(ref, _subset(rel, shared))
    ate = absolute_trajectory_error(est, ref)
    return {"seed": seed, "relations": len(rel), "revisit_relations": int(revisit.sum()),
            "relations_on_reference_scans": int(shared.sum()),
            "ours_relations_m": ours_all.translation_mean_m, "ours_relations_deg": ours_all.rotation_mean_deg,
            "ours_revisits_m": ours_revisits.translation_mean_m, "ours_revisits_deg": ours_revisits.rotation_mean_deg,
            "ours_on_reference_scans_m": ours_shared.translation_mean_m,
            "ours_on_reference_scans_deg": ours_shared.rotation_mean_deg,
            "reference_on_reference_scans_m": ref_shared.translation_mean_m,
            "reference_on_reference_scans_deg": ref_shared.rotation_mean_deg,
            "ate_vs_reference_m": ate.rmse_m, "ate_vs_reference_max_m": ate.max_m, "ate_matched": ate.n_matched}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--corrected", type=Path, required=True,
                        help="csail-corrected.log.gz from acschaefer/ple (data/carmen); see above")
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="filter seeds (default 0 1 2)")
    parser.add_argument("--data", help="the shared data folder (default: $MCNKIT_SHARED_DATA, else ../shared/data)")
    args = parser.parse_args()
    data = data_dir(args.data)
    full = data / "reallab" / "mit-csail" / "mit-csail.clf"
    rel = read_relations(data / "reallab" / "mit-csail" / "mit-csail.relations")
    ref = corrected_with_stamps(args.corrected, full)
    lines = ["| seed | `mcnkit slam`: relations error, all / revisits (m, °) | on the relations between reference scans: "
             "`mcnkit slam` / corrected reference (m, °) | ATE of `mcnkit slam` against the corrected reference (m) |",
             "|---|---|---|---|"]
    rows = []
    for seed in args.seeds:
        r = one(seed, full, rel, ref)
        rows.append(r)
        lines.append(f"| {seed} | {r['ours_relations_m']:.4f} / {r['ours_revisits_m']:.4f} m, "
                     f"{r['ours_relations_deg']:.2f} / {r['ours_revisits_deg']:.2f}° | "
                     f"{r['ours_on_reference_scans_m']:.3f} / {r['reference_on_reference_scans_m']:.3f} m, "
                     f"{r['ours_on_reference_scans_deg']:.2f} / {r['reference_on_reference_scans_deg']:.2f}° | "
                     f"{r['ate_vs_reference_m']:.3f} (max {r['ate_vs_reference_max_m']:.3f}) |")
        print(lines[-1], flush=True)
    head = (f"{len(ref)} corrected poses stamped from the full log; {rows[0]['relations']} relations, "
            f"{rows[0]['revisit_relations']} of them revisits (more than {REVISIT_S:.0f} s apart), "
            f"{rows[0]['relations_on_reference_scans']} with both ends among the corrected log's scans.")
    table = "\n".join(lines)
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "reference_quality.md").write_text(
        "# How far is a corrected reference from the truth? (`benchmarks/studies/reference_quality.py`)\n\n"
        "MIT CSAIL: `mcnkit slam` on the full log (`--particles 30 --resolution 0.05`, default configuration) against "
        "the Kümmerle et al. ground-truth relations and against the corrected log of the same run "
        "(acschaefer/ple `data/carmen/csail-corrected.log.gz`).\n\n" + head + "\n\n" + table + "\n")
    (OUT / "reference_quality.json").write_text(
        json.dumps({"corrected_poses": len(ref), "rows": rows}, indent=2) + "\n")
    print(head)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
