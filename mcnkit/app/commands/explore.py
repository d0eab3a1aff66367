"""``mcnkit explore``: a simulated robot explores a floor plan on its own, choosing where to look next.

    mcnkit explore --map houseexpo:ID|procedural:SEED|image:FILE --planner frontier|mcn [--rrd FILE] [--out DIR]

The loop (:mod:`mcnkit.explore.loop`): lidar → FastSLAM → (K completions of the map →) planner → motion, until the
reachable free space is covered, no reachable frontier is left, or the path budget (``--explore.budget-m``) is
spent.  ``frontier`` goes to the nearest reachable frontier (Yamauchi 1997); ``mcn`` scores every frontier by the
area a scan from it is expected to reveal in K sampled completions of the map (``--model``), against the path cost.
``image:FILE`` is a PNG/PGM occupancy image (dark = wall, light = free), placed by a ROS map_server ``.yaml`` beside
it, else ``--resolution-m`` per pixel.

``--out DIR`` gets the map (``map.pgm/.yaml/.png``), the estimated and true trajectories (``trajectory.tum``,
``ground_truth.tum``), the coverage curve (``coverage.csv``) and ``summary.json`` (coverage reached, path length,
frames, planning steps, CPU time, the path to 50/80/90/95 % coverage, F of the final map and of its completion, the
whole configuration).  ``--rrd FILE`` records every frame and planning step (:mod:`mcnkit.viz.explore`).  An
interrupted run (Ctrl-C, SIGTERM) still closes the recording and writes ``--out`` with ``"interrupted": true``.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from mcnkit.app.options import add_options
from mcnkit.app.recording import LIVE_CONST, LiveOptions
from mcnkit.explore.config import ExploreConfig, GainConfig
from mcnkit.slam.config import SlamConfig

__all__ = ["DEFAULT_MODEL", "ExploreOptions", "add_explore_parser", "cmd_explore"]

DEFAULT_MODEL = "sampler-seen-large"
"""The completion model ``mcn`` plans with unless ``--model`` names another: the larger sampler trained on the
window the planner completes (the seen part plus 2 m, :func:`mcnkit.grid.seen_window`), whose expected gains choose
the viewpoint the true plan would more often than the smaller one's; the option's help names when ``sampler-seen``
is the better choice."""

_SLAM_DEFAULTS = {"updates": {"linear_m": 0.3, "angular_rad": 0.3}}
"""Explore's own SlamConfig defaults (those of :data:`mcnkit.explore.loop.EXPLORE_SLAM`)."""


def cmd_explore(args: argparse.Namespace) -> int:
    """``mcnkit explore``: see the module docstring."""
    import dataclasses
    import time

    import torch
    from tqdm import tqdm

    from mcnkit.app.drive import SIGNALS
    from mcnkit.app.exits import fail
    from mcnkit.app.outputs import Output, check_outputs
    from mcnkit.app.recording import RecordingConfig, ViewerError, live_viewer
    from mcnkit.app.runconfig import ConfigError, config_file, resolve_section, resolve_seed
    from mcnkit.completion.registry import MODELS, CheckpointError
    from mcnkit.explore.loop import Explorer, seed_streams
    from mcnkit.explore.metrics import final_map_f, summarize
    from mcnkit.explore.planners import FrontierPlanner, McnPlanner, Planner
    from mcnkit.mcn import load_model
    from mcnkit.sim import SimConfig, plan_raster

    try:
        file = config_file(args)
        seed = resolve_seed(args, file)
        explore_cfg = resolve_section(ExploreConfig, args, "explore", file)
        gain_cfg = resolve_section(GainConfig, args, "gain", file)
        slam_cfg = resolve_section(SlamConfig, args, "slam", file, defaults=_SLAM_DEFAULTS)
        recording = resolve_section(RecordingConfig, args, "recording", file)
        live = live_viewer(args, recording)
        raster = plan_raster(args.map, args.resolution_m, args.houseexpo)
    except (ConfigError, ViewerError, ValueError) as err:
        return fail("explore", err)
    inputs = [Path(args.map.partition(":")[2])] if args.map.startswith("image:") else []
    uses_model = args.planner == "mcn"
    if uses_model and args.model not in MODELS:
        inputs.append(Path(args.model))
    outputs = [Output(p, folder=p == args.out) for p in (args.rrd, args.out) if p is not None]
    check_outputs(inputs, outputs, overwrite=args.overwrite)
    torch.set_num_threads(max(1, args.threads))
    sim = SimConfig(resolution_m=args.resolution_m)
    planner: Planner = FrontierPlanner()
    net = None
    if uses_model:
        try:
            net = load_model(args.model)
        except (CheckpointError, FileNotFoundError) as err:
            return fail("explore", err)
        planner = McnPlanner(net, gain_cfg, sim.lidar.range_max_m, torch.Generator().manual_seed(seed_streams(seed)[2]))
    info: dict[str, Any] = {"command": "explore", "map": args.map, "planner": args.planner,
                            "model": args.model if uses_model else None, "seed": seed, "threads": args.threads,
                            "explore": dataclasses.asdict(explore_cfg), "gain": dataclasses.asdict(gain_cfg),
                            "slam": dataclasses.asdict(slam_cfg), "recording": dataclasses.asdict(recording)}
    t0 = time.perf_counter()
    try:
        explorer = Explorer(raster, planner, explore_cfg, sim, slam_cfg, seed)
    except ValueError as err:  # a plan with no place the robot fits
        return fail("explore", err)
    recorder = None
    if args.rrd is not None or live is not None:
        from mcnkit.viz.explore import ExploreRecorder

        recorder = ExploreRecorder(args.rrd, explorer, samples=gain_cfg.samples if uses_model else 0,
                                   recording_id=f"explore-{raster.name}-{args.planner}-{seed}", live=live, config=info)
    stopped_by = None
    try:
        with SIGNALS.deferred(), tqdm(total=round(explore_cfg.budget_m), unit="m", disable=args.no_progress,
                                      desc=f"explore ({args.planner})") as bar:
            if recorder is not None:
                recorder.on_frame(explorer.records[0])
            while not explorer.done:
                if (stopped_by := SIGNALS.requested()) is not None:
                    break
                record = explorer.step()
                if recorder is not None:
                    recorder.on_frame(record)
                bar.update(int(explorer.path_length_m) - bar.n)
                bar.set_postfix(coverage=f"{explorer.coverage:.2f}", refresh=False)
    finally:
        if recorder is not None:
            recorder.close()
    if args.rrd is not None and stopped_by is None and args.rrd.is_file():
        from mcnkit.viz.files import optimize_recording

        optimize_recording(args.rrd)  # compacted, as mcnkit run's finished recordings are
    with SIGNALS.deferred():
        f_slam, f_done = final_map_f(explorer, net, gain_cfg.samples, torch.Generator().manual_seed(seed))
        summary = summarize(explorer, f_slam, f_done)
        result = {**info, "interrupted": stopped_by is not None, "stopped_by": stopped_by, **summary.as_dict(),
                  "wall_s": time.perf_counter() - t0}
        if args.out is not None:
            _write_outputs(args.out, explorer, result)
    done = summary.path_to_coverage_m["0.9"]
    why = _STOPS.get(summary.stop_reason, summary.stop_reason) if stopped_by is None else f"stopped by {stopped_by}"
    if stopped_by is None and summary.stop_reason == "explored" and summary.frontiers_left:
        why += f" ({summary.frontiers_left} frontier segment{'s' * (summary.frontiers_left > 1)} left that no path reaches)"
    print(f"{why}: coverage "
          f"{summary.coverage:.3f} after {summary.path_length_m:.1f} m ({summary.frames} frames, "
          f"{summary.planning_steps} planning steps"
          f"{f', {summary.collisions} collisions' if summary.collisions else ''}), 90 % coverage at "
          f"{'—' if done is None else f'{done:.1f} m'}; F of the map {f_slam:.3f}"
          f"{'' if f_done is None else f', completed {f_done:.3f}'}; CPU {summary.cpu_s:.1f} s "
          f"({1000 * summary.plan_cpu_s_mean:.0f} ms per planning step)", flush=True)
    if args.rrd is not None:
        print(f"recording: {args.rrd}    watch it: rerun {args.rrd}", flush=True)
    return 0


_STOPS = {"explored": "no reachable frontier left", "coverage": "the reachable free space is covered",
          "budget": "path budget spent", "time": "time limit reached", "stuck": "no room to move on the map"}


def _write_outputs(out: Path, explorer: Any, summary: dict[str, Any]) -> None:
    """map.pgm/.yaml/.png, trajectory.tum, ground_truth.tum, coverage.csv and summary.json, staged."""
    import json

    import numpy as np

    from mcnkit.app.outputs import staged_folder
    from mcnkit.io.mapfiles import write_map_strips
    from mcnkit.metrics import write_tum
    from mcnkit.types import Trajectory

    records = explorer.records[: explorer.n_frames]
    rate = explorer.sim.scan_rate_hz
    stamps = explorer.sim.start_stamp_ns + np.array([round(r.index * 1e9 / rate) for r in records], np.int64)
    with staged_folder(out) as tmp:
        write_tum(tmp / "trajectory.tum", Trajectory(stamps, np.array([r.estimate for r in records])))
        write_tum(tmp / "ground_truth.tum", Trajectory(stamps.copy(), np.array([r.truth for r in records])))
        spec, strips = explorer.slam.best_map_strips()
        write_map_strips(tmp, spec, strips, explorer.slam.config.map.occ_thresh)
        lines = ["frame,path_length_m,coverage", *(f"{r.index},{r.path_length_m:.3f},{r.coverage:.5f}" for r in records)]
        (tmp / "coverage.csv").write_text("\n".join(lines) + "\n")
        (tmp / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")


@dataclass(frozen=True, kw_only=True)
class ExploreOptions(LiveOptions):
    """``mcnkit explore --map SPEC --planner frontier|mcn [--rrd FILE] [--out DIR]``: the sections are ``explore``,
    ``gain``, ``slam`` and ``recording``."""

    map: str
    """the floor plan: houseexpo:ID, procedural:SEED or image:FILE (a PNG/PGM occupancy image, dark = wall)"""
    planner: Literal["frontier", "mcn"] = "mcn"
    """frontier: the nearest reachable frontier; mcn: frontiers scored by what K sampled completions expect a scan
    from there to reveal, against the path cost"""
    rrd: Path | None = None
    """record every frame and planning step to this Rerun file"""
    out: Path | None = None
    """write map.pgm/.yaml/.png, trajectory.tum, ground_truth.tum, coverage.csv and summary.json here"""
    overwrite: bool = False
    """replace existing outputs (--rrd, --out files)"""
    model: str = DEFAULT_MODEL
    """completion model of the mcn planner: a shipped model's name or a checkpoint path (sampler-seen: four to
    six times less CPU per planning step, and it explored buildings larger than a house better; see
    docs/exploration.md)"""
    seed: int | None = None
    """seed of the start pose, the sensor and odometry noise, the filter and the samples (default 0, or the config
    file's)"""
    resolution_m: float = 0.05
    """cell size of the plan's raster; for image:FILE without a map_server .yaml beside it, the image's pixel size"""
    houseexpo: str | None = None
    """HouseExpo json.tar.gz or json/ folder (default: the installed one)"""
    config: Path | None = None
    """settings file: TOML ([explore], [gain], [slam], [slam.SECTION], [recording] tables, seed = N) or a run's
    summary.json; flags given here override it"""
    threads: int = 1
    """torch CPU threads"""
    no_progress: bool = False
    """no progress bar"""
    explore: ExploreConfig = field(default_factory=ExploreConfig)
    """The closed loop's settings."""
    gain: GainConfig = field(default_factory=GainConfig)
    """How the mcn planner scores a viewpoint."""
    slam: SlamConfig = field(default_factory=SlamConfig)
    """The filter's settings (explore's defaults differ from mcnkit slam's in one place: a filter update every
    0.3 m or 0.3 rad, --slam.updates.linear-m / --slam.updates.angular-rad)."""


def add_explore_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Registers ``mcnkit explore``."""
    p = sub.add_parser("explore", help="a simulated robot explores a floor plan on its own (frontier or mcn planner)",
                       usage="mcnkit explore --map SPEC [--planner frontier|mcn] [--rrd FILE] [--out DIR] "
                             "[--model NAME|PATH] [--explore.FIELD|--gain.FIELD|--slam.SECTION.FIELD VALUE ...]",
                       description="A simulated robot explores a floor plan on its own: lidar -> FastSLAM -> (K "
                       "completions of its map ->) planner -> motion; it stops once the reachable free space is covered, no "
                       "reachable frontier is left, or the path budget (--explore.budget-m) is spent.  frontier goes to "
                       "the nearest reachable frontier (Yamauchi 1997); mcn scores every frontier by the area a scan "
                       "from it is expected to reveal in K sampled completions of the map (--model), against the path "
                       "cost.  image:FILE is a PNG/PGM occupancy image (dark = wall, light = free), placed by a ROS "
                       "map_server .yaml beside it, else --resolution-m per pixel.  --out DIR gets the map "
                       "(map.pgm/.yaml/.png), trajectory.tum, ground_truth.tum, coverage.csv and summary.json "
                       "(coverage, path length, frames, CPU time, path to 50/80/90/95% coverage, F of the final map "
                       "and of its completion, the whole configuration; --config DIR/summary.json re-runs it); --rrd "
                       "records every frame and planning step.  An interrupted run (Ctrl-C, SIGTERM) still closes the "
                       "recording and writes --out with \"interrupted\": true.  Outputs never replace an input, and "
                       "replace existing files only with --overwrite.")
    add_options(p, ExploreOptions, const=LIVE_CONST)
    p.set_defaults(func=cmd_explore)
