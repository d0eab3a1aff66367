"""``mcnkit run``: MCN-SLAM on a robot log, every step recorded to Rerun.

    mcnkit run LOG --rrd run.rrd [--model unet|pix2pix|PATH] [--samples K] [--ranks R] [--particles N]

At every filter update the R best particles' maps are completed K times by the network (one forward pass),
and the recording gets the particles, the best map and its unknown mask, each rank's m_t, its K samples and
their uncertainty (see :mod:`mcnkit.viz`).  With ``--out DIR`` it also writes ``trajectory.tum``, the map
(``map.pgm/.yaml/.png``), the last completion (``completion.png``) and ``summary.json`` (timings included).
An interrupted run (Ctrl-C, SIGTERM, a damaged log) still closes the recording (``rerun rrd verify`` passes) and
writes ``--out`` with the results so far (``"interrupted": true`` in ``summary.json``); exit code 130 / 143 for a
signal.  Outputs never replace an input, and replace an existing file only with ``--overwrite``.

``--connect [URL]`` streams the recording live to a running viewer and ``--serve`` from a gRPC server of its own on
127.0.0.1 (see :mod:`mcnkit.app.recording`), also beside ``--rrd``.  Settings: ``--slam.FIELD``, ``--mcn.FIELD`` and
``--recording.FIELD`` for every field of SlamConfig, McnConfig and RecordingConfig, or ``--config`` (TOML tables,
or a run's ``summary.json``, which holds them all; so does the recording, at ``/config``).

:func:`mcnkit.viz.run_mcn` is the same loop for scripts and notebooks (frames in, a summary out).
"""

from __future__ import annotations

import argparse
import dataclasses
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

from mcnkit.app.commands.info import TopicOptions
from mcnkit.app.options import add_options
from mcnkit.app.recording import LIVE_CONST, LiveOptions
from mcnkit.app.runconfig import SLAM_FLAG_ALIASES
from mcnkit.completion.registry import DEFAULT_MODEL, MODELS
from mcnkit.mcn_config import McnConfig
from mcnkit.slam.config import SlamConfig

__all__ = ["RunOptions", "add_run_parser", "cmd_run"]


_RUN_MAP_EVERY = 5
"""``mcnkit run``'s default McnConfig.full_map_every (the library's is 1): the best full map every 5 completions."""


def cmd_run(args: argparse.Namespace) -> int:
    """``mcnkit run``: see the module docstring."""
    import numpy as np
    import torch

    from mcnkit.app.drive import SIGNALS, drive
    from mcnkit.app.exits import fail
    from mcnkit.app.outputs import Output, check_outputs
    from mcnkit.app.recording import RecordingConfig, ViewerError, live_viewer
    from mcnkit.app.runconfig import ConfigError, config_file, resolve_section, resolve_slam_config
    from mcnkit.app.sinks import McnOutputs
    from mcnkit.completion.checkpoint import CheckpointError
    from mcnkit.io import open_log
    from mcnkit.mcn import McnSlam, load_model
    from mcnkit.viz.plots import completion_figure
    from mcnkit.viz.record import announce_live, mcn_sinks, recording_logger, serve_on

    try:
        file = config_file(args)
        slam_config, seed = resolve_slam_config(args, file)
        short = {name: (f"--{flag}", getattr(args, flag.replace("-", "_"))) for name, flag in (
            ("samples", "samples"), ("ranks", "ranks"), ("window", "window"), ("window_m", "window-m"),
            ("every", "every"), ("full_map_every", "map-every"))}
        config = resolve_section(McnConfig, args, "mcn", file, short, defaults={"full_map_every": _RUN_MAP_EVERY})
        recording = resolve_section(RecordingConfig, args, "recording", file)
        model_name = args.model if args.model is not None else file.get("model", DEFAULT_MODEL)
        if not isinstance(model_name, str):
            raise ConfigError(f"{args.config}: model: expected a name or a path, got {model_name!r}")
        live = live_viewer(args, recording)
    except (ConfigError, ViewerError) as err:
        return fail("run", err)
    model_path = [] if model_name in MODELS else [Path(model_name)]
    outputs = [Output(p, folder=p == args.out) for p in (args.rrd, args.out) if p is not None]
    check_outputs([args.log, *model_path], outputs, overwrite=args.overwrite)
    torch.set_num_threads(max(1, args.threads))
    try:
        model = load_model(model_name)
    except (CheckpointError, FileNotFoundError) as err:
        return fail("run", err)
    info = {"command": "run", "log": str(args.log), "model": model_name, "samples": config.samples,
            "ranks": config.ranks, "particles": slam_config.n_particles, "seed": seed, "window": config.window,
            "threads": args.threads, "config": dataclasses.asdict(slam_config), "mcn": dataclasses.asdict(config),
            "recording": dataclasses.asdict(recording)}
    recorded = args.rrd is not None or live is not None
    # the full map feeds only the recording (it changes no particle): not computed without one
    stepped = config if recorded else dataclasses.replace(config, full_map_every=0)
    mcn = McnSlam(slam_config, model, stepped, np.random.default_rng(seed),
                  generator=torch.Generator().manual_seed(seed))
    logger = None
    with SIGNALS.deferred(), open_log(args.log, scan_topic=args.scan_topic, odom=args.odom,
                                      odometry=slam_config.motion.odometry) as log:
        info.update(scan_topic=log.scan_topic, odometry_source=log.odom_source)
        count = next((t.count for t in getattr(log, "topics", []) if t.name == getattr(log, "scan_topic", None)),
                     None)
        rec_id = f"mcn-{Path(args.log).stem}-{model_name if model_name in MODELS else 'custom'}-{seed}"
        summary, sinks = mcn_sinks(mcn, rrd=args.rrd, recording_id=rec_id, progress=not args.no_progress,
                                   total=count, live=live, config=info, flush_updates=recording.flush_updates,
                                   keep_serving=True)
        logger = recording_logger(sinks)
        if logger is not None:
            announce_live(logger)
        if args.out is not None:
            sinks.append(McnOutputs(args.out, mcn, summary, info, draw=completion_figure))
        outcome = drive(log.frames(), mcn, sinks, stop=SIGNALS.requested)
    try:
        if summary.scans == 0:
            return 0 if outcome.interrupted else fail("run", f"{args.log}: no scans")
        for note in mcn.slam.notes() if not outcome.interrupted else ():
            warnings.warn(note, stacklevel=1)
        share = summary.cpu_s_recording / max(summary.cpu_s, 1e-9)
        stopped = f" (stopped by {outcome.stopped_by})" if outcome.interrupted else ""
        stopped += ", lidar-only (motion from the scans alone)" if mcn.slam.lidar_only else ""
        print(f"{summary.scans} scans{stopped}, {summary.filter_updates} filter updates, {summary.completions} "
              f"completions (R={config.ranks} × K={config.samples}), mean sample diversity "
              f"{summary.mean_diversity:.3f}; CPU {summary.cpu_s:.1f} s ({100 * share:.1f} % recording), wall "
              f"{summary.wall_s:.1f} s", flush=True)
        if args.rrd is not None:
            print(f"recording: {args.rrd} ({summary.rrd_bytes / 1e6:.1f} MB; {summary.rrd_bytes_written / 1e6:.1f} "
                  f"MB before compaction)    watch it: rerun {args.rrd}", flush=True)
        return 0
    finally:
        if logger is not None:  # --serve: on after a finished run (until Ctrl-C by default)
            serve_on(logger, recording.linger_s if summary.scans else 0, SIGNALS)


@dataclass(frozen=True, kw_only=True)
class RunOptions(LiveOptions, TopicOptions):
    """``mcnkit run LOG [--rrd FILE] [--out DIR] [...]``: the sections are ``slam``, ``mcn`` and ``recording``."""

    log: Path
    """a log open_log reads (CARMEN, .bag, rosbag2 folder, .mcap)"""
    rrd: Path | None = None
    """record every step to this Rerun file"""
    out: Path | None = None
    """also write trajectory.tum, map.pgm/.yaml/.png, completion.png, summary.json here"""
    overwrite: bool = False
    """replace existing outputs (--rrd, --out files)"""
    model: str | None = None
    """completion network: a shipped model's name or a checkpoint path (default: the config file's, else
    sampler-explore)"""
    config: Path | None = None
    """settings file: TOML ([slam], [slam.SECTION], [mcn] and [recording] tables, seed = N, model = NAME) or a
    run's summary.json (re-runs it); flags given here override it"""
    samples: int | None = None
    """K completions per particle (default 4; = --mcn.samples)"""
    ranks: int | None = None
    """R best particles completed (default 3; = --mcn.ranks)"""
    particles: int | None = None
    """SLAM particles (default 30; = --slam.n-particles)"""
    resolution: float | None = None
    """map cell size in metres (default 0.05; = --slam.resolution-m)"""
    odometry: Literal["use", "ignore"] | None = None
    """use the log's odometry, or ignore it: every scan's motion found from the scans alone, lidar-only, as
    'mcnkit info/convert --odometry ignore' read a log (default use; = --slam.motion.odometry)"""
    window: Literal["map", "robot"] | None = None
    """network input: the whole map shrunk to 64x64 (paper; the default) or a robot-centred square
    (= --mcn.window)"""
    window_m: float | None = None
    """side of the robot-centred window (default 12.8 m; = --mcn.window-m)"""
    every: int | None = None
    """complete at every N-th filter update (default 1: each; = --mcn.every)"""
    map_every: int | None = None
    """record the best full-resolution map every N completions (default 5; = --mcn.full-map-every; not computed
    without a recording)"""
    seed: int | None = None
    """seed of the filter and of the samples (default 0, or the config file's)"""
    threads: int = 1
    """torch CPU threads"""
    no_progress: bool = False
    """no progress bar"""
    slam: SlamConfig = field(default_factory=SlamConfig)
    """The filter's settings."""
    mcn: McnConfig = field(default_factory=McnConfig)
    """How the maps are completed."""


def add_run_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Registers ``mcnkit run``."""
    p = sub.add_parser("run", help="MCN-SLAM on a robot log: SLAM + sampled map completions, recorded to Rerun",
                       usage="mcnkit run LOG [--rrd FILE] [--out DIR] [--model NAME|PATH] [--config FILE] "
                             "[--slam.SECTION.FIELD|--mcn.FIELD|--recording.FIELD VALUE ...] [options]",
                       description="MCN-SLAM on a robot log.  At every filter update the R best particles' maps are "
                       "completed K times by the network (one forward pass); with --rrd the recording gets the "
                       "particles, the best map and its unknown mask, each rank's map, its K samples and their "
                       "uncertainty.  With --out it also writes trajectory.tum, the map (map.pgm/.yaml/.png), the "
                       "last completion (completion.png) and summary.json.  An interrupted run (Ctrl-C, SIGTERM, a "
                       "damaged log) still closes the recording (rerun rrd verify passes) and writes --out with the "
                       "results so far (\"interrupted\": true in summary.json); exit code 130 / 143 for a signal.  "
                       "Outputs never replace an input, and replace existing files only with --overwrite.  "
                       "--connect streams every step live to a running Rerun viewer, --serve from a gRPC server of "
                       "its own on 127.0.0.1 (both also beside --rrd).  Every SlamConfig, McnConfig and "
                       "RecordingConfig field is a flag (--slam.FIELD, --slam.SECTION.FIELD, --mcn.FIELD, "
                       "--recording.FIELD); summary.json and the recording (/config) hold the whole configuration, "
                       "and --config OUT/summary.json re-runs it.")
    model = (f"completion network: {', '.join(MODELS)} (shipped weights) or a checkpoint path (default: the config "
             f"file's, else {DEFAULT_MODEL}: the masked sampler trained on maps part-way through an exploration, whose "
             "K samples are K different houses; sampler is trained on the paper's one-scan maps; unet, unet-explore "
             "and pix2pix are deterministic nets whose samples differ only by dropout)")
    add_options(p, RunOptions, positional=("log",), const=LIVE_CONST, help={"model": model},
                aliases=SLAM_FLAG_ALIASES)
    p.set_defaults(func=cmd_run)
