"""The sinks of :func:`mcnkit.app.drive.drive`: MCN-SLAM's run statistics and the output
folders of ``mcnkit slam`` and ``mcnkit run`` / ``demo`` (written when the drive ends, however it ends, with
``"interrupted"`` in ``summary.json``).

Torch and matplotlib are imported only by the sinks that need them (when they are made or closed).  The sink that
records to Rerun is :class:`mcnkit.viz.record.RecordingSink`.
"""

from __future__ import annotations

import json
import resource
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from mcnkit.app.drive import DriveStep, Outcome
from mcnkit.app.outputs import staged_folder

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from mcnkit.mcn import Completion, McnSlam
    from mcnkit.slam.fastslam import FastSlam

__all__ = ["McnOutputs", "McnStats", "RunSummary", "SlamOutputs", "peak_rss_mb"]


def peak_rss_mb() -> float:
    """This process's peak resident memory so far, MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _stop_fields(outcome: Outcome) -> dict[str, Any]:
    return {"interrupted": outcome.interrupted, "stopped_by": outcome.stopped_by}


@dataclass
class RunSummary:
    """What an MCN-SLAM run did and how long it took (CPU seconds of this process)."""

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
    interrupted: bool = False
    """True when the run stopped before the frames ran out (a signal, an error)."""
    lidar_only: bool = False
    """True when no odometry reached the filter (none in the log, or ``--slam.motion.odometry ignore``)."""

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict (without ``last_completion``)."""
        return {k: v for k, v in asdict(self).items() if k != "last_completion"}


class McnStats:
    """Fills a :class:`RunSummary` from MCN-SLAM steps."""

    def __init__(self, mcn: McnSlam) -> None:
        self.mcn = mcn
        self.summary = RunSummary()
        self._diversities: list[float] = []

    def on_step(self, step: DriveStep) -> None:
        """Counts the scan and, at a completion, its diversity and scores."""
        self.summary.scans += 1
        c = step.mcn.completion if step.mcn is not None else None
        if c is not None and step.mcn is not None:
            self.summary.completions += 1
            self.summary.last_completion = c
            self._diversities.append(float(c.diversity[0]))
            if step.mcn.scores:
                self.summary.scores.append(dict(step.mcn.scores))

    def close(self, outcome: Outcome) -> None:
        """Times, filter updates and the mean diversity."""
        s = self.summary
        s.filter_updates = self.mcn.slam.n_updates
        s.cpu_s, s.wall_s = outcome.cpu_s, outcome.wall_s
        s.mean_diversity = float(np.mean(self._diversities)) if self._diversities else float("nan")
        s.interrupted = outcome.interrupted
        s.lidar_only = self.mcn.slam.lidar_only


class SlamOutputs:
    """``mcnkit slam``'s output folder, written when the drive ends (see :mod:`mcnkit.app.commands.slam`): the five
    trajectories, the map and ``summary.json`` (``info`` first, then the run's figures)."""

    def __init__(self, out: Path, slam: FastSlam, info: dict[str, Any]) -> None:
        self.out, self.slam, self.info = out, slam, info
        self.cpu0, self.wall0 = time.process_time(), time.perf_counter()
        self.summary: dict[str, Any] | None = None

    def on_step(self, step: DriveStep) -> None:
        """Nothing per step."""

    def close(self, outcome: Outcome) -> None:
        """Writes the results so far (nothing when no scan was read)."""
        from mcnkit.io.mapfiles import write_map_strips
        from mcnkit.metrics import write_tum

        slam = self.slam
        if slam.n_scans == 0:
            return
        with staged_folder(self.out) as tmp:
            # stopped by a signal, the user waits: the refinement (seconds on long logs) is left out
            main_mode = "tracked" if outcome.signalled else "refined"
            main = slam.trajectory(mode=main_mode)
            write_tum(tmp / "trajectory.tum", main)
            for name, mode in [("trajectory_tracked", "tracked"), ("trajectory_online", "online"),
                               ("trajectory_gmapping", "gmapping"), ("trajectory_matched", "matched"),
                               ("trajectory_smoothed", "smoothed")]:
                write_tum(tmp / f"{name}.tum", slam.trajectory(mode=mode))
            # the map is cast from trajectory.tum's poses at the update scans: the map and the trajectory agree
            spec, strips = slam.best_map_strips(poses=main.poses[slam.update_scans()])
            write_map_strips(tmp, spec, strips, slam.config.map.occ_thresh)
            self.summary = {
                **self.info,
                **_stop_fields(outcome),
                "trajectory": main_mode,  # what trajectory.tum holds (see mcnkit.app.commands.slam)
                "loop_closures": slam.loops.stats.accepted,
                "loop_corrections": slam.n_loop_corrections,
                # mcnkit.slam.wholegraph's edges (solved only with the option, for the refined trajectory)
                "whole_graph": asdict(slam.whole_graph_stats) if slam.whole_graph_stats is not None else None,
                "lidar_only": slam.lidar_only,  # no odometry reached the filter (none in the log, or ignored)
                "unknown_motion_scans": slam.n_unknown_motion,  # no odometry for them (Frame.odom_known, or ignored)
                "odometry_rejected_scans": slam.n_odometry_rejected,  # odometry the scans contradicted
                "wide_search_jumps": slam.n_wide_jumps,  # steps the wide search moved far from the prediction
                "self_hit_beams": [int(b) for b in slam.self_hits.beams],  # the robot's own returns (MatchingConfig)
                "self_hit_returns_dropped": slam.self_hits.n_dropped,
                "scans": slam.n_scans,
                "filter_updates": slam.n_updates,
                "resamplings": slam.n_resamples,
                "final_neff": slam.neff,
                "best_particle": slam.best_index,
                "cpu_s": time.process_time() - self.cpu0,
                "wall_s": time.perf_counter() - self.wall0,
                "cpu_s_filter": outcome.cpu_s,
                "wall_s_filter": outcome.wall_s,
                "peak_rss_mb": peak_rss_mb(),
                "particle_maps_mb": slam.maps.nbytes / 1e6,
                "map_cells": [spec.height, spec.width],
            }
            (tmp / "summary.json").write_text(json.dumps(self.summary, indent=2) + "\n")


class McnOutputs:
    """``mcnkit run`` / ``demo``'s output folder, written when the drive ends: ``trajectory.tum``, the best map,
    ``completion.png`` (the last completion as ``draw`` draws it, e.g. :func:`mcnkit.viz.plots.completion_figure`;
    none without ``draw``) and ``summary.json`` (``info``, then the :class:`RunSummary`, which :class:`McnStats`
    fills and must therefore be closed before)."""

    def __init__(self, out: Path, mcn: McnSlam, summary: RunSummary, info: dict[str, Any], *, dpi: int = 110,
                 draw: Callable[[Completion], Figure] | None = None, extra: Callable[[Path], None] | None = None
                 ) -> None:
        self.out, self.mcn, self.summary, self.info, self.dpi = out, mcn, summary, info, dpi
        self.draw, self.extra = draw, extra
        self.written = False

    def on_step(self, step: DriveStep) -> None:
        """Nothing per step."""

    def close(self, outcome: Outcome) -> None:
        """Writes the results so far (nothing when no scan was read); ``extra(folder)`` may add files."""
        from mcnkit.io.mapfiles import write_map
        from mcnkit.metrics import write_tum

        slam = self.mcn.slam
        if slam.n_scans == 0:
            return
        with staged_folder(self.out) as tmp:
            write_tum(tmp / "trajectory.tum", slam.trajectory())
            write_map(slam.best_map(), tmp)
            summary = self.summary
            if summary.last_completion is not None and self.draw is not None:
                self.draw(summary.last_completion).savefig(tmp / "completion.png", dpi=self.dpi)
            payload = {**self.info, **_stop_fields(outcome), "peak_rss_mb": peak_rss_mb(), **summary.as_dict()}
            (tmp / "summary.json").write_text(json.dumps(payload, indent=2) + "\n")
            if self.extra is not None:
                self.extra(tmp)
        self.written = True
