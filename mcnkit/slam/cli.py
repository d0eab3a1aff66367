"""``mcnkit slam``: run the filter on a log (``mcnkit eval`` is :mod:`mcnkit.slam.evaluate`).

The dispatcher (``mcnkit/cli.py``) wires it in with :func:`add_slam_parser`, which sets ``func`` to a function
``(args) -> exit code``.

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

__all__ = ["add_slam_parser", "run_slam"]

_DESCRIPTION = """Run grid FastSLAM (gmapping's scan-matched proposal) on a robot log and write into --out:

  trajectory.tum            the best particle's pose at every scan (corrected at the filter updates,
                            tracked by scan matching in between)
  trajectory_online.tum     at every scan the pose of the particle that was best then (causal)
  trajectory_gmapping.tum   gmapping's convention: last corrected pose plus the odometry since
  trajectory_matched.tum    every scan matched against the final map (uses later information)
  trajectory_smoothed.tum   each correction spread over the interval before it
  map.pgm, map.yaml         the best particle's map (ROS map_server: occupied 0, free 254, unknown 205), map.png
  summary.json              scans, filter updates, resamplings, CPU and wall time, peak memory, the configuration

With --rrd every step is also recorded for Rerun.  Score a trajectory with 'mcnkit eval'."""



def add_slam_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Adds ``slam LOG --particles N --resolution M --seed S --out DIR``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        "slam",
        help="run grid FastSLAM (gmapping-class) on a robot log",
        description=_DESCRIPTION,
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
    import numpy as np
    from tqdm import tqdm

    from mcnkit.io.errors import LogError
    from mcnkit.io.mapfiles import write_map_strips
    from mcnkit.metrics import write_tum
    from mcnkit.slam.config import SlamConfig
    from mcnkit.slam.fastslam import FastSlam

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
