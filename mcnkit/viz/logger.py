"""Rerun recordings of SLAM runs — the only module that imports rerun.

One recording per run, saved as an ``.rrd`` file with its blueprint inside.  Timelines: ``step`` (scan
number) and ``stamp`` (the scan's ROS time, datetime64[ns]).  Everything is logged in metres in the map frame;
``/world`` flips y so +y points up, as in RViz.

Entities:

| path | what |
|---|---|
| ``/`` | AnnotationContext: 0 free, 1 unknown, 2 occupied (static) |
| ``/world/map/estimate`` | best particle's ternary map (SegmentationImage, placed in metres by a Transform3D) |
| ``/world/map/unknown_mask`` | its unknown cells (own AnnotationContext: 1 = magenta, 0 transparent) |
| ``/world/map/gt`` | ground-truth map when known (static) |
| ``/world/particles`` | particle positions, radius and colour by weight, with ``weight`` and ``particle_id`` attached |
| ``/world/robot/pose`` | best particle's pose (arrow) |
| ``/world/robot/trajectory``, ``/world/robot/odom_path`` | best trajectory so far, raw odometry path |
| ``/world/scan/hits`` | scan end points seen from the best pose |
| ``/metrics/n_eff`` | effective sample size (scalar) |
| ``/world/mcn/rank{r}/window`` | MCN-SLAM: the network's window of the r-th best particle (Transform3D, metres) |
| ``/world/mcn/rank{r}/window/partial`` | that particle's m_t on the window (64 × 64) |
| ``/world/mcn/rank{r}/window/sample{k}`` | its k-th sampled completion |
| ``…/window/mean``, ``…/window/uncertainty`` | the mean completion; entropy of the samples per cell (0–255, magma) |
| ``/world/mcn/rank{r}/particle`` | that particle's pose |
| ``/metrics/f_slam``, ``/metrics/f_completed``, ``/metrics/miou_unknown``, ``/metrics/sample_diversity`` | scalars |
| ``/log`` | filter updates and resampling events (TextLog) |
| ``/config`` | the run's whole configuration, JSON (TextDocument, static) |

Besides the file, a run can stream live to a running viewer or to a gRPC server of its own on 127.0.0.1 (see
:mod:`mcnkit.app.recording`).  The logger is a context manager: leaving it, normally or by an exception (Ctrl-C included), flushes and
finalises the file, so an interrupted run still leaves a readable recording.
"""

from __future__ import annotations

import json
import os
import subprocess
import uuid
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray

from mcnkit.app.outputs import partial_path
from mcnkit.geometry import transform_points
from mcnkit.slam.fastslam import SlamStep
from mcnkit.types import Frame, TernaryMap
from mcnkit.viz.blueprints import APPLICATION_ID, CLASSES, METRICS, SERIES, slam_blueprint
from mcnkit.viz.columns import entity_columns, ternary_classes
from mcnkit.viz.streams import Tee
from mcnkit.viz.webviewer import serve_web_viewer

if TYPE_CHECKING:
    from mcnkit.app.recording import LiveViewer
    from mcnkit.mcn import StepResult

__all__ = ["RerunLogger"]


class RerunLogger:
    """Writes one run to ``path`` (``.rrd``: written as ``path.partial`` and renamed when closed, unless
    ``atomic=False``; None: no file), streams it live to ``live`` (a running viewer and/or a gRPC server hosted on
    127.0.0.1, see :mod:`mcnkit.app.recording`) and, with ``notebook_viewer=True``, to ``.viewer`` (a
    ``rerun.notebook.Viewer``: show it with ``logger.viewer.display()``).

    ``config``, when given, is the run's whole configuration: logged as a JSON text document at ``/config``
    (static), so that the recording says how it was made."""

    def __init__(self, path: str | Path | None, recording_id: str | None = None,
                 blueprint: rrb.Blueprint | None = None, *, notebook_viewer: bool = False,
                 viewer_size: tuple[int, int] = (1000, 520), flush_updates: int = 50, atomic: bool = True,
                 live: LiveViewer | None = None, config: dict[str, Any] | None = None) -> None:
        self.path = Path(path) if path is not None else None
        recording_id = recording_id or str(uuid.uuid4())
        blueprint = blueprint or slam_blueprint()
        self.rec = Tee(APPLICATION_ID, recording_id)
        self.live = live
        self._web: subprocess.Popen[bytes] | None = None
        self._partial: Path | None = None
        if self.path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            # renamed to ``path`` once finalised (see close); atomic=False writes ``path`` itself as it grows
            self._partial = partial_path(self.path) if atomic else self.path
            self.rec.attach_file(self._partial, blueprint)
        if live is not None:
            self.rec.attach_grpc(live, blueprint)
            if live.web_port is not None and live.serve_url is not None:
                self._web = serve_web_viewer(live.web_port, live.serve_url)
        self.viewer = self.rec.attach_notebook_viewer(blueprint, viewer_size) if notebook_viewer else None
        self.rec.log("/", rr.AnnotationContext([rr.AnnotationInfo(id=i, label=n, color=c) for i, n, c in CLASSES]),
                     static=True)
        self.rec.log("/world", rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True)
        self.rec.log("/world/map/unknown_mask", rr.AnnotationContext([
            rr.AnnotationInfo(id=0, label="known", color=(0, 0, 0, 0)),
            rr.AnnotationInfo(id=1, label="unknown", color=(255, 0, 255, 90))]), static=True)
        if config is not None:
            self.log_config(config)
        self._odom_path: list[NDArray[np.float64]] = []
        self._updates = 0
        self._paths_logged_at = 0
        self.flush_updates = flush_updates
        self._queued: dict[str, tuple[str, list[int], list[int], list[Any]]] = {}  # entity -> kind, rows
        self._live_sent: dict[str, int] = {}  # entity -> its queued rows already sent to the live streams
        self._closed = False

    @property
    def serving(self) -> bool:
        """True while the run's own gRPC server (``live.serve_port``) is up, also after :meth:`close`."""
        return self.rec.served is not None

    def log_config(self, config: dict[str, Any]) -> None:
        """The run's configuration as a JSON document at ``/config`` (static), shown in the blueprints' config
        tab."""
        text = json.dumps(config, indent=2, default=str)
        self.rec.log("/config", rr.TextDocument(text, media_type=rr.MediaType.TEXT), static=True)

    def seek(self, step: int) -> None:
        """Moves the embedded viewer's time cursor to ``step`` (no-op without a viewer)."""
        if self.viewer is not None:
            self.viewer.set_time_ctrl(timeline="step", sequence=int(step), play=False)

    def set_time(self, step: int, stamp_ns: int) -> None:
        """Moves both timelines to this scan."""
        self.rec.set_time("step", sequence=step)
        self.rec.set_time("stamp", timestamp=np.datetime64(int(stamp_ns), "ns"))

    def log_map(self, entity: str, ternary: TernaryMap, *, static: bool = False, mask: bool = False) -> None:
        """A ternary map as a SegmentationImage placed in metres (its GridSpec gives origin and cell size)."""
        spec = ternary.spec
        if spec is not None:
            self.rec.log(entity, rr.Transform3D(translation=[spec.origin_x_m, spec.origin_y_m, 0.0],
                                                scale=[spec.resolution_m, spec.resolution_m, 1.0]), static=static)
        self.rec.log(entity, rr.SegmentationImage(ternary_classes(ternary.image), draw_order=-10.0), static=static)
        if mask and spec is not None:
            m = "/world/map/unknown_mask"
            self.rec.log(m, rr.Transform3D(translation=[spec.origin_x_m, spec.origin_y_m, 0.0],
                                           scale=[spec.resolution_m, spec.resolution_m, 1.0]), static=static)
            self.rec.log(m, rr.SegmentationImage(ternary.unknown_mask.astype(np.uint8), draw_order=-5.0,
                                                 opacity=0.35), static=static)

    def log_mcn_step(self, frame: Frame, result: StepResult, trajectory_xy: NDArray[np.float64] | None = None) -> None:
        """One MCN-SLAM step: the SLAM part (:meth:`log_slam_step`), the best map when the step carries it, and
        at completion steps every rank's m_t, samples, uncertainty and the scores.

        The completion entities are queued like the per-scan ones (see :meth:`log_slam_step`).
        """
        self.log_slam_step(frame, result.slam, trajectory_xy)
        if result.best_map is not None:
            self.log_map("/world/map/estimate", result.best_map, mask=True)
        c = result.completion
        if c is None:
            return
        step, stamp = result.slam.index, result.slam.stamp_ns
        for r, window in enumerate(c.windows):
            base = f"/world/mcn/rank{r}"
            # one transform for every image of the rank: the window's corner and cell size, in metres
            self._queue(f"{base}/window", "place", step, stamp,
                        np.array([window.origin_x_m, window.origin_y_m, window.resolution_m]))
            for name, image in [("partial", c.partial[r]), ("mean", c.mean[r]),
                                *((f"sample{k}", c.samples[r, k]) for k in range(c.samples.shape[1]))]:
                self._queue(f"{base}/window/{name}", "segmentation", step, stamp, ternary_classes(image))
            # one byte per cell, drawn with a colour map (a third of an RGB image in the file)
            u8 = np.rint(np.clip(c.uncertainty[r], 0.0, 1.0) * 255).astype(np.uint8)
            self._queue(f"{base}/window/uncertainty", "depth", step, stamp, u8)
            self._queue(f"{base}/particle", "point", step, stamp, result.slam.poses[int(c.particles[r]), :2].copy())
        scores = dict(result.scores)
        scores["sample_diversity"] = float(c.diversity[0])
        for key, value in scores.items():
            if key in METRICS and np.isfinite(value):
                self._queue(f"/metrics/{key}", "scalar", step, stamp, float(value))

    def _queue(self, entity: str, kind: str, step: int, stamp_ns: int, value: Any) -> None:
        if entity not in self._queued:
            self._queued[entity] = (kind, [], [], [])
            if kind in ("segmentation", "depth"):  # static image format and style, once per entity
                h, w = value.shape
                fmt = rr.components.ImageFormat(width=w, height=h, color_model="L", channel_datatype="U8")
                if kind == "segmentation":
                    self.rec.log(entity, rr.SegmentationImage.from_fields(format=fmt, draw_order=-10.0), static=True)
                else:
                    self.rec.log(entity, rr.DepthImage.from_fields(format=fmt, meter=255.0, colormap="magma",
                                                                   depth_range=[0.0, 255.0]), static=True)
            elif kind == "point":
                self.rec.log(entity, rr.Points2D.from_fields(radii=[0.15], colors=[[230, 40, 40]]), static=True)
            elif kind == "hits":
                self.rec.log(entity, rr.Points2D.from_fields(radii=[0.03], colors=[[255, 160, 0]]), static=True)
            elif kind == "arrow":
                self.rec.log(entity, rr.Arrows2D.from_fields(colors=[[230, 40, 40]]), static=True)
            elif kind == "scalar":  # the series' name and colour
                color, label = SERIES[entity.rsplit("/", 1)[-1]]
                self.rec.log(entity, rr.SeriesLines(names=label, colors=[color], widths=2), static=True)
        queue = self._queued[entity]
        queue[1].append(step)
        queue[2].append(stamp_ns)
        queue[3].append(value)

    def _flush(self, *, live_only: bool = False) -> None:
        """Sends every queued entity as one column chunk (``send_columns``): the rows not sent yet to the live
        streams, and, unless ``live_only``, all of them to the file (which keeps its own, larger batches)."""
        for entity, (kind, steps, stamps, values) in self._queued.items():
            sent = self._live_sent.get(entity, 0)
            if len(steps) > sent and len(self.rec.streams) > (self.rec.file is not None):
                self.rec.send_columns(entity, self._index(steps[sent:], stamps[sent:]), entity_columns(kind, values[sent:]),
                                      live=True)
                self._live_sent[entity] = len(steps)
            if steps and not live_only:
                if self.rec.file is not None:
                    self.rec.send_columns(entity, self._index(steps, stamps), entity_columns(kind, values), live=False)
                steps.clear()
                stamps.clear()
                values.clear()
                self._live_sent[entity] = 0

    @staticmethod
    def _index(steps: list[int], stamps: list[int]) -> list[Any]:
        return [rr.TimeColumn("step", sequence=np.asarray(steps, np.int64)),
                rr.TimeColumn("stamp", timestamp=np.asarray(stamps, np.int64).astype("datetime64[ns]"))]

    def log_ground_truth(self, ternary: TernaryMap) -> None:
        """The ground-truth map (static: the same at every step)."""
        self.log_map("/world/map/gt", ternary, static=True)

    def log_slam_step(self, frame: Frame, step: SlamStep, trajectory_xy: NDArray[np.float64] | None = None) -> None:
        """Particles, best pose, scan hits, odometry path and N_eff of one filter step.

        Per-scan and per-completion entities are queued and sent as columns (``send_columns``) every
        ``flush_updates`` filter updates and on :meth:`close`, which costs a fraction of one ``log`` call per row;
        with a live notebook viewer every step is sent at once, with a gRPC viewer (``live``) every filter update.
        """
        w = np.asarray(step.weights, dtype=np.float64)
        pose = np.asarray(step.best_pose, dtype=np.float64)
        scan = frame.scan
        valid = scan.valid
        angles = scan.spec.angles_rad[valid]
        r = scan.ranges_m[valid].astype(np.float64)
        laser = transform_points(pose, np.array([[scan.spec.base_to_laser.x_m, scan.spec.base_to_laser.y_m]]))[0]
        yaw = pose[2] + scan.spec.base_to_laser.yaw_rad
        hits = np.stack([laser[0] + r * np.cos(yaw + angles), laser[1] + r * np.sin(yaw + angles)], axis=1)
        self._queue("/world/particles", "particles", step.index, step.stamp_ns, (step.poses[:, :2].copy(), w))
        self._queue("/world/robot/pose", "arrow", step.index, step.stamp_ns, pose)
        self._queue("/world/scan/hits", "hits", step.index, step.stamp_ns, hits)
        self._odom_path.append(frame.odom.as_array()[:2])
        if step.updated:  # row-by-row logs below (and log_mcn_step's) happen at filter updates only
            self._updates += 1
        # a notebook viewer gets every scan at once (and so does the file then, which the notebook's player reads
        # as it grows), a gRPC viewer every filter update, the file otherwise every flush_updates updates
        if self.viewer is not None or (step.updated and self._updates % self.flush_updates == 0):
            self._flush()
        elif step.updated and self.live is not None:
            self._flush(live_only=True)
        if step.updated:
            self.set_time(step.index, step.stamp_ns)
            # whole paths, re-sent every max(1, updates/50) updates: a growing path without quadratic file size
            if self._updates - self._paths_logged_at >= max(1, self._updates // 50):
                self._paths_logged_at = self._updates
                self.rec.log("/world/robot/odom_path",
                             rr.LineStrips2D([np.asarray(self._odom_path)], radii=0.02, colors=[[150, 150, 150]]))
                if trajectory_xy is not None:
                    self.rec.log("/world/robot/trajectory",
                                 rr.LineStrips2D([trajectory_xy], radii=0.03, colors=[[0, 180, 0]]))
            self._queue("/metrics/n_eff", "scalar", step.index, step.stamp_ns, float(step.neff))
            what = "filter update, particles resampled" if step.resampled else "filter update"
            self._queue("/log", "text", step.index, step.stamp_ns, f"scan {step.index}: {what} (N_eff {step.neff:.1f})")

    def close(self, *, keep_serving: bool = False) -> None:
        """Sends what is buffered, flushes and finalises the file, ends the connection to a running viewer and,
        unless ``keep_serving``, the run's own server (idempotent; see :meth:`stop_serving`)."""
        if not self._closed:
            self._closed = True
            self._flush()
            self.rec.close(keep_serving)
            if self._partial is not None and self._partial != self.path and self._partial.is_file():
                os.replace(self._partial, self.path)  # type: ignore[arg-type]
        if not keep_serving:
            self.stop_serving()

    def stop_serving(self) -> None:
        """Shuts down the run's gRPC server and web viewer, if any (idempotent)."""
        served = self.rec.served
        if served is not None:
            self.rec.served = None
            self.rec.streams = [s for s in self.rec.streams if s is not served]
            served.disconnect()
        if self._web is not None:
            self._web.terminate()
            try:
                self._web.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._web.kill()
            self._web = None

    def __enter__(self) -> RerunLogger:
        return self

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
