"""``mcnkit run``: MCN-SLAM on a robot log, every step recorded to Rerun.

    mcnkit run LOG --rrd run.rrd [--model unet|pix2pix|PATH] [--samples K] [--ranks R] [--particles N]

At every filter update the R best particles' maps are completed K times by the network (one forward pass),
and the recording gets the particles, the best map and its unknown mask, each rank's m_t, its K samples and
their uncertainty (see :mod:`mcnkit.viz`).  With ``--out DIR`` it also writes ``trajectory.tum``, the map
(``map.pgm/.yaml/.png``), the last completion (``completion.png``) and ``summary.json`` (timings included).
An interrupted run (Ctrl-C, a damaged log) still closes the recording: what was logged stays readable.

:func:`run_mcn` is the same loop for scripts and notebooks (frames in, a :class:`RunSummary` out).
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from collections.abc import Callable, Iterable
from contextlib import ExitStack
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mcnkit.completion.registry import MODELS
from mcnkit.slam.config import SlamConfig
from mcnkit.types import Frame, TernaryMap

if TYPE_CHECKING:  # torch loads when a run starts, not for `mcnkit run --help`
    from mcnkit.mcn import Completion, McnSlam, StepResult

__all__ = ["RunSummary", "add_run_parser", "run_mcn"]


@dataclass
class RunSummary:
    """What a run did and how long it took (CPU seconds of this process)."""

    scans: int = 0
    filter_updates: int = 0
    completions: int = 0
    cpu_s: float = 0.0
    cpu_s_recording: float = 0.0
    """CPU spent writing the recording (included in ``cpu_s``)."""
    wall_s: float = 0.0
    mean_diversity: float = float("nan")
    rrd_bytes_written: int = 0
    """Size of the recording as written, and after ``rerun rrd optimize`` (0 without a recording)."""
    rrd_bytes: int = 0
    scores: list[dict[str, float]] = field(default_factory=list)
    """Per completion, the step's scores against the ground truth (empty without one)."""
    last_completion: Completion | None = field(default=None, repr=False)
    """The run's last completion (for a figure); not part of :meth:`as_dict`."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict (without ``last_completion``)."""
        return {k: v for k, v in asdict(self).items() if k != "last_completion"}


def run_mcn(frames: Iterable[Frame], mcn: McnSlam, *, rrd: Path | None = None, recording_id: str | None = None,
            ground_truth: TernaryMap | None = None, progress: bool = True, total: int | None = None,
            on_step: Callable[[Frame, StepResult], None] | None = None, notebook_viewer: bool = False,
            optimize: bool = True) -> RunSummary:
    """Feeds ``frames`` to ``mcn`` and records each step to ``rrd`` (when given); returns the summary.

    ``on_step(frame, result)`` is called after every step (a notebook can draw from it).  A finished recording is
    compacted with ``rerun rrd optimize`` unless ``optimize=False`` (an interrupted one is left as written).
    """
    from tqdm import tqdm

    summary = RunSummary()
    cpu0, wall0 = time.process_time(), time.perf_counter()
    diversities: list[float] = []
    with ExitStack() as stack:
        recorder = None
        if rrd is not None:
            from mcnkit.viz import RerunLogger, mcn_blueprint

            cfg = mcn.config
            recorder = stack.enter_context(RerunLogger(rrd, recording_id, mcn_blueprint(cfg.ranks, cfg.samples),
                                                       notebook_viewer=notebook_viewer))
            if ground_truth is not None:
                recorder.log_ground_truth(ground_truth)
        bar = tqdm(frames, total=total, unit="scan", disable=not progress)
        for frame in bar:
            result = mcn.step(frame)
            summary.scans += 1
            if result.completion is not None:
                summary.completions += 1
                summary.last_completion = result.completion
                diversities.append(float(result.completion.diversity[0]))
                if result.scores:
                    summary.scores.append(dict(result.scores))
                bar.set_postfix(updates=mcn.slam.n_updates, neff=f"{result.slam.neff:.1f}", refresh=False)
            if recorder is not None:
                t0 = time.process_time()
                traj = mcn.slam.update_poses()[:, :2] if result.slam.updated else None  # corrected poses so far
                recorder.log_mcn_step(frame, result, traj)
                summary.cpu_s_recording += time.process_time() - t0
            if on_step is not None:
                on_step(frame, result)
    summary.filter_updates = mcn.slam.n_updates
    summary.cpu_s = time.process_time() - cpu0
    summary.wall_s = time.perf_counter() - wall0
    if rrd is not None and optimize:
        from mcnkit.viz import optimize_recording

        summary.rrd_bytes_written, summary.rrd_bytes = optimize_recording(rrd)
    summary.mean_diversity = float(np.mean(diversities)) if diversities else float("nan")
    return summary


def _write_outputs(out: Path, mcn: McnSlam, summary: RunSummary, args: argparse.Namespace) -> None:
    from mcnkit.io.mapfiles import write_map
    from mcnkit.metrics import write_tum

    out.mkdir(parents=True, exist_ok=True)
    write_tum(out / "trajectory.tum", mcn.slam.trajectory())
    write_map(mcn.slam.best_map(), out)
    payload = {"log": str(args.log), "model": args.model, "samples": args.samples, "ranks": args.ranks,
               "particles": args.particles, "seed": args.seed, "window": args.window,
               "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0, **summary.as_dict()}
    (out / "summary.json").write_text(json.dumps(payload, indent=2) + "\n")


def cmd_run(args: argparse.Namespace) -> int:
    """``mcnkit run``: see the module docstring."""
    import torch

    from mcnkit.cli import fail
    from mcnkit.completion.checkpoint import CheckpointError
    from mcnkit.io import open_log
    from mcnkit.mcn import McnConfig, McnSlam, load_model

    torch.set_num_threads(max(1, args.threads))
    try:
        model = load_model(args.model)
    except (CheckpointError, FileNotFoundError) as err:
        return fail("run", err)
    try:
        config = McnConfig(samples=args.samples, ranks=args.ranks, window=args.window, window_m=args.window_m,
                           every=args.every, full_map_every=args.map_every if args.rrd is not None else 0)
        slam_config = SlamConfig(n_particles=args.particles, resolution_m=args.resolution)
    except ValueError as err:
        return fail("run", err)
    mcn = McnSlam(slam_config, model, config, np.random.default_rng(args.seed),
                  generator=torch.Generator().manual_seed(args.seed))
    with open_log(args.log) as log:
        count = next((t.count for t in getattr(log, "topics", []) if t.name == getattr(log, "scan_topic", None)),
                     None)
        rec_id = f"mcn-{Path(args.log).stem}-{args.model if args.model in MODELS else 'custom'}-{args.seed}"
        summary = run_mcn(log.frames(), mcn, rrd=args.rrd, recording_id=rec_id, progress=not args.no_progress,
                          total=count)
    if summary.scans == 0:
        return fail("run", f"{args.log}: no scans")
    if args.out is not None:
        _write_outputs(args.out, mcn, summary, args)
        if summary.last_completion is not None:
            from mcnkit.plots import completion_figure

            completion_figure(summary.last_completion).savefig(args.out / "completion.png", dpi=110)
    share = summary.cpu_s_recording / max(summary.cpu_s, 1e-9)
    print(f"{summary.scans} scans, {summary.filter_updates} filter updates, {summary.completions} completions "
          f"(R={args.ranks} × K={args.samples}), mean sample diversity {summary.mean_diversity:.3f}; CPU "
          f"{summary.cpu_s:.1f} s ({100 * share:.1f} % recording), wall {summary.wall_s:.1f} s")
    if args.rrd is not None:
        print(f"recording: {args.rrd} ({summary.rrd_bytes / 1e6:.1f} MB; {summary.rrd_bytes_written / 1e6:.1f} MB "
              f"before compaction)    watch it: rerun {args.rrd}")
    return 0


def add_run_parser(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Registers ``mcnkit run``."""
    p = sub.add_parser("run", help="MCN-SLAM on a robot log: SLAM + sampled map completions, recorded to Rerun",
                       description="MCN-SLAM on a robot log.  At every filter update the R best particles' maps are "
                       "completed K times by the network (one forward pass); with --rrd the recording gets the "
                       "particles, the best map and its unknown mask, each rank's map, its K samples and their "
                       "uncertainty.  With --out it also writes trajectory.tum, the map (map.pgm/.yaml/.png), the "
                       "last completion (completion.png) and summary.json.  An interrupted run (Ctrl-C, a damaged "
                       "log) still closes the recording: what was logged stays readable.")
    p.add_argument("log", type=Path, help="a log open_log reads (CARMEN, .bag, rosbag2 folder, .mcap)")
    p.add_argument("--rrd", type=Path, default=None, help="record every step to this Rerun file")
    p.add_argument("--out", type=Path, default=None,
                   help="also write trajectory.tum, map.pgm/.yaml/.png, completion.png, summary.json here")
    p.add_argument("--model", default="unet-explore",
                   help=f"completion network: {', '.join(MODELS)} (shipped weights) or a checkpoint path "
                        "(default unet-explore: the U-net trained on maps part-way through an exploration, which "
                        "leaves the outside of a building occupied; unet is the paper's, trained on one-scan maps)")
    p.add_argument("--samples", type=int, default=4, help="K completions per particle (default 4)")
    p.add_argument("--ranks", type=int, default=3, help="R best particles completed (default 3)")
    p.add_argument("--particles", type=int, default=30, help="SLAM particles (default 30)")
    p.add_argument("--resolution", type=float, default=0.05, help="map cell size in metres (default 0.05)")
    p.add_argument("--window", choices=["map", "robot"], default="map",
                   help="network input: the whole map shrunk to 64x64 (paper) or a robot-centred square")
    p.add_argument("--window-m", type=float, default=12.8, help="side of the robot-centred window (default 12.8 m)")
    p.add_argument("--every", type=int, default=1, help="complete at every N-th filter update (default 1: each)")
    p.add_argument("--map-every", type=int, default=5,
                   help="with --rrd: record the best full-resolution map every N completions (default 5)")
    p.add_argument("--seed", type=int, default=0, help="seed of the filter and of the samples")
    p.add_argument("--threads", type=int, default=1, help="torch CPU threads (default 1)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_run)


if __name__ == "__main__":
    from mcnkit.cli import main

    sys.exit(main(["run", *sys.argv[1:]]))
