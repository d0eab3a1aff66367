"""A FastSLAM stepper for notebooks — the only module that imports ipywidgets.

``SlamStepper(frames, rrd_path)`` runs :class:`~mcnkit.slam.FastSlam` one scan at a time and records every
step to an ``.rrd`` (and, with ``viewer=True``, to an embedded Rerun viewer).  ``stepper.widget()`` gives
step / run / reset buttons, particle-count and motion-noise controls, and a step slider tied to the viewer's
time cursor; ``stepper.figure()`` is the static fallback when there is no front end.

Example:
    >>> stepper = SlamStepper(frames, "run.rrd", particles=30)   # doctest: +SKIP
    >>> stepper.step(50); stepper.figure()                      # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from itertools import islice
from pathlib import Path
from typing import Any

import ipywidgets as w
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from mcnkit.app.drive import CallbackSink, Outcome, Sink, close_sinks, drive
from mcnkit.slam import FastSlam, SlamConfig, SlamStep
from mcnkit.types import Frame, TernaryMap
from mcnkit.viz import RerunLogger, recording_viewer
from mcnkit.viz.plots import plot_slam_state
from mcnkit.viz.record import RecordingSink

__all__ = ["SlamStepper", "recording_player"]


class SlamStepper:
    """Steps FastSLAM through ``frames`` and records each step."""

    def __init__(
        self, frames: Sequence[Frame], rrd_path: str | Path, *, particles: int = 30, noise_scale: float = 1.0,
        seed: int = 0, viewer: bool = False, ground_truth: TernaryMap | None = None,
    ) -> None:
        self.frames = frames
        self.rrd_path = Path(rrd_path)
        self.particles, self.noise_scale, self.seed = particles, noise_scale, seed
        self.use_viewer = viewer
        self.ground_truth = ground_truth
        self.events: list[str] = []
        self._ui: dict[str, Any] = {}
        self._logger: RerunLogger | None = None
        self._sinks: list[Sink] = []
        self.index = 0
        self._on_change: list[Callable[[], None]] = []
        self.reset()

    @property
    def logger(self) -> RerunLogger:
        """The recording of the current run."""
        assert self._logger is not None
        return self._logger

    # -- the filter ---------------------------------------------------------------------------------------
    def config(self) -> SlamConfig:
        """gmapping's defaults with the chosen particle count and the odometry noise scaled."""
        base = SlamConfig(n_particles=self.particles)
        k = self.noise_scale
        m = base.motion
        return dataclasses.replace(base, motion=dataclasses.replace(m, srr=m.srr * k, srt=m.srt * k, str_=m.str_ * k,
                                                                  stt=m.stt * k))

    def reset(self) -> None:
        """A new filter and a new recording (the old file is replaced)."""
        if self._logger is not None:
            close_sinks(self._sinks, Outcome(self.index, "reset", 0.0, 0.0))
        self.slam = FastSlam(self.config(), np.random.default_rng(self.seed))
        self._logger = RerunLogger(self.rrd_path, recording_id=f"stepper-{self.seed}", notebook_viewer=self.use_viewer,
                                   atomic=False)  # the file grows as the user steps (flushed after each step)
        if self.ground_truth is not None:
            self.logger.log_ground_truth(self.ground_truth)
        # the one driver, run in parts: every filter update's map and the tracked path recorded, events noted
        self._sinks = [RecordingSink(self.logger, self.slam, map_every=1, trajectory="tracked"),
                       CallbackSink(self._note)]
        self.index = 0
        self.last: SlamStep | None = None
        self.events = []

    def _note(self, frame: Frame, st: SlamStep) -> None:
        self.last = st
        if st.updated and st.resampled:
            self.events.append(f"scan {st.index}: resampled (N_eff was {st.neff:.1f} of {self.particles})")

    def step(self, n: int = 1) -> SlamStep | None:
        """Runs ``n`` more scans (fewer at the end of the log); returns the last step."""
        part = drive(islice(self.frames, self.index, self.index + max(0, n)), self.slam, self._sinks, close=False)
        self.index += part.scans
        self.logger.rec.flush()
        for callback in self._on_change:
            callback()
        return self.last

    def run(self) -> SlamStep | None:
        """Runs to the end of the log and finalises the recording."""
        last = self.step(len(self.frames))
        close_sinks(self._sinks, Outcome(self.index, None, 0.0, 0.0))
        return last

    def status(self) -> str:
        """One line: where the filter is."""
        st = self.last
        if st is None:
            return f"0 / {len(self.frames)} scans"
        return (f"{self.index} / {len(self.frames)} scans, {self.slam.n_updates} filter updates, "
                f"{self.slam.n_resamples} resamplings, N_eff {st.neff:.1f} of {self.particles}")

    def figure(self) -> Figure:
        """The current state as a static figure: best map, particles, trajectory, odometry."""
        fig, ax = plt.subplots(figsize=(7, 6))
        st = self.last
        if st is not None:
            odom = np.array([f.odom.as_array()[:2] for f in self.frames[: self.index]])
            ternary = self.slam.best_ternary() if self.slam.n_updates else None
            plot_slam_state(ax, ternary, st.poses, st.weights, self.slam.trajectory().poses[:, :2], odom,
                            title=self.status())
        plt.close(fig)
        return fig

    # -- the widget ---------------------------------------------------------------------------------------
    def widget(self) -> w.VBox:
        """Buttons, controls, the step slider (tied to the viewer's time cursor) and a status line."""
        ui = self._ui
        ui["particles"] = w.IntSlider(value=self.particles, min=1, max=100, description="particles")
        ui["noise"] = w.FloatLogSlider(value=self.noise_scale, base=10, min=-1, max=1, description="odom noise ×")
        ui["n"] = w.BoundedIntText(value=10, min=1, max=10_000, description="scans/step")
        ui["step_btn"] = w.Button(description="step", icon="forward")
        ui["run_btn"] = w.Button(description="run to end", icon="fast-forward")
        ui["reset_btn"] = w.Button(description="reset", icon="refresh")
        ui["cursor"] = w.IntSlider(value=0, min=0, max=max(len(self.frames) - 1, 0), description="view step",
                                   continuous_update=False)
        ui["status"] = w.HTML(self.status())
        ui["events"] = w.Textarea(value="", layout=w.Layout(width="95%", height="80px"), disabled=True)

        def refresh() -> None:
            ui["status"].value = self.status()
            ui["events"].value = "\n".join(self.events[-20:])
            ui["cursor"].value = max(self.index - 1, 0)

        def on_step(_: Any) -> None:
            self.step(int(ui["n"].value))

        def on_run(_: Any) -> None:
            self.step(len(self.frames))

        def on_reset(_: Any) -> None:
            self.particles, self.noise_scale = int(ui["particles"].value), float(ui["noise"].value)
            self.reset()
            refresh()

        self._on_change.append(refresh)
        ui["step_btn"].on_click(on_step)
        ui["run_btn"].on_click(on_run)
        ui["reset_btn"].on_click(on_reset)
        ui["cursor"].observe(lambda ch: self.logger.seek(int(ch["new"])), names="value")
        return w.VBox([
            w.HBox([ui["particles"], ui["noise"], ui["reset_btn"]]),
            w.HBox([ui["n"], ui["step_btn"], ui["run_btn"]]),
            ui["cursor"], ui["status"], ui["events"],
        ])


def recording_player(path: str | Path, n_steps: int) -> w.VBox:
    """A finished recording in the embedded viewer, with a step slider that scrubs its time cursor."""
    viewer = recording_viewer(path)
    slider = w.IntSlider(value=n_steps - 1, min=0, max=max(n_steps - 1, 0), description="step",
                         continuous_update=True, layout=w.Layout(width="95%"))
    slider.observe(lambda ch: viewer.set_time_ctrl(timeline="step", sequence=int(ch["new"]), play=False),
                   names="value")
    viewer.display()
    return w.VBox([slider])
