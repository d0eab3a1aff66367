"""``mcnkit slam``: run the filter on a log (``mcnkit eval`` is :mod:`mcnkit.app.commands.eval`).

The dispatcher (``mcnkit/app/main.py``) wires it in with :func:`add_slam_parser`, which sets ``func`` to a function
``(args) -> exit code``.

Outputs of ``mcnkit slam LOG --out DIR``:

* ``trajectory.tum``: ``trajectory_tracked.tum`` refined offline, every scan moved onto the map of all the other
  scans, later ones included (``mode="refined"`` of :meth:`mcnkit.slam.FastSlam.trajectory`,
  :mod:`mcnkit.slam.refine`; with ``--slam.offline.whole-graph`` the filter updates are first solved again as one
  graph over the whole log, :mod:`mcnkit.slam.wholegraph`); after Ctrl-C or SIGTERM the refinement is skipped and it holds the tracked
  trajectory (``summary.json``: ``"trajectory": "tracked"``);
* ``trajectory_tracked.tum``: the best particle's pose at every scan: its corrected poses at the filter updates
  (its ancestry, as gmapping reports it) and, in between, that pose moved by the scan-to-map tracking the filter
  did online (``SlamConfig.track_every_scan``: changes no weight or map) instead of by raw odometry;
* ``trajectory_online.tum``: strictly causal — at every scan the pose of the particle that was best *then*;
* ``trajectory_gmapping.tum``: gmapping's convention for the same run, the last corrected pose plus the
  odometry change since (the convention the gmapping anchors were measured with);
* offline refinements of the same run: ``trajectory_matched.tum`` (every scan matched against the best
  particle's final map, ``mode="matched"`` of :meth:`mcnkit.slam.FastSlam.trajectory`: a smoother that uses
  later information) and ``trajectory_smoothed.tum`` (each correction spread over the interval before it);
* ``run.rrd`` with ``--rrd``: every step recorded for Rerun (see :mod:`mcnkit.viz`), the configuration at
  ``/config``; ``--connect [URL]`` / ``--serve`` stream the same live (see :mod:`mcnkit.app.recording`);
* ``map.pgm`` + ``map.yaml`` (ROS ``map_server``: occupied 0, free 254, unknown 205), ``map.png``: the update
  scans ray-cast from ``trajectory.tum``'s poses, so map and trajectory agree;
* ``summary.json``: scans, filter updates, resamplings, cpu_s, wall_s, peak_rss_mb, final Neff, whether the run was
  lidar-only (``"lidar_only"``: the log has no odometry, or ``--slam.motion.odometry ignore``), ...

A log without odometry, or one whose odometry is ignored, runs lidar-only: every scan's motion is found from the
scans alone (:mod:`mcnkit.slam.scanmotion`).  Where a log with odometry has gaps, jumps or slips, those steps are
found the same way, counted in one warning at the end.
"""

from __future__ import annotations

import argparse
import dataclasses
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from mcnkit.app.commands.info import TopicOptions
from mcnkit.app.options import add_options
from mcnkit.app.recording import LIVE_CONST, LiveOptions
from mcnkit.app.runconfig import SLAM_FLAG_ALIASES, resolve_slam_config
from mcnkit.slam.config import SlamConfig

__all__ = ["SlamOptions", "add_slam_parser", "run_slam"]

_DESCRIPTION = """Run grid FastSLAM (gmapping's scan-matched proposal) on a robot log and write into --out:

  trajectory.tum            trajectory_tracked.tum refined offline: every scan moved onto the map of all
                            the other scans, later ones included (--slam.offline.whole-graph: the filter
                            updates solved again as one graph first)
  trajectory_tracked.tum    the best particle's pose at every scan (corrected at the filter updates,
                            tracked by scan matching in between)
  trajectory_online.tum     at every scan the pose of the particle that was best then (causal)
  trajectory_gmapping.tum   gmapping's convention: last corrected pose plus the odometry since
  trajectory_matched.tum    every scan matched against the final map (uses later information)
  trajectory_smoothed.tum   each correction spread over the interval before it
  map.pgm, map.yaml         the update scans cast from trajectory.tum's poses (ROS map_server: occupied 0,
                            free 254, unknown 205), map.png
  summary.json              scans, filter updates, resamplings, CPU and wall time, peak memory, the configuration

With --rrd every step is also recorded for Rerun; --connect streams it live to a running viewer (start one
with 'rerun'), --serve from a gRPC server of its own on 127.0.0.1 (it prints the address; --recording.web-viewer
also serves a web viewer), both also beside --rrd.  The recording holds the whole configuration (/config).
Score a trajectory with 'mcnkit eval'.

A log without odometry (a handheld scanner, a bag of /scan alone) runs lidar-only: every scan's motion is found
from the scans; --odometry ignore (or --slam.odometry ignore, both short for --slam.motion.odometry ignore) runs
any log that way.  Steps whose odometry is missing, jumps or slips are found the same way, counted in one
warning.

Settings: every SlamConfig field is a --slam.FIELD flag (its sections' fields --slam.SECTION.FIELD), every
RecordingConfig field a --recording.FIELD flag (below); --config FILE reads them from a TOML file ([slam],
[slam.SECTION] and [recording] tables, seed = N) or from a run's summary.json, which holds the full
configuration, so 'mcnkit slam LOG --config OLD/summary.json --out NEW' repeats a run exactly (a summary.json
written before SlamConfig had sections is read too).

Ctrl-C or SIGTERM stops after the scan at hand: --out and --rrd get the results so far (summary.json says
"interrupted": true; trajectory.tum is then the tracked one, not refined), exit code 130 / 143.  Outputs never
replace the log; an existing --rrd, or an --out folder that is not empty, is replaced only with --overwrite."""


@dataclass(frozen=True, kw_only=True)
class SlamOptions(LiveOptions, TopicOptions):
    """``mcnkit slam LOG --out DIR [...]``: the filter's settings are the ``slam`` section."""

    log: Path
    """a log open_log reads (CARMEN .clf/.log[.gz], .bag, rosbag2, .mcap)"""
    config: Path | None = None
    """settings file: TOML ([slam], [slam.SECTION] and [recording] tables, seed = N) or a run's summary.json
    (re-runs it); flags given here override it"""
    particles: int | None = None
    """number of particles (default 30; = --slam.n-particles)"""
    resolution: float | None = None
    """cell size in metres (default 0.05; = --slam.resolution-m)"""
    odometry: Literal["use", "ignore"] | None = None
    """use the log's odometry, or ignore it: every scan's motion found from the scans alone, lidar-only, as
    'mcnkit info/convert --odometry ignore' read a log (default use; = --slam.motion.odometry)"""
    seed: int | None = None
    """random seed (default 0, or the config file's)"""
    out: Path
    """output folder (created; an existing one that is not empty needs --overwrite)"""
    overwrite: bool = False
    """replace existing outputs (--out files, --rrd)"""
    no_progress: bool = False
    """no progress bar"""
    rrd: Path | None = None
    """record every step to this Rerun file (.rrd)"""
    rrd_map_every: int | None = None
    """record the best particle's map every N filter updates (default 10; = --recording.map-every)"""
    slam: SlamConfig = field(default_factory=SlamConfig)
    """The filter's settings."""


def add_slam_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Adds ``slam LOG --particles N --resolution M --seed S --out DIR``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        "slam",
        help="run grid FastSLAM (gmapping-class) on a robot log",
        usage="mcnkit slam LOG --out DIR [--rrd FILE] [--config FILE] [--slam.SECTION.FIELD VALUE ...] [options]",
        description=_DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_options(p, SlamOptions, positional=("log",), const=LIVE_CONST, aliases=SLAM_FLAG_ALIASES)
    p.set_defaults(func=run_slam)
    return p


def _scan_count(reader: Any) -> int | None:
    try:
        return next(t.count for t in reader.topics if t.name == reader.scan_topic)
    except (StopIteration, AttributeError, NotImplementedError):
        return None


def run_slam(args: argparse.Namespace) -> int:
    """Runs the filter over a log and writes trajectory, map and summary into ``args.out`` (also when interrupted:
    the results so far, ``"interrupted": true`` in ``summary.json``)."""
    import numpy as np

    from mcnkit.app.drive import SIGNALS, ProgressSink, Sink, drive
    from mcnkit.app.exits import fail
    from mcnkit.app.outputs import Output, OutputError, check_outputs
    from mcnkit.app.recording import RecordingConfig, ViewerError, live_viewer
    from mcnkit.app.runconfig import ConfigError, config_file, resolve_section
    from mcnkit.app.sinks import SlamOutputs
    from mcnkit.io import open_log
    from mcnkit.io.errors import LogError
    from mcnkit.slam.fastslam import FastSlam
    from mcnkit.viz.record import RecordingSink, announce_live, serve_on

    try:
        file = config_file(args)
        config, seed = resolve_slam_config(args, file)
        recording = resolve_section(RecordingConfig, args, "recording", file,
                                    {"map_every": ("--rrd-map-every", args.rrd_map_every)})
        live = live_viewer(args, recording)
    except (ConfigError, ViewerError) as err:
        return fail("slam", err)
    rrd: Path | None = getattr(args, "rrd", None)
    info = {"command": "slam", "log": str(args.log), "particles": config.n_particles,
            "resolution_m": config.resolution_m, "seed": seed, "config": dataclasses.asdict(config),
            "recording": dataclasses.asdict(recording)}
    slam = FastSlam(config, np.random.default_rng(seed))
    outputs = SlamOutputs(args.out, slam, info)
    logger = None
    try:
        check_outputs([args.log], [Output(args.out, folder=True), *([Output(rrd)] if rrd is not None else [])],
                      overwrite=getattr(args, "overwrite", False))
        with SIGNALS.deferred(), open_log(args.log, scan_topic=args.scan_topic, odom=args.odom,
                                          odometry=config.motion.odometry) as reader:
            info.update(scan_topic=reader.scan_topic, odometry_source=reader.odom_source)
            sinks: list[Sink] = [ProgressSink(_scan_count(reader), enabled=not args.no_progress)]
            if rrd is not None or live is not None:
                from mcnkit.viz import RerunLogger  # rerun only when asked for

                logger = RerunLogger(rrd, recording_id=f"slam-{Path(args.log).stem}-{seed}", live=live, config=info,
                                     flush_updates=recording.flush_updates)
                announce_live(logger)
                sinks.append(RecordingSink(logger, slam, map_every=recording.map_every, trajectory="tracked",
                                           keep_serving=True))
            outcome = drive(reader.frames(), slam, [*sinks, outputs], stop=SIGNALS.requested)
    except (LogError, OutputError) as err:
        return fail("slam", err)
    except OSError as err:
        return fail("slam", f"{err.filename}: {err.strerror}" if err.filename else err)
    try:
        if outputs.summary is None:
            if outcome.interrupted:
                return 0  # stopped before the first scan: main() reports the signal
            return fail("slam", f"{args.log}: no scans")
        summary = outputs.summary
        for note in slam.notes() if not outcome.interrupted else ():
            warnings.warn(note, stacklevel=1)
        stopped = f" (stopped by {outcome.stopped_by})" if outcome.interrupted else ""
        lidar = ", lidar-only (motion from the scans alone)" if slam.lidar_only else ""
        print(
            f"{slam.n_scans} scans{stopped}{lidar}, {slam.n_updates} filter updates, {slam.n_resamples} resamplings, "
            f"CPU {summary['cpu_s']:.1f} s, wall {summary['wall_s']:.1f} s, peak RSS {summary['peak_rss_mb']:.0f} MB"
            f" -> {args.out}", flush=True
        )
        return 0
    finally:
        if logger is not None:  # --serve: on after a finished run (until Ctrl-C by default)
            serve_on(logger, recording.linger_s if outputs.summary is not None else 0, SIGNALS)
