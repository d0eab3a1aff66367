"""Steppers for notebooks — the only module that imports ipywidgets.

``SlamStepper(frames, rrd_path)`` runs :class:`~mcnkit.slam.FastSlam` one scan at a time and records every
step to an ``.rrd`` (and, with ``viewer=True``, to an embedded Rerun viewer).  ``stepper.widget()`` gives
step / run / reset buttons, particle-count and motion-noise controls, and a step slider tied to the viewer's
time cursor; ``stepper.figure()`` is the static fallback when there is no front end.

``ExploreStepper({"frontier": ex1, "mcn": ex2})`` steps exploration runs side by side (:mod:`mcnkit.explore`) and
shows, after every planning step, each planner's frontiers, scored viewpoints, goal and path, the samples behind the
``mcn`` planner's scores, the coverage curves, and a table of why each goal won.

Example:
    >>> stepper = SlamStepper(frames, "run.rrd", particles=30)   # doctest: +SKIP
    >>> stepper.step(50); stepper.figure()                      # doctest: +SKIP
"""

from __future__ import annotations

import dataclasses
import html
from collections.abc import Callable, Mapping, Sequence
from itertools import islice
from pathlib import Path
from typing import TYPE_CHECKING, Any

import ipywidgets as w
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure

from mcnkit.app.drive import CallbackSink, Outcome, Sink, close_sinks, drive
from mcnkit.slam import FastSlam, SlamConfig, SlamStep
from mcnkit.types import Frame, TernaryMap
from mcnkit.viz import RerunLogger, recording_viewer
from mcnkit.viz.plots import coverage_figure, plot_decision, plot_prediction, plot_slam_state
from mcnkit.viz.record import RecordingSink

if TYPE_CHECKING:
    from mcnkit.explore.loop import Explorer
    from mcnkit.explore.planners import Decision
    from mcnkit.viz.explore import ExploreRecorder

__all__ = ["ExploreStepper", "SlamStepper", "recording_player"]


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


class ExploreStepper:
    """Steps exploration runs side by side (name -> :class:`~mcnkit.explore.loop.Explorer`, e.g. both planners on
    the same house and seed), recording each to ``<rrd_prefix>_<name>.rrd`` when given (the last one also to an
    embedded viewer with ``viewer=True``)."""

    def __init__(self, explorers: Mapping[str, Explorer], rrd_prefix: str | Path | None = None,
                 viewer: bool = False) -> None:
        from mcnkit.viz.explore import ExploreRecorder

        self.explorers = dict(explorers)
        self.decisions: dict[str, Decision | None] = dict.fromkeys(self.explorers)
        self.recorders: dict[str, ExploreRecorder] = {}
        if rrd_prefix is not None:
            names = list(self.explorers)
            for name, ex in self.explorers.items():
                samples = getattr(getattr(ex.planner, "config", None), "samples", 0)
                rec = ExploreRecorder(f"{rrd_prefix}_{name}.rrd", ex, samples=samples,
                                      recording_id=f"explore-{name}", notebook_viewer=viewer and name == names[-1])
                rec.on_frame(ex.records[-1])
                self.recorders[name] = rec
        self._ui: dict[str, Any] = {}

    @property
    def viewer(self) -> Any:
        """The embedded viewer (None without one)."""
        return next((r.viewer for r in self.recorders.values() if r.viewer is not None), None)

    @property
    def done(self) -> bool:
        """True once every run stopped."""
        return all(ex.done for ex in self.explorers.values())

    def _advance(self, name: str, until_plan: bool, frames: int) -> None:
        ex = self.explorers[name]
        for _ in range(frames):
            if ex.done:
                break
            record = ex.step()
            if name in self.recorders:
                self.recorders[name].on_frame(record)
            if record.decision is not None:
                self.decisions[name] = record.decision
                if until_plan:
                    break
        if name in self.recorders:
            self.recorders[name].rec.flush()

    def step(self, frames: int = 1) -> None:
        """Every run ``frames`` frames further (or to its end)."""
        for name in self.explorers:
            self._advance(name, False, frames)

    def next_plan(self, max_frames: int = 10_000) -> None:
        """Every run on to its next planning step."""
        for name in self.explorers:
            self._advance(name, True, max_frames)

    def run(self) -> None:
        """Every run to its end; the recordings finalised."""
        for name in self.explorers:
            self._advance(name, False, 10**9)
            if name in self.recorders:
                self.recorders[name].close()

    def status(self) -> str:
        """One line per run: frames, path, coverage, planning steps, how it stopped."""
        return "<br>".join(
            f"<b>{html.escape(name)}</b>: {ex.n_frames} frames, {ex.path_length_m:.1f} m, coverage {ex.coverage:.3f}, "
            f"{len(ex.plans)} planning steps{'' if ex.stop_reason is None else ' — ' + ex.stop_reason}"
            for name, ex in self.explorers.items())

    def why(self, name: str, top: int = 6) -> str:
        """An HTML table of the last planning step's best viewpoints: gain, path cost, score; the chosen one bold."""
        d = self.decisions[name]
        if d is None or d.choice is None:
            return f"<p>{html.escape(name)}: no planning step yet</p>" if d is None else \
                f"<p>{html.escape(name)}: no reachable frontier left</p>"
        order = np.argsort(-d.score, kind="stable")[:top]
        rows = "".join(
            f"<tr style='font-weight:{'bold' if i == d.choice else 'normal'}'><td>{r + 1}</td>"
            f"<td>({d.points.xy_m[i, 0]:.1f}, {d.points.xy_m[i, 1]:.1f})</td><td>{d.gain[i]:.1f}</td>"
            f"<td>{d.points.cost_m[i]:.1f}</td><td>{d.score[i]:.2f}</td></tr>" for r, i in enumerate(order))
        how = "it keeps the goal it was driving to" if d.kept else "the goal is the best score"
        return (f"<p><b>{html.escape(name)}</b>: {len(d.points)} frontier viewpoints, {how} "
                f"(CPU {1000 * d.cpu_s:.0f} ms)</p><table><tr><th>#</th><th>viewpoint [m]</th><th>gain [m²]</th>"
                f"<th>path cost [m]</th><th>score</th></tr>{rows}</table>")

    def figure(self) -> Figure:
        """Each run's last planning step side by side (with its trajectory), the coverage curves, and the samples
        behind the last prediction."""
        names = list(self.explorers)
        pred_name = next((n for n in names if (d := self.decisions[n]) is not None and d.prediction is not None), None)
        rows = 2 if pred_name is not None else 1
        fig = plt.figure(figsize=(4.2 * (len(names) + 1), 4.0 * rows), layout="constrained")
        grid = fig.add_gridspec(rows, len(names) + 1)
        for k, name in enumerate(names):
            ax = fig.add_subplot(grid[0, k])
            d = self.decisions[name]
            ex = self.explorers[name]
            if d is not None:
                traj = np.array([r.estimate[:2] for r in ex.records])
                plot_decision(ax, d, traj, f"{name}: {ex.path_length_m:.1f} m, coverage {ex.coverage:.2f}")
        curves = {name: (np.array([r.path_length_m for r in ex.records]), np.array([r.coverage for r in ex.records]))
                  for name, ex in self.explorers.items()}
        cov_ax = fig.add_subplot(grid[0, len(names)])
        for name, (path, cov) in curves.items():
            cov_ax.plot(path, cov, label=name)
        cov_ax.axhline(0.9, color="0.6", lw=0.8, ls=":")
        cov_ax.set(xlabel="path [m]", ylabel="coverage", ylim=(0, 1.02), title="coverage")
        cov_ax.legend(loc="lower right")
        if pred_name is not None:
            d = self.decisions[pred_name]
            assert d is not None and d.prediction is not None
            sub = grid[1, :].subgridspec(1, len(names) + 1)
            plot_prediction([fig.add_subplot(sub[0, j]) for j in range(len(names) + 1)], d.prediction, d.goal_xy_m)
        plt.close(fig)
        return fig

    def coverage(self) -> Figure:
        """The coverage curves so far."""
        return coverage_figure({name: (np.array([r.path_length_m for r in ex.records]),
                                       np.array([r.coverage for r in ex.records])) for name, ex in self.explorers.items()})

    def widget(self) -> w.VBox:
        """Buttons (frames / next planning step / run to the end), the figure, the why-tables and a status line."""
        ui = self._ui
        ui["n"] = w.BoundedIntText(value=20, min=1, max=100_000, description="frames")
        ui["step_btn"] = w.Button(description="step", icon="forward")
        ui["plan_btn"] = w.Button(description="next planning step", icon="map-marker")
        ui["run_btn"] = w.Button(description="run to end", icon="fast-forward")
        ui["status"] = w.HTML(self.status())
        ui["why"] = w.HTML("")
        ui["plot"] = w.Output()

        def refresh() -> None:
            ui["status"].value = self.status()
            ui["why"].value = "".join(self.why(name) for name in self.explorers)
            ui["plot"].clear_output(wait=True)
            with ui["plot"]:
                from IPython.display import display

                display(self.figure())

        def act(what: Callable[[], None]) -> Callable[[Any], None]:
            def on_click(_: Any) -> None:
                what()
                refresh()

            return on_click

        ui["step_btn"].on_click(act(lambda: self.step(int(ui["n"].value))))
        ui["plan_btn"].on_click(act(self.next_plan))
        ui["run_btn"].on_click(act(self.run))
        refresh()
        return w.VBox([w.HBox([ui["n"], ui["step_btn"], ui["plan_btn"], ui["run_btn"]]), ui["status"], ui["plot"],
                       ui["why"]])
