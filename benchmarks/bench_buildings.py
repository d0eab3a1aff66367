"""The building benchmark: the default ``mcnkit slam`` on every real building, three seeds each.

For every log of ``../shared/data/reallab`` with a reference (the six Radish "corrected" logs, the Intel lab,
MIT CSAIL) and every seed, runs the documented command in its own process::

    mcnkit slam LOG --particles 30 --resolution 0.05 --seed S --out DIR --no-progress

and scores ``trajectory.tum``: ATE RMSE / max against the log's corrected poses after a rigid 2-D alignment,
matched by stamp (by scan order where the log's stamps were degenerate and had to be rebuilt: the reference
then carries the same rebuilt stamps), and the Kümmerle relations error where a relations file exists (MIT
CSAIL).  CPU seconds and peak RSS are the child process's own (start-up and file writing included).  Where the
reference holds one pose per scan it also compares :func:`mcnkit.metrics.hit_cells` of the estimate and of the
reference (cells hit by the scans' returns: the thinner the walls, the fewer): a ratio under 1 says the scans
agree better with the estimate than with the reference, itself the output of a SLAM system.

Writes ``benchmarks/results/buildings/buildings.json``, ``buildings.md``, one ``NAME.png`` per building (its
seed-0 map with the estimate in green and the aligned reference in red) and ``contact_sheet.png``.

    .venv/bin/python -m benchmarks.bench_buildings [--seeds 0 1 2] [--only aces fr079] [--jobs 2]
    .venv/bin/python -m benchmarks.bench_buildings --extra /path/seattle-corrected.log.gz --out /tmp/b
    .venv/bin/python -m benchmarks.bench_buildings --slam-option=--no-slam.motion.noise-from-log --out /tmp/c
    .venv/bin/python -m benchmarks.bench_buildings --lidar-only

``--lidar-only`` runs every building with its odometry ignored (``--slam.motion.odometry ignore``: every scan's motion
found from the scans alone), writes the same table and files into ``benchmarks/results/buildings_lidar_only/``, and
adds a table of its ATEs beside those of the default run (``benchmarks/results/buildings/buildings.json``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from concurrent.futures import ThreadPoolExecutor
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from benchmarks.common import BUILDINGS, ROOT, SLAM_ENV, data_dir, slam_command

OUT = ROOT / "benchmarks" / "results" / "buildings"
OUT_LIDAR_ONLY = ROOT / "benchmarks" / "results" / "buildings_lidar_only"
LIDAR_ONLY = ["--slam.motion.odometry", "ignore"]

# the targets: ATE RMSE (m) and CPU (s) per log; MIT: relations error and CPU; campus: ATE by order, CPU, RSS
TARGETS = {"ate_m": 0.15, "cpu_s": 90.0, "mit_relations_m": 0.045, "mit_cpu_s": 30.0,
           "campus_ate_m": 0.5, "campus_cpu_s": 120.0, "campus_rss_mb": 500.0}


@dataclass(frozen=True)
class Run:
    """One ``mcnkit slam`` run and its scores."""

    building: str
    seed: int
    scans: int
    filter_updates: int
    loop_closures: int
    cpu_s: float
    wall_s: float
    peak_rss_mb: float
    ate_rmse_m: float | None
    ate_max_m: float | None
    matched_by: str | None
    relations_m: float | None
    relations_deg: float | None
    hit_cells: int | None  # cells hit by the scans placed on the estimate (see mcnkit.metrics.hit_cells)
    reference_hit_cells: int | None  # the same on the reference poses


def _run(name: str, seed: int, data: Path, out: Path, options: list[str]) -> Run:
    from mcnkit.io import open_log
    from mcnkit.metrics import absolute_trajectory_error, hit_cells, read_relations, read_tum, relations_error

    log_rel, rel_rel = BUILDINGS[name]
    log = data / log_rel
    t0 = time.perf_counter()
    proc = subprocess.Popen(slam_command(log, seed, out, options), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            env=SLAM_ENV)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    err = proc.stderr.read().decode() if proc.stderr else ""
    if status != 0:
        raise RuntimeError(f"{name} seed {seed}: mcnkit slam failed: {err.strip().splitlines()[-1:]}")
    summary = json.loads((out / "summary.json").read_text())
    est = read_tum(out / "trajectory.tum")
    ate = ate_max = rel_t = rel_r = None
    matched_by = None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with open_log(log) as reader:
            gt = reader.ground_truth()
            scans = [frame.scan for frame in reader.frames()] if gt is not None and len(gt) == len(est) else None
    cells = ref_cells = None
    if scans is not None and gt is not None:  # one reference pose per scan
        cells, ref_cells = hit_cells(scans, est.poses), hit_cells(scans, gt.poses)
    if gt is not None:
        degenerate = any("scan stamps" in str(w.message) and "log order" in str(w.message) and "every" in str(w.message)
                         for w in caught)
        matched_by = "scan order" if degenerate else "stamp"  # rebuilt stamps: pair by scan order, said plainly
        res = absolute_trajectory_error(est, gt, match="order" if degenerate else "stamp")
        ate, ate_max = res.rmse_m, res.max_m
    if rel_rel is not None:
        r = relations_error(est, read_relations(data / rel_rel))
        rel_t, rel_r = r.translation_mean_m, r.rotation_mean_deg
    return Run(name, seed, summary["scans"], summary["filter_updates"], summary.get("loop_closures", 0),
               usage.ru_utime + usage.ru_stime, wall, usage.ru_maxrss / 1024.0, ate, ate_max, matched_by, rel_t, rel_r, cells, ref_cells)


def _load_pgm(path: Path) -> np.ndarray:
    data = path.read_bytes()
    parts = data.split(b"\n", 3)
    w, h = (int(v) for v in parts[1].split())
    return np.frombuffer(parts[3], np.uint8, count=w * h).reshape(h, w)


def _draw(ax: object, name: str, out: Path, data: Path) -> None:
    """The seed-0 map of a building with its estimate (green) and the aligned reference (red)."""
    from mcnkit.io import open_log
    from mcnkit.metrics import align_rigid_2d, read_tum

    img = _load_pgm(out / "map.pgm")
    meta = dict(line.split(": ", 1) for line in (out / "map.yaml").read_text().splitlines() if ": " in line)
    res = float(meta["resolution"])
    ox, oy = (float(v) for v in meta["origin"].strip("[]").split(",")[:2])
    h, w = img.shape
    ax.imshow(img, cmap="gray", extent=(ox, ox + w * res, oy, oy + h * res), interpolation="nearest")  # type: ignore[attr-defined]
    est = read_tum(out / "trajectory.tum").poses
    ax.plot(est[:, 0], est[:, 1], "-", color="tab:green", lw=0.8, label="estimate")  # type: ignore[attr-defined]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with open_log(data / BUILDINGS[name][0]) as reader:
            gt = reader.ground_truth()
    if gt is not None and len(gt) == len(est):
        al = align_rigid_2d(gt.poses[:, :2], est[:, :2])  # the reference drawn onto the estimate
        ax.plot(al[:, 0], al[:, 1], "-", color="tab:red", lw=0.5, label="reference")  # type: ignore[attr-defined]
    ax.set_title(name)  # type: ignore[attr-defined]
    ax.set_aspect("equal")  # type: ignore[attr-defined]
    ax.tick_params(labelsize=6)  # type: ignore[attr-defined]


def _table(runs: list[Run]) -> tuple[str, dict[str, dict[str, object]]]:
    lines = ["| building | ATE RMSE (seeds) | ATE max | relations | CPU s | peak RSS MB | loops | matched by | "
             "hit cells estimate / reference | verdict |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    verdicts: dict[str, dict[str, object]] = {}
    for name in BUILDINGS:
        rs = [r for r in runs if r.building == name]
        if not rs:
            continue
        ates = [r.ate_rmse_m for r in rs if r.ate_rmse_m is not None]
        cpu = max(r.cpu_s for r in rs)
        rss = max(r.peak_rss_mb for r in rs)
        rel = [r.relations_m for r in rs if r.relations_m is not None]
        if name == "mit-csail":
            ok = bool(rel) and max(rel) <= TARGETS["mit_relations_m"] and cpu <= TARGETS["mit_cpu_s"]
        elif name == "campus":
            ok = bool(ates) and max(ates) <= TARGETS["campus_ate_m"] and cpu <= TARGETS["campus_cpu_s"] \
                and rss <= TARGETS["campus_rss_mb"]
        else:
            ok = bool(ates) and max(ates) <= TARGETS["ate_m"] and cpu <= TARGETS["cpu_s"]
        verdicts[name] = {"meets_target": ok, "worst_ate_m": max(ates) if ates else None, "worst_cpu_s": cpu,
                          "worst_rss_mb": rss, "worst_relations_m": max(rel) if rel else None}
        fmt = lambda v: f"{v:.3f}" if v is not None else "–"  # noqa: E731
        lines.append(
            f"| {name} | {' / '.join(fmt(a) for a in ates) or '–'} | "
            f"{' / '.join(fmt(r.ate_max_m) for r in rs) if ates else '–'} | "
            f"{' / '.join(fmt(v) for v in rel) or '–'} | {' / '.join(f'{r.cpu_s:.0f}' for r in rs)} | "
            f"{' / '.join(f'{r.peak_rss_mb:.0f}' for r in rs)} | {' / '.join(str(r.loop_closures) for r in rs)} | "
            f"{rs[0].matched_by or '–'} | "
            f"{' / '.join(f'{r.hit_cells / r.reference_hit_cells:.3f}' for r in rs if r.hit_cells and r.reference_hit_cells) or '–'} | "
            f"{'meets' if ok else 'misses'} |"
        )
    return "\n".join(lines), verdicts


def _beside(runs: list[Run]) -> str:
    """The lidar-only runs' ATEs (relations for MIT CSAIL) beside those of the default run's ``buildings.json``, per
    building and seed; empty when that file does not exist."""
    path = OUT / "buildings.json"
    if not path.exists():
        return ""
    default = {(r["building"], r["seed"]): r for r in json.loads(path.read_text())["runs"]}
    lines = ["| building | with odometry (seeds) | lidar-only (seeds) | CPU s with odometry / lidar-only |",
             "|---|---|---|---|"]
    for name in BUILDINGS:
        rs = [r for r in runs if r.building == name]
        if not rs:
            continue
        key = "relations_m" if name == "mit-csail" else "ate_rmse_m"
        fmt = lambda v: "–" if v is None else f"{v:.3f}"  # noqa: E731
        cpu = lambda v: "–" if v is None else f"{v:.0f}"  # noqa: E731
        odo = [default.get((name, r.seed), {}) for r in rs]
        lines.append(f"| {name} | {' / '.join(fmt(d.get(key)) for d in odo)} | "
                     f"{' / '.join(fmt(getattr(r, key)) for r in rs)} | "
                     f"{' / '.join(cpu(d.get('cpu_s')) for d in odo)} / {' / '.join(cpu(r.cpu_s) for r in rs)} |")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2], help="filter seeds of every building (default 0 1 2)")
    parser.add_argument("--only", nargs="+", choices=list(BUILDINGS),
                        help="a subset of the buildings (default: all; with --extra: none but those logs)")
    parser.add_argument("--data", help="the shared data folder (default: $MCNKIT_SHARED_DATA, else ../shared/data)")
    parser.add_argument("--jobs", type=int, default=2, help="runs in parallel (default 2: this machine's cores)")
    parser.add_argument("--out", type=Path, help=f"results folder (default {OUT.relative_to(ROOT)}, with --lidar-only "
                                                f"{OUT_LIDAR_ONLY.relative_to(ROOT)})")
    parser.add_argument("--lidar-only", action="store_true",
                        help="ignore every log's odometry (--slam.motion.odometry ignore) and set the ATEs beside the "
                             "default run's")
    parser.add_argument("--extra", type=Path, nargs="+", default=[], metavar="LOG",
                        help="more logs with a reference, scored like the others and named by their file (e.g. the "
                             "other Radish corrected logs of github.com/acschaefer/ple, data/carmen: buildings this "
                             "project was not developed on; use another --out to keep the committed results). Given "
                             "without --only, only these logs run; with --only, the buildings named there too")
    parser.add_argument("--slam-option", action="append", default=[], metavar="FLAG",
                        help="a flag passed on to every `mcnkit slam` run, to measure a setting across the buildings "
                             "(repeatable; e.g. --slam-option=--no-slam.motion.noise-from-log; use another --out)")
    args = parser.parse_args()
    options = [word for flag in args.slam_option for word in flag.split()] + (LIDAR_ONLY if args.lidar_only else [])
    args.out = args.out or (OUT_LIDAR_ONLY if args.lidar_only else OUT)
    data = data_dir(args.data)
    names = list(args.only or ([] if args.extra else BUILDINGS))  # --extra alone: just those
    for log in args.extra:  # an absolute path: data / path is the path itself
        name = log.name.split(".")[0].removesuffix("-corrected")
        BUILDINGS[name] = (str(log.resolve()), None)
        names.append(name)
    args.out.mkdir(parents=True, exist_ok=True)
    jobs = [(n, s) for n in names for s in args.seeds]
    with tempfile.TemporaryDirectory() as tmp:
        outs = {(n, s): Path(tmp) / f"{n}-{s}" for n, s in jobs}

        def one(job: tuple[str, int]) -> Run:
            run = _run(job[0], job[1], data, outs[job], options)
            ate = f"ATE {run.ate_rmse_m:.3f} m (max {run.ate_max_m:.2f})" if run.ate_rmse_m is not None else ""
            rel = f"relations {run.relations_m:.4f} m" if run.relations_m is not None else ""
            print(f"{job[0]:>10} seed {job[1]}: {ate}{rel}  CPU {run.cpu_s:.1f} s  peak RSS {run.peak_rss_mb:.0f} MB  "
                  f"{run.loop_closures} loops", flush=True)
            return run

        with ThreadPoolExecutor(max(1, args.jobs)) as pool:
            runs = list(pool.map(one, jobs))
        import matplotlib

        matplotlib.use("Agg")  # a script's own choice: files only
        import matplotlib.pyplot as plt

        seed0 = args.seeds[0]
        cols = 4
        rows = (len(names) + cols - 1) // cols
        sheet, axes = plt.subplots(rows, cols, figsize=(5 * cols, 5 * rows))
        for ax in np.atleast_1d(axes).ravel()[len(names):]:
            ax.axis("off")
        for ax, name in zip(np.atleast_1d(axes).ravel(), names, strict=False):
            _draw(ax, name, outs[(name, seed0)], data)
            single, sax = plt.subplots(figsize=(10, 10))
            _draw(sax, name, outs[(name, seed0)], data)
            sax.legend(loc="lower right", fontsize=8)
            single.savefig(args.out / f"{name}.png", dpi=110, bbox_inches="tight")
            plt.close(single)
        what = "odometry ignored (lidar-only)" if args.lidar_only else "default configuration"
        sheet.suptitle(f"mcnkit slam, {what}, seed {seed0}: estimate (green), reference (red)")
        sheet.savefig(args.out / "contact_sheet.png", dpi=90, bbox_inches="tight")
        plt.close(sheet)
    table, verdicts = _table(runs)
    print(table)
    beside = _beside(runs) if args.lidar_only else ""
    if beside:
        print(beside)
    (args.out / "buildings.md").write_text(
        f"# Building benchmark (`benchmarks/bench_buildings.py{' --lidar-only' if args.lidar_only else ''}`)\n\n"
        + ("Every log's odometry ignored (`--slam.motion.odometry ignore`): each scan's motion found from the scans "
           "alone.\n\n" if args.lidar_only else "") +
        f"Targets: ATE ≤ {TARGETS['ate_m']} m and CPU ≤ {TARGETS['cpu_s']:.0f} s per log; MIT CSAIL relations "
        f"≤ {TARGETS['mit_relations_m']} m, CPU ≤ {TARGETS['mit_cpu_s']:.0f} s; Freiburg campus ATE ≤ "
        f"{TARGETS['campus_ate_m']} m, CPU ≤ {TARGETS['campus_cpu_s']:.0f} s, peak RSS ≤ {TARGETS['campus_rss_mb']:.0f} MB."
        f" Seeds {', '.join(map(str, args.seeds))}.\n\n{table}\n\n"
        "*Hit cells estimate / reference*: cells hit by the scans' returns (up to 20 m) placed on the estimate, "
        "over the same on the reference poses (`mcnkit.metrics.hit_cells`). Under 1: the scans draw thinner walls "
        "on the estimate than on the reference. `trajectory.tum` is refined against the scans and the reference is not: "
        "`benchmarks/studies/reference_consistency.py` refines both alike for a fair comparison.\n"
        + (f"\n## Beside the default run (with odometry)\n\n{beside}\n" if beside else "")
    )
    (args.out / "buildings.json").write_text(json.dumps(
        {"command": " ".join(["mcnkit slam LOG --particles 30 --resolution 0.05 --seed S --out DIR --no-progress",
                              *options]),
         "seeds": args.seeds, "targets": TARGETS, "verdicts": verdicts, "runs": [asdict(r) for r in runs]},
        indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
