"""``mcnkit demo``: MCN-SLAM end to end on embedded data (no download, shipped network weights).

1. simulate a robot exploring a procedurally generated apartment (lidar + drifting odometry + ground truth);
2. write it as a ROS2-profile MCAP log and show ``mcnkit info`` of it;
3. run MCN-SLAM on the log: grid FastSLAM, and at every filter update K sampled completions of the R best
   particles' maps by the shipped masked sampler, every step recorded to a Rerun file (``recordings/demo/demo.rrd``);
   write the trajectory (TUM), the map (PGM/YAML/PNG) and the last completions (PNG);
4. score against the ground truth: trajectory (ATE, SLAM vs raw odometry) and map completion (F of the free
   space, SLAM map vs completed map, at the first and the last filter update).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from mcnkit.app.options import add_options
from mcnkit.app.recording import LIVE_CONST, LiveOptions
from mcnkit.completion.registry import DEFAULT_MODEL, MODELS

if TYPE_CHECKING:
    from mcnkit.app.drive import Outcome, Signals
    from mcnkit.app.recording import LiveViewer, RecordingConfig
    from mcnkit.app.sinks import RunSummary
    from mcnkit.mcn import McnSlam
    from mcnkit.sim import SimResult

__all__ = ["DemoOptions", "DemoResult", "add_demo_parser", "run_demo"]


@dataclass(frozen=True)
class DemoResult:
    """Where the demo wrote its files and how well MCN-SLAM did."""

    log_path: Path
    rrd_path: Path
    map_png: Path
    completion_png: Path
    scans: int
    filter_updates: int
    ate_slam_m: float
    ate_odometry_m: float
    f_slam_first: float
    f_completed_first: float
    f_slam_last: float
    f_completed_last: float
    wall_s: float


def run_demo(out: Path, rrd: Path, *, apartment: int = 3, seed: int = 0, particles: int = 30,
             duration_s: float = 120.0, samples: int = 4, ranks: int = 2, model: str = DEFAULT_MODEL,
             progress: bool = True, signals: Signals | None = None, live: LiveViewer | None = None,
             recording: RecordingConfig | None = None) -> DemoResult:
    """Simulates, records and scores one run (see the module docstring).

    With ``signals`` (``mcnkit demo``), a SIGINT / SIGTERM during MCN-SLAM stops it between frames, the recording
    and outputs so far are written, and :class:`~mcnkit.app.drive.Interrupted` is raised; a recording served live
    (``live``, see :mod:`mcnkit.app.recording`) stays up after the run for ``recording.linger_s``.
    """
    import dataclasses
    from contextlib import nullcontext

    import numpy as np
    import torch

    from mcnkit.app.drive import drive
    from mcnkit.app.recording import RecordingConfig
    from mcnkit.app.sinks import McnOutputs
    from mcnkit.io import open_log
    from mcnkit.io.info import describe, print_info
    from mcnkit.mcn import McnConfig, McnSlam, load_model
    from mcnkit.sim import SimConfig, plan_raster, simulate, write_sim_log
    from mcnkit.slam import SlamConfig
    from mcnkit.types import TernaryMap
    from mcnkit.viz.plots import completion_figure
    from mcnkit.viz.record import announce_live, mcn_sinks, recording_logger, serve_on

    t0 = time.perf_counter()
    net = load_model(model)  # first: a bad checkpoint is reported before anything is simulated or written
    out.mkdir(parents=True, exist_ok=True)
    print(f"[1/4] simulating a robot in procedural apartment #{apartment} (seed {seed})")
    raster = plan_raster(f"procedural:{apartment}", 0.05, None)
    sim = simulate(raster, SimConfig(max_duration_s=duration_s), seed)
    log_path = write_sim_log(sim, out / "apartment.mcap", "mcap", overwrite=True)
    print(f"[2/4] wrote {log_path}")
    with open_log(log_path) as log:
        print_info(describe(log))
        frames = list(log.frames())
    truth = TernaryMap(np.where(raster.free, 0.0, 1.0).astype(np.float32), raster.grid)
    print(f"[3/4] MCN-SLAM: {particles} particles, {samples} completions of the {ranks} best maps per filter "
          f"update ({model}), recording every step to {rrd}")
    slam_config, mcn_config = SlamConfig(n_particles=particles), McnConfig(samples=samples, ranks=ranks)
    recording = recording or RecordingConfig()
    mcn = McnSlam(slam_config, net, mcn_config, np.random.default_rng(seed),
                  generator=torch.Generator().manual_seed(seed), ground_truth=truth)
    info = {"command": "demo", "log": str(log_path), "model": model, "samples": samples, "ranks": ranks,
            "particles": particles, "seed": seed, "apartment": apartment, "duration_s": duration_s,
            "config": dataclasses.asdict(slam_config), "mcn": dataclasses.asdict(mcn_config),
            "recording": dataclasses.asdict(recording)}
    with signals.deferred() if signals is not None else nullcontext():
        summary, sinks = mcn_sinks(mcn, rrd=rrd, recording_id=f"demo-apartment{apartment}-seed{seed}",
                                   ground_truth=truth, progress=progress, live=live, config=info,
                                   flush_updates=recording.flush_updates, keep_serving=signals is not None)
        logger = recording_logger(sinks)
        if logger is not None:
            announce_live(logger)
        sinks.append(McnOutputs(out, mcn, summary, info, dpi=100, draw=completion_figure))
        outcome = drive(frames, mcn, sinks, stop=signals.requested if signals is not None else None)
    try:
        result = _score(outcome, signals, mcn, sim, summary, log_path, rrd, out, t0)
    except BaseException:
        if logger is not None:
            logger.stop_serving()
        raise
    if logger is not None:
        serve_on(logger, recording.linger_s, signals)
    return result


def _score(outcome: Outcome, signals: Signals | None, mcn: McnSlam, sim: SimResult, summary: RunSummary,
           log_path: Path, rrd: Path, out: Path, t0: float) -> DemoResult:
    """Step 4: the run against the ground truth, printed and written to ``demo.json``."""
    from mcnkit.app.drive import Interrupted
    from mcnkit.metrics import absolute_trajectory_error

    if outcome.interrupted and signals is not None and signals.received is not None:
        raise Interrupted(signals.received)
    ate_slam = absolute_trajectory_error(mcn.slam.trajectory(), sim.ground_truth)
    ate_odom = absolute_trajectory_error(sim.odometry, sim.ground_truth)
    first, final = summary.scores[0], summary.scores[-1]
    result = DemoResult(log_path, rrd, out / "map.png", out / "completion.png", summary.scans,
                        summary.filter_updates, ate_slam.rmse_m, ate_odom.rmse_m, first["f_slam"],
                        first["f_completed"], final["f_slam"], final["f_completed"], time.perf_counter() - t0)
    (out / "demo.json").write_text(json.dumps({k: str(v) if isinstance(v, Path) else v
                                               for k, v in result.__dict__.items()}, indent=2) + "\n")
    print(f"[4/4] against the ground truth: trajectory ATE RMSE {ate_slam.rmse_m:.3f} m (odometry alone "
          f"{ate_odom.rmse_m:.3f} m); free-space F at the first update {first['f_slam']:.3f} (SLAM map) -> "
          f"{first['f_completed']:.3f} (completed), at the last {final['f_slam']:.3f} -> {final['f_completed']:.3f}"
          f"  ({summary.scans} scans, {summary.filter_updates} filter updates, {result.wall_s:.1f} s)")
    return result


def _main(args: argparse.Namespace) -> int:
    from mcnkit.app.drive import SIGNALS
    from mcnkit.app.exits import fail
    from mcnkit.app.outputs import Output, check_outputs
    from mcnkit.app.recording import RecordingConfig, ViewerError, live_viewer
    from mcnkit.app.runconfig import ConfigError, resolve_section

    try:
        recording = resolve_section(RecordingConfig, args, "recording", {})
        live = live_viewer(args, recording)
    except (ConfigError, ViewerError) as err:
        return fail("demo", err)
    model_path = [] if args.model in MODELS else [Path(args.model)]
    rrd = args.rrd if args.rrd is not None else args.out / "demo.rrd"
    check_outputs(model_path, [Output(args.out, folder=True), Output(rrd)], overwrite=args.overwrite)
    result = run_demo(args.out, rrd, apartment=args.apartment, seed=args.seed, particles=args.particles,
                      duration_s=args.duration_s, samples=args.samples, ranks=args.ranks, model=args.model,
                      signals=SIGNALS, live=live, recording=recording)
    print(f"\nrecording: {result.rrd_path}   map: {result.map_png}   completions: {result.completion_png}")
    print(f"watch it:  {_rerun_command()} {result.rrd_path}")
    print(f"           headless: {_rerun_command()} {result.rrd_path} --serve-web --bind 127.0.0.1 (then open the "
          "printed http address)")
    print(f"           in Jupyter: {_notebook_hint(result.rrd_path)}")
    return 0


def _notebook_hint(rrd: Path) -> str:
    """Where to watch the recording in Jupyter: the quickstart notebook of a checkout when the command runs from its
    root, else the one call that shows any recording (an installed wheel ships no notebooks)."""
    notebook = Path("notebooks/01_quickstart.ipynb")
    if notebook.is_file():
        return f"open {notebook}"
    return f'mcnkit.viz.recording_viewer("{rrd.resolve()}").display()'


def _rerun_command() -> str:
    """The ``rerun`` viewer installed beside this Python (relative to here when it lies below), else ``rerun``."""
    viewer = Path(sys.executable).parent / "rerun"
    if not viewer.is_file():
        return "rerun"
    try:
        return str(viewer.relative_to(Path.cwd()))
    except ValueError:
        return str(viewer)


_DESCRIPTION = """MCN-SLAM end to end on embedded data (no download, shipped network weights):

  1. simulate a robot exploring a procedurally generated apartment (lidar, drifting odometry, ground truth);
  2. write it as a ROS2-profile MCAP log and show 'mcnkit info' of it;
  3. run MCN-SLAM on the log: grid FastSLAM and, at every filter update, K sampled completions of the R best
     particles' maps by the shipped masked sampler, every step recorded to a Rerun file (--rrd); write the trajectory
     (TUM), the map (PGM/YAML/PNG) and the last completions (PNG) into --out;
  4. score against the ground truth: trajectory (ATE, SLAM vs raw odometry) and map completion (F of the free
     space, SLAM map vs completed map, at the first and the last filter update).

Outputs go to recordings/demo/ by default (git ignores it); an earlier run there is replaced only with
--overwrite.  Ctrl-C or SIGTERM during MCN-SLAM writes the recording and outputs so far (exit 130 / 143).
Watch it live: --connect streams to a running Rerun viewer, --serve from a gRPC server on 127.0.0.1."""


@dataclass(frozen=True, kw_only=True)
class DemoOptions(LiveOptions):
    """``mcnkit demo [--out DIR] [...]``."""

    out: Path = Path("recordings/demo")
    """output folder (default recordings/demo, which git ignores)"""
    rrd: Path | None = None
    """the Rerun recording (default OUT/demo.rrd)"""
    overwrite: bool = False
    """replace the outputs of an earlier run"""
    apartment: int = 3
    """procedural apartment number"""
    seed: int = 0
    """random seed of the robot run and the filter"""
    particles: int = 30
    """SLAM particles"""
    duration_s: float = 120.0
    """simulated seconds at most"""
    samples: int = 4
    """K completions per particle"""
    ranks: int = 2
    """R best particles completed"""
    model: str = DEFAULT_MODEL
    """a shipped model's name or a checkpoint path"""


def add_demo_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Registers ``mcnkit demo``."""
    p = sub.add_parser("demo", help="simulate an apartment, run MCN-SLAM on its log, record it for Rerun (no dataset)",
                       description=_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_options(p, DemoOptions, const=LIVE_CONST,
                help={"model": f"{', '.join(MODELS)} (shipped weights) or a checkpoint path (default {DEFAULT_MODEL})"})
    p.set_defaults(func=_main)
