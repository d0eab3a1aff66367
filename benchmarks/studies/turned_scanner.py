"""SLAM from a bag that does not say where its scanner points: MIT CSAIL as turned scanners would have logged it.

Each case writes the MIT CSAIL log as an MCAP bag whose scanner is mounted turned, backwards, upside down or off the
base's centre (:func:`mcnkit.io.mountfit.as_mounted`: the same beams in the world, the scanner's own angles) and
leaves ``/tf_static`` out, as a bag recorded with ``ros2 bag record /scan /odom /tf`` does.  The reader finds the
mount from the robot's motion (:mod:`mcnkit.io.mountfit`); ``mcnkit slam`` maps the bag as the documented command
does, and the estimate (moved from the base to where the scanner sits, by the true offset) is scored on the log's
relations (Kümmerle et al.), as the original log is.

    .venv/bin/python -m benchmarks.studies.turned_scanner [--seeds 0 1 2] [--data DIR] [--json FILE]

Prints the table and writes ``benchmarks/results/turned_scanner.{json,md}``.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import tempfile
import time
import warnings
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from benchmarks.common import RESULTS, SLAM_ENV, data_dir, save_report, slam_command
from mcnkit.geometry import compose
from mcnkit.io import LogContent, open_log, write_log
from mcnkit.io.mountfit import as_mounted
from mcnkit.metrics import read_relations, read_tum, relations_error
from mcnkit.types import Pose2D, Trajectory

LOG, RELATIONS = "reallab/mit-csail/mit-csail.clf", "reallab/mit-csail/mit-csail.relations"
CASES: dict[str, tuple[Pose2D, bool] | None] = {
    "as logged (CARMEN, the scanner at the base)": None,
    "a quarter turn": (Pose2D(0.0, 0.0, math.pi / 2), False),
    "165.5°, 0.25 m behind, 0.12 m left": (Pose2D(-0.25, 0.12, math.radians(165.5)), False),
    "backwards, upside down, 0.3 m ahead": (Pose2D(0.3, -0.1, math.pi), True),
}


@dataclass(frozen=True)
class Case:
    """One mount: the true one, what the reader found, and the SLAM run's relations error per seed."""

    case: str
    true_yaw_deg: float
    true_xy_m: tuple[float, float]
    upside_down: bool
    found_yaw_deg: float
    found_xy_m: tuple[float, float]
    found_upside_down: bool
    said: str
    relations_m: list[float]
    relations_deg: list[float]
    cpu_s: list[float]


def _logged_trajectory(base: Trajectory, mount: Pose2D) -> Trajectory:
    """The poses of the frame the original log's relations are given in: where the scanner sits, heading as the
    base (a scanner turned on the base sees the world that the original laser, facing forward, saw)."""
    at = np.array([mount.x_m, mount.y_m, 0.0])
    return Trajectory(base.stamps_ns, np.array([compose(p, at) for p in base.poses]))


def _run_case(name: str, case: tuple[Pose2D, bool] | None, seeds: list[int], data: Path, work: Path) -> Case:
    log = data / LOG
    mount, upside_down = case if case is not None else (Pose2D(), False)
    said = ""
    if case is not None:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            with open_log(log) as original:
                path = write_log(work / f"{len(list(work.iterdir()))}.mcap",
                                 LogContent(as_mounted(original.frames(), mount, upside_down), mount_transform=False))
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with open_log(path) as reader:
                found = reader.lidar_spec.base_to_laser
        said = next((str(w.message).split(": ", 1)[1] for w in caught if "no transform" in str(w.message)), "")
        found_flip = "upside down" in said
        log = path
    else:
        found, found_flip = Pose2D(), False
    rel_m, rel_deg, cpu = [], [], []
    relations = read_relations(data / RELATIONS)
    for seed in seeds:
        out = work / f"{name[:8]}-{seed}"
        proc = subprocess.run(slam_command(log, seed, out), env=SLAM_ENV, capture_output=True, text=True, check=False)
        if proc.returncode != 0:
            raise RuntimeError(f"{name} seed {seed}: mcnkit slam failed: {proc.stderr.strip().splitlines()[-1:]}")
        cpu.append(float(json.loads((out / "summary.json").read_text())["cpu_s"]))
        r = relations_error(_logged_trajectory(read_tum(out / "trajectory.tum"), mount), relations)
        rel_m.append(r.translation_mean_m)
        rel_deg.append(r.rotation_mean_deg)
        print(f"  {name}, seed {seed}: relations {r.translation_mean_m:.4f} m / {r.rotation_mean_deg:.3f}°", flush=True)
    return Case(name, math.degrees(mount.yaw_rad), (mount.x_m, mount.y_m), upside_down, math.degrees(found.yaw_rad),
                (found.x_m, found.y_m), found_flip, said, rel_m, rel_deg, cpu)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--seeds", type=int, nargs="+", default=[0], help="SLAM seeds per case (default 0)")
    ap.add_argument("--data", default=None, help="the shared data folder (default $MCNKIT_SHARED_DATA, else "
                                                 "../shared/data)")
    ap.add_argument("--json", type=Path, default=RESULTS / "turned_scanner.json",
                    help="where the report goes, with a .md beside it (default benchmarks/results/turned_scanner.json)")
    args = ap.parse_args(argv)
    data = data_dir(args.data)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        cases = [_run_case(name, case, args.seeds, data, Path(tmp)) for name, case in CASES.items()]
    base = cases[0]
    lines = ["| scanner | found by the reader | relations error (m), seeds " + " / ".join(map(str, args.seeds))
             + " | CPU (s) |", "|---|---|---|---|"]
    for c in cases:
        found = ("(its mount is in the log)" if c is base else
                 f"{c.found_yaw_deg:.1f}°{', upside down' if c.found_upside_down else ''}, "
                 f"({c.found_xy_m[0]:.2f}, {c.found_xy_m[1]:.2f}) m")
        lines.append(f"| {c.case} | {found} | {' / '.join(f'{v:.4f}' for v in c.relations_m)} | "
                     f"{' / '.join(f'{v:.1f}' for v in c.cpu_s)} |")
    worst = max(max(c.relations_m) for c in cases[1:])
    ok = worst <= 1.5 * max(base.relations_m)  # the same map, within what the fit's degree and centimetres cost
    lines.append(f"\nWorst turned scanner {worst:.4f} m against {max(base.relations_m):.4f} m as logged "
                 f"({'within' if ok else 'beyond'} 1.5 times: {'the same map' if ok else 'a map lost'}); "
                 f"{time.perf_counter() - t0:.0f} s wall.")
    return save_report(args.json, {"cases": [asdict(c) for c in cases], "verdict": {"ok": ok, "worst_turned_m": worst}},
                       "\n".join(lines))


if __name__ == "__main__":
    raise SystemExit(main())
