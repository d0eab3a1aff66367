"""``mcnkit slam`` and ``mcnkit eval``: run the filter on a log, and score trajectories.

The lead's dispatcher (``mcnkit/cli.py``) wires these in with :func:`add_slam_parser` and
:func:`add_eval_parser`; each sets ``func`` to a function ``(args) -> exit code``.

Outputs of ``mcnkit slam LOG --out DIR``:

* ``trajectory.tum``: the best particle's pose at every scan: its corrected poses at the filter updates (its
  ancestry, as gmapping reports it) and, in between, that pose moved by the scan-to-map tracking the filter did
  online (``SlamConfig.track_every_scan``: changes no weight or map) instead of by raw odometry;
* ``trajectory_online.tum``: strictly causal — at every scan the pose of the particle that was best *then*;
* ``trajectory_gmapping.tum``: gmapping's convention for the same run, the last corrected pose plus the
  odometry change since (the convention the gmapping anchors were measured with);
* offline refinements of the same run: ``trajectory_matched.tum`` (every scan matched against the best
  particle's final map, ``mode="matched"`` of :meth:`mcnkit.slam.FastSlam.trajectory`: a smoother that uses
  later information) and ``trajectory_smoothed.tum`` (each correction spread over the interval before it);
* ``run.rrd`` with ``--rrd``: every step recorded for Rerun (see :mod:`mcnkit.viz`);
* ``map.pgm`` + ``map.yaml`` (ROS ``map_server``: occupied 0, free 254, unknown 205), ``map.png``;
* ``summary.json``: scans, filter updates, resamplings, cpu_s, wall_s, peak_rss_mb, final Neff, ...
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import resource
import sys
import time
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np

from mcnkit.io.errors import LogError
from mcnkit.io.mapfiles import write_map_strips
from mcnkit.metrics import (
    absolute_trajectory_error,
    read_relations,
    read_tum,
    relations_error,
    relative_pose_error,
    write_tum,
)
from mcnkit.slam.config import SlamConfig
from mcnkit.slam.fastslam import FastSlam

__all__ = ["add_eval_parser", "add_slam_parser", "run_eval_ate", "run_eval_relations", "run_slam"]



def add_slam_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Adds ``slam LOG --particles N --resolution M --seed S --out DIR``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        "slam",
        help="run grid FastSLAM (gmapping-class) on a robot log",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("log", type=Path, help="a log open_log reads (CARMEN .clf/.log[.gz], .bag, rosbag2, .mcap)")
    p.add_argument("--particles", type=int, default=30, help="number of particles (default 30)")
    p.add_argument("--resolution", type=float, default=0.05, help="cell size in metres (default 0.05)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--out", type=Path, required=True, help="output folder (created)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--rrd", type=Path, help="record every step to this Rerun file (.rrd)")
    p.add_argument("--rrd-map-every", type=int, default=10,
                   help="with --rrd: log the best particle's map every N filter updates (default 10)")
    p.set_defaults(func=run_slam)
    return p


def add_eval_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Adds ``eval relations TRAJ RELATIONS [--json]`` and ``eval ate TRAJ REFERENCE [--json]``."""
    p: argparse.ArgumentParser = subparsers.add_parser("eval", help="score a TUM trajectory")
    sub = p.add_subparsers(dest="eval_command", required=True)
    r = sub.add_parser("relations", help="Kümmerle et al. 2009 relations error (translation m, rotation deg)")
    r.add_argument("trajectory", type=Path, help="estimated trajectory, TUM format")
    r.add_argument("relations", type=Path, help="relations file: t1 t2 x y z roll pitch yaw per line")
    r.add_argument("--tolerance-s", type=float, default=0.005, help="stamp matching tolerance (default 0.005)")
    r.add_argument("--json", action="store_true", help="print JSON instead of text")
    r.set_defaults(func=run_eval_relations)
    a = sub.add_parser("ate", help="ATE (after rigid 2-D alignment) and RPE against a reference trajectory")
    a.add_argument("trajectory", type=Path, help="estimated trajectory, TUM format")
    a.add_argument("reference", type=Path, help="reference trajectory, TUM format")
    a.add_argument("--tolerance-s", type=float, default=0.005, help="stamp matching tolerance (default 0.005)")
    a.add_argument("--json", action="store_true", help="print JSON instead of text")
    a.set_defaults(func=run_eval_ate)
    return p


def _open(path: Path) -> Any:
    try:
        from mcnkit.io import open_log
    except ImportError:  # until the generic reader lands: CARMEN logs only
        from mcnkit.io.carmen import CarmenLog

        return CarmenLog(path)
    return open_log(path)


def _scan_count(reader: Any) -> int | None:
    try:
        return next(t.count for t in reader.topics if t.name == reader.scan_topic)
    except (StopIteration, AttributeError, NotImplementedError):
        return None


def run_slam(args: argparse.Namespace) -> int:
    """Runs the filter over a log and writes trajectory, map and summary into ``args.out``."""
    from tqdm import tqdm

    wall0, cpu0 = time.perf_counter(), time.process_time()
    try:
        config = SlamConfig(n_particles=args.particles, resolution_m=args.resolution)
    except ValueError as err:
        print(f"mcnkit slam: {err}", file=sys.stderr)
        return 2
    rrd: Path | None = getattr(args, "rrd", None)
    try:
        reader = _open(args.log)
        slam = FastSlam(config, np.random.default_rng(args.seed))
        with reader, ExitStack() as stack:
            recorder = None
            if rrd is not None:
                from mcnkit.viz import RerunLogger  # rerun only when asked for

                recorder = stack.enter_context(RerunLogger(rrd, recording_id=f"slam-{Path(args.log).stem}-{args.seed}"))
            frames = tqdm(reader.frames(), total=_scan_count(reader), unit="scan", disable=args.no_progress)
            for frame in frames:
                step = slam.step(frame)
                if recorder is not None:
                    recorder.log_slam_step(frame, step, slam.trajectory().poses[:, :2] if step.updated else None)
                    if step.updated and slam.n_updates % max(args.rrd_map_every, 1) == 1:
                        recorder.log_map("/world/map/estimate", slam.best_ternary(), mask=True)
                if step.updated:
                    frames.set_postfix(updates=slam.n_updates, neff=f"{step.neff:.1f}", refresh=False)
    except (LogError, OSError) as err:
        print(f"mcnkit slam: {err}".splitlines()[0], file=sys.stderr)
        return 2
    if slam.n_scans == 0:
        print(f"mcnkit slam: {args.log}: no scans", file=sys.stderr)
        return 2
    cpu_slam, wall_slam = time.process_time() - cpu0, time.perf_counter() - wall0
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    write_tum(out / "trajectory.tum", slam.trajectory(mode="tracked"))
    write_tum(out / "trajectory_online.tum", slam.trajectory(mode="online"))
    write_tum(out / "trajectory_gmapping.tum", slam.trajectory(mode="gmapping"))
    write_tum(out / "trajectory_matched.tum", slam.trajectory(mode="matched"))
    write_tum(out / "trajectory_smoothed.tum", slam.trajectory(mode="smoothed"))
    spec, strips = slam.best_map_strips()
    write_map_strips(out, spec, strips, config.occ_thresh)
    summary = {
        "log": str(args.log),
        "particles": config.n_particles,
        "resolution_m": config.resolution_m,
        "seed": args.seed,
        "config": dataclasses.asdict(config),
        "loop_closures": slam.loops.stats.accepted,
        "loop_corrections": slam.n_loop_corrections,
        "scans": slam.n_scans,
        "filter_updates": slam.n_updates,
        "resamplings": slam.n_resamples,
        "final_neff": slam.neff,
        "best_particle": slam.best_index,
        "cpu_s": time.process_time() - cpu0,
        "wall_s": time.perf_counter() - wall0,
        "cpu_s_filter": cpu_slam,
        "wall_s_filter": wall_slam,
        "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
        "particle_maps_mb": slam.maps.nbytes / 1e6,
        "map_cells": [spec.height, spec.width],
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    print(
        f"{slam.n_scans} scans, {slam.n_updates} filter updates, {slam.n_resamples} resamplings, "
        f"CPU {summary['cpu_s']:.1f} s, wall {summary['wall_s']:.1f} s, peak RSS {summary['peak_rss_mb']:.0f} MB"
        f" -> {out}"
    )
    return 0


def _read(kind: str, reader: Any, path: Path) -> Any:
    try:
        return reader(path)
    except (OSError, ValueError) as err:
        print(f"mcnkit eval: cannot read {kind} {path}: {err}".splitlines()[0], file=sys.stderr)
        return None


def run_eval_relations(args: argparse.Namespace) -> int:
    """Prints the relations error of a TUM trajectory."""
    traj, rel = _read("trajectory", read_tum, args.trajectory), _read("relations", read_relations, args.relations)
    if traj is None or rel is None:
        return 2
    err = relations_error(traj, rel, args.tolerance_s)
    if args.json:
        print(json.dumps(err.as_dict()))
    else:
        print(
            f"translation {err.translation_mean_m:.4f} ± {err.translation_std_m:.4f} m, "
            f"rotation {err.rotation_mean_deg:.3f} ± {err.rotation_std_deg:.3f} deg "
            f"over {len(err.translation_m)} relations ({err.n_skipped} without a pose within {args.tolerance_s} s)"
        )
    return 0


def run_eval_ate(args: argparse.Namespace) -> int:
    """Prints ATE and RPE of a TUM trajectory against a reference TUM trajectory."""
    traj, ref = _read("trajectory", read_tum, args.trajectory), _read("reference", read_tum, args.reference)
    if traj is None or ref is None:
        return 2
    try:
        ate = absolute_trajectory_error(traj, ref, args.tolerance_s)
        rpe = relative_pose_error(traj, ref, args.tolerance_s)
    except ValueError as err:
        print(f"mcnkit eval: {err}", file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps({"ate": ate.as_dict(), "rpe": rpe.as_dict()}))
    else:
        print(
            f"ATE rmse {ate.rmse_m:.4f} m (mean {ate.mean_m:.4f}, max {ate.max_m:.4f}) over {ate.n_matched} poses; "
            f"RPE {rpe.translation_mean_m:.4f} ± {rpe.translation_std_m:.4f} m, "
            f"{rpe.rotation_mean_deg:.3f} ± {rpe.rotation_std_deg:.3f} deg"
        )
    return 0
