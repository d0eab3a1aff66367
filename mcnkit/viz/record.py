"""Recording runs for Rerun: the sink that logs every step of a drive (:class:`RecordingSink`), the sinks of an
MCN-SLAM run with its recording (:func:`mcn_sinks`), and that loop for scripts and notebooks (:func:`run_mcn`:
frames in, a :class:`~mcnkit.app.sinks.RunSummary` out)."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from mcnkit.app.sinks import RunSummary

if TYPE_CHECKING:
    from mcnkit.app.drive import DriveStep, Outcome, Signals, Sink
    from mcnkit.app.recording import LiveViewer
    from mcnkit.mcn import McnSlam, StepResult
    from mcnkit.slam.fastslam import FastSlam
    from mcnkit.types import Frame, TernaryMap
    from mcnkit.viz.logger import RerunLogger

__all__ = ["RecordingSink", "announce_live", "mcn_sinks", "recording_logger", "run_mcn", "serve_on"]


class RecordingSink:
    """Records every step with a :class:`~mcnkit.viz.RerunLogger` and finalises the file when the drive ends.

    Plain FastSLAM steps: particles, pose, scan, paths, and the best map every ``map_every`` filter updates
    (``trajectory="tracked"`` draws the best particle's tracked trajectory, ``"updates"`` its corrected poses at
    the updates).  MCN-SLAM steps: :meth:`~mcnkit.viz.RerunLogger.log_mcn_step`.  With ``optimize`` a finished
    recording is compacted with ``rerun rrd optimize`` (an interrupted one is left as written).  ``summary``, when
    given, gets the recording's CPU time and sizes.
    """

    def __init__(self, logger: RerunLogger, slam: FastSlam, *, map_every: int = 10, trajectory: str = "updates",
                 optimize: bool = False, summary: RunSummary | None = None, keep_serving: bool = False) -> None:
        self.logger, self.slam = logger, slam
        self.map_every, self.trajectory, self.optimize = map_every, trajectory, optimize
        self.summary = summary
        self.keep_serving = keep_serving
        self.cpu_s = 0.0
        self.bytes_written = self.bytes = 0

    def _trajectory_xy(self) -> Any:
        if self.trajectory == "tracked":
            return self.slam.trajectory().poses[:, :2]
        return self.slam.update_poses()[:, :2]

    def on_step(self, step: DriveStep) -> None:
        """Logs the step."""
        t0 = time.process_time()
        traj = self._trajectory_xy() if step.slam.updated else None
        if step.mcn is not None:
            self.logger.log_mcn_step(step.frame, step.mcn, traj)
        else:
            self.logger.log_slam_step(step.frame, step.slam, traj)
            if step.slam.updated and self.map_every > 0 and (self.slam.n_updates - 1) % self.map_every == 0:
                self.logger.log_map("/world/map/estimate", self.slam.best_ternary(), mask=True)
        self.cpu_s += time.process_time() - t0

    def close(self, outcome: Outcome) -> None:
        """Finalises the file (footer written, renamed into place) and compacts a finished one; ends the live
        streams, except a served one after a finished run with ``keep_serving`` (see :func:`serve_on`)."""
        self.logger.close(keep_serving=self.keep_serving and not outcome.interrupted)
        path = self.logger.path
        self.bytes_written = self.bytes = path.stat().st_size if path is not None and path.is_file() else 0
        if self.optimize and not outcome.interrupted and path is not None and path.is_file():
            from mcnkit.viz.files import optimize_recording

            self.bytes_written, self.bytes = optimize_recording(path)
        if self.summary is not None:
            self.summary.cpu_s_recording = self.cpu_s
            self.summary.rrd_bytes_written, self.summary.rrd_bytes = self.bytes_written, self.bytes


def announce_live(logger: RerunLogger) -> None:
    """Prints where the run streams live (the addresses to open), when it does."""
    live = logger.live
    if live is None:
        return
    if live.connect is not None:
        print(f"streaming live to the viewer at {live.connect}", flush=True)
    if live.serve_url is not None:
        print(f"serving live at {live.serve_url}    watch it: rerun --connect {live.serve_url}", flush=True)
    if live.web_url is not None:
        print(f"web viewer: {live.web_url}", flush=True)


def serve_on(logger: RerunLogger, linger_s: float, signals: Signals | None) -> None:
    """After a run: keeps the run's own server (``--serve``) up for ``linger_s`` seconds (< 0: until SIGINT or
    SIGTERM, which then end only the serving), then shuts it down.  Nothing to do when it is not serving."""
    if not logger.serving:
        return
    try:
        if linger_s != 0 and signals is not None:
            until = "Ctrl-C" if linger_s < 0 else f"{linger_s:g} s or Ctrl-C"
            print(f"the run is over; still serving {logger.live.serve_url if logger.live else ''} until {until}",
                  flush=True)
            signals.wait(linger_s)
    finally:
        logger.stop_serving()


def mcn_sinks(mcn: McnSlam, *, rrd: Path | None = None, recording_id: str | None = None,
              ground_truth: TernaryMap | None = None, progress: bool = True, total: int | None = None,
              on_step: Callable[[Frame, StepResult], None] | None = None, notebook_viewer: bool = False,
              optimize: bool = True, live: LiveViewer | None = None, config: dict[str, Any] | None = None,
              flush_updates: int = 50, keep_serving: bool = False) -> tuple[RunSummary, list[Sink]]:
    """The sinks of an MCN-SLAM run (statistics, recording, progress bar, callback) and the summary they fill.

    The recording goes to ``rrd`` and/or ``live`` (a running viewer, a server of its own: see
    :mod:`mcnkit.app.recording`); ``config`` (the run's whole configuration) is written into it.  With
    ``keep_serving`` a served recording stays up after a finished run (see :func:`serve_on`).
    """
    from mcnkit.app.drive import CallbackSink, ProgressSink
    from mcnkit.app.sinks import McnStats

    stats = McnStats(mcn)
    sinks: list[Sink] = [stats]
    if rrd is not None or live is not None:
        from mcnkit.viz.blueprints import mcn_blueprint
        from mcnkit.viz.logger import RerunLogger

        cfg = mcn.config
        logger = RerunLogger(rrd, recording_id, mcn_blueprint(cfg.ranks, cfg.samples), notebook_viewer=notebook_viewer,
                             live=live, config=config, flush_updates=flush_updates)
        if ground_truth is not None:
            logger.log_ground_truth(ground_truth)
        sinks.append(RecordingSink(logger, mcn.slam, optimize=optimize, summary=stats.summary,
                                   keep_serving=keep_serving))
    sinks.append(ProgressSink(total, enabled=progress))
    if on_step is not None:
        sinks.append(CallbackSink(on_step))
    return stats.summary, sinks


def recording_logger(sinks: list[Sink]) -> RerunLogger | None:
    """The Rerun logger among ``sinks`` (None without a recording)."""
    return next((s.logger for s in sinks if isinstance(s, RecordingSink)), None)


def run_mcn(frames: Iterable[Frame], mcn: McnSlam, *, rrd: Path | None = None, recording_id: str | None = None,
            ground_truth: TernaryMap | None = None, progress: bool = True, total: int | None = None,
            on_step: Callable[[Frame, StepResult], None] | None = None, notebook_viewer: bool = False,
            optimize: bool = True, live: LiveViewer | None = None,
            config: dict[str, Any] | None = None) -> RunSummary:
    """Feeds ``frames`` to ``mcn`` and records each step to ``rrd`` and/or ``live`` (when given); returns the
    summary.

    ``on_step(frame, result)`` is called after every step (a notebook can draw from it).  A finished recording is
    compacted with ``rerun rrd optimize`` unless ``optimize=False`` (an interrupted one is left as written).  An
    exception (Ctrl-C included) still closes the recording, then propagates.  This is :func:`mcnkit.app.drive.drive`
    with the sinks of :func:`mcn_sinks`.
    """
    from mcnkit.app.drive import drive

    summary, sinks = mcn_sinks(mcn, rrd=rrd, recording_id=recording_id, ground_truth=ground_truth,
                               progress=progress, total=total, on_step=on_step, notebook_viewer=notebook_viewer,
                               optimize=optimize, live=live, config=config)
    drive(frames, mcn, sinks)
    return summary
