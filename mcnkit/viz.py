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
:mod:`mcnkit.recording`).  The logger is a context manager: leaving it, normally or by an exception (Ctrl-C included), flushes and
finalises the file, so an interrupted run still leaves a readable recording.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import uuid
import warnings
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray

from mcnkit.geometry import transform_points
from mcnkit.outputs import partial_path
from mcnkit.slam.fastslam import SlamStep
from mcnkit.types import Frame, TernaryMap

if TYPE_CHECKING:
    from mcnkit.mcn import StepResult
    from mcnkit.recording import LiveViewer

__all__ = ["APPLICATION_ID", "RerunLogger", "mcn_blueprint", "optimize_recording", "recording_blueprint", "recording_viewer",
           "slam_blueprint"]

APPLICATION_ID = "mcnkit"
_CLASSES = [(0, "free", (235, 235, 235)), (1, "unknown", (128, 128, 128)), (2, "occupied", (20, 20, 20))]


def slam_blueprint() -> rrb.Blueprint:
    """Map with particles, robot and scan on the left; metrics and the event log on the right."""
    return rrb.Blueprint(
        rrb.Horizontal(
            # origin "/": a view ignores its origin's own transform, and /world's flips y up (map frame as in RViz)
            rrb.Spatial2DView(name="SLAM", origin="/", contents=["+ /world/**", "- /world/map/gt/**"]),
            rrb.Vertical(
                rrb.TimeSeriesView(name="metrics", origin="/metrics"),
                rrb.Tabs(rrb.Spatial2DView(name="ground truth", origin="/", contents=["+ /world/map/gt/**"]),
                         rrb.TextLogView(name="events", origin="/log"),
                         rrb.TextDocumentView(name="config", origin="/config")),
                row_shares=[1, 2],
            ),
            column_shares=[3, 2],
        ),
        rrb.TimePanel(timeline="step", expanded=True),
        collapse_panels=False,
    )


_METRICS = {"f_slam": ((120, 120, 120), "F, SLAM map"), "f_completed": ((220, 60, 30), "F, completed"),
            "miou_unknown": ((30, 150, 60), "mIoU unknown cells"), "sample_diversity": ((150, 60, 200), "diversity")}
"""MCN scores recorded under ``/metrics/<key>``: colour and name of each series."""
_SERIES = {**_METRICS, "n_eff": ((30, 120, 220), "N_eff")}
"""Every ``/metrics`` series (the scores and N_eff): colour and name."""


def _map_view(name: str, entity: str, *extra: str) -> rrb.Spatial2DView:
    return rrb.Spatial2DView(name=name, origin="/", contents=[f"+ {entity}/**", *(f"+ {e}" for e in extra)])


def mcn_blueprint(ranks: int, samples: int) -> rrb.Blueprint:
    """MCN-SLAM layout from (R, K): the SLAM view and metrics on the left; on the right one row per particle
    rank ``#r`` with its m_t, its K sampled completions ``s0…`` and their uncertainty; ground truth and events
    in tabs.  The blueprint and selection panels start collapsed (room for the views)."""
    rows = []
    for r in range(ranks):
        base = f"/world/mcn/rank{r}"
        robot = f"{base}/particle"
        views = [_map_view(f"#{r} m_t", f"{base}/window/partial", robot)]
        views += [_map_view(f"#{r} s{k}", f"{base}/window/sample{k}", robot) for k in range(samples)]
        views.append(_map_view(f"#{r} unc.", f"{base}/window/uncertainty", robot))
        rows.append(rrb.Horizontal(*views))
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(
                rrb.Spatial2DView(name="SLAM", origin="/",
                                  contents=["+ /world/**", "- /world/map/gt/**", "- /world/mcn/**"]),
                rrb.Horizontal(
                    rrb.TimeSeriesView(name="scores", origin="/metrics", contents=["+ /metrics/**", "- /metrics/n_eff"]),
                    rrb.TimeSeriesView(name="N_eff", origin="/metrics/n_eff"),
                ),
                row_shares=[3, 1],
            ),
            rrb.Vertical(
                *rows,
                rrb.Tabs(rrb.Spatial2DView(name="ground truth", origin="/", contents=["+ /world/map/gt/**"]),
                         rrb.TextLogView(name="events", origin="/log"),
                         rrb.TextDocumentView(name="config", origin="/config")),
            ),
            column_shares=[2, 3],
        ),
        rrb.TimePanel(timeline="step", expanded=True),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
    )


def recording_blueprint(entity_paths: set[str]) -> rrb.Blueprint:
    """The layout for a recording with these entities: :func:`mcn_blueprint` with its (R, K) when it holds MCN
    completions, else :func:`slam_blueprint`."""
    found = [re.fullmatch(r"/world/mcn/rank(\d+)/window/sample(\d+)", e) for e in entity_paths]
    pairs = [(int(m.group(1)), int(m.group(2))) for m in found if m]
    if not pairs:
        return slam_blueprint()
    return mcn_blueprint(max(r for r, _ in pairs) + 1, max(k for _, k in pairs) + 1)


def recording_viewer(path: str | Path, size: tuple[int, int] = (1000, 560)) -> Any:
    """An embedded notebook viewer showing a finished ``.rrd`` (its chunks are sent from the kernel, offline),
    laid out by :func:`recording_blueprint`.

    Returns the ``rerun.notebook.Viewer``; call ``.display()`` on it, and ``.set_time_ctrl(timeline="step",
    sequence=i, play=False)`` to move its time cursor.
    """
    import os

    from rerun.chunk import RrdReader

    os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")
    import rerun.notebook

    reader = RrdReader(str(path))
    rec_id = reader.recordings()[0].recording_id if reader.recordings() else str(uuid.uuid4())
    store = reader.store()
    blueprint = recording_blueprint({chunk.entity_path for chunk in reader.stream().collect().stream()})
    stream = rr.RecordingStream(APPLICATION_ID, recording_id=rec_id)
    viewer = rerun.notebook.Viewer(recording=stream, width=size[0], height=size[1], blueprint=blueprint)
    viewer.update_panels(blueprint="hidden", selection="hidden")
    stream.send_chunks(store)
    return viewer


def optimize_recording(path: str | Path) -> tuple[int, int]:
    """Compacts a finished ``.rrd`` in place with ``rerun rrd optimize`` (many small chunks merged: about a third
    of the size, the blueprint kept); returns the sizes before and after.  On failure the file is left as it was.
    """
    import subprocess
    import sys

    path = Path(path)
    before = path.stat().st_size
    tmp = path.with_name(path.name + ".optimized.partial")
    done = subprocess.run([sys.executable, "-m", "rerun", "rrd", "optimize", str(path), "-o", str(tmp)],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0 or not tmp.is_file() or tmp.stat().st_size == 0:
        tmp.unlink(missing_ok=True)
        return before, before
    tmp.replace(path)
    return before, path.stat().st_size


def _ternary_classes(image: NDArray[np.float32]) -> NDArray[np.uint8]:
    return np.rint(np.asarray(image) * 2.0).astype(np.uint8)  # 0 / 0.5 / 1 -> 0 / 1 / 2


def _weight_colors(w: NDArray[np.float64]) -> NDArray[np.uint8]:
    u = w / max(float(w.max()), 1e-12)
    return np.stack([40 + 215 * u, 90 + 60 * (1 - u), 255 * (1 - u)], axis=1).astype(np.uint8)


class _Tee:
    """One recording, sent to the ``.rrd`` file and, optionally, to live viewers (gRPC, a notebook).

    Every destination has its own stream with the same application and recording ids, and every call is made on
    each: a notebook viewer takes over the sinks of its stream, the file is finalised when the run ends while a
    served stream may go on serving, and a viewer that goes away cannot hold up the file.
    """

    def __init__(self, application_id: str, recording_id: str) -> None:
        self.streams: list[rr.RecordingStream] = []
        self.file: rr.RecordingStream | None = None
        self.served: rr.RecordingStream | None = None
        self._ids = (application_id, recording_id)

    def _stream(self) -> rr.RecordingStream:
        stream = rr.RecordingStream(self._ids[0], recording_id=self._ids[1])
        stream.set_log_time_enabled(False)  # deterministic files: no wall-clock timeline
        self.streams.append(stream)
        return stream

    def attach_file(self, path: Path, blueprint: rrb.Blueprint) -> None:
        self.file = self._stream()
        self.file.save(str(path), default_blueprint=blueprint)

    def attach_grpc(self, live: LiveViewer, blueprint: rrb.Blueprint) -> None:
        """A stream to a running viewer (``live.connect``) and one to a server hosted on 127.0.0.1."""
        if live.connect is not None:
            self._stream().set_sinks(rr.GrpcSink(live.connect), default_blueprint=blueprint)
        if live.serve_port is not None:
            self.served = self._stream()
            server = rr.GrpcServerSink(bind_ip="127.0.0.1", port=live.serve_port,
                                       server_memory_limit=live.server_memory_limit)
            self.served.set_sinks(server, default_blueprint=blueprint)

    def attach_notebook_viewer(self, blueprint: rrb.Blueprint, size: tuple[int, int]) -> Any:
        import os

        os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")  # offline: the kernel serves the viewer
        import rerun.notebook

        live = self._stream()
        viewer = rerun.notebook.Viewer(recording=live, width=size[0], height=size[1], blueprint=blueprint)
        viewer.update_panels(blueprint="hidden", selection="hidden")  # room for the views; the time panel stays
        return viewer

    def log(self, *args: Any, **kwargs: Any) -> None:
        for s in self.streams:
            s.log(*args, **kwargs)

    def set_time(self, *args: Any, **kwargs: Any) -> None:
        for s in self.streams:
            s.set_time(*args, **kwargs)

    def send_columns(self, *args: Any, live: bool | None = None, **kwargs: Any) -> None:
        """To every stream (``live=None``), the live ones only (True) or the file only (False)."""
        for s in self.streams:
            if live is None or live == (s is not self.file):
                s.send_columns(*args, **kwargs)

    def flush(self) -> None:
        for s in self.streams:
            s.flush()

    def close(self, keep_serving: bool) -> None:
        """Flushes and disconnects every stream (the file last but one: finalised with its footer) except, with
        ``keep_serving``, the served one.  The file goes first; a live viewer that went away is reported, not
        raised."""
        for s in sorted(self.streams, key=lambda s: s is not self.file):  # the file first: it never waits on a viewer
            if s is self.served and keep_serving:
                continue
            if s is not self.file:
                try:
                    s.flush(timeout_sec=2.0)
                except RuntimeError as err:  # gRPC could not deliver: the viewer is gone
                    warnings.warn(f"live viewer: {str(err).splitlines()[0]}", stacklevel=2)
            s.disconnect()
        self.streams = [self.served] if keep_serving and self.served is not None else []


def _columns(kind: str, values: list[Any]) -> Any:
    """The ``send_columns`` columns of one queued entity: ``values`` holds one row per step."""
    n = len(values)
    if kind == "particles":  # (positions (N, 2), weights (N,)) per row; weights attached to every particle
        counts = [len(xy) for xy, _ in values]
        w_all = np.concatenate([w for _, w in values])
        w_rel = np.concatenate([w / max(float(w.max()), 1e-12) for _, w in values])
        return [*rr.Points2D.columns(positions=np.concatenate([xy for xy, _ in values]), radii=0.02 + 0.08 * w_rel,
                                     colors=_weight_colors(w_rel)).partition(counts),
                *rr.AnyValues.columns(weight=w_all,
                                      particle_id=np.concatenate([np.arange(k) for k in counts])).partition(counts)]
    if kind == "arrow":  # a pose (3,) per row
        p = np.asarray(values)
        heading = 0.4 * np.stack([np.cos(p[:, 2]), np.sin(p[:, 2])], axis=1)
        return rr.Arrows2D.columns(origins=p[:, :2], vectors=heading).partition(np.ones(n, int))
    if kind == "hits":  # (M, 2) points per row
        return rr.Points2D.columns(positions=np.concatenate(values)).partition([len(h) for h in values])
    if kind == "point":  # one (2,) point per row
        return rr.Points2D.columns(positions=np.asarray(values))
    if kind == "segmentation":
        return rr.SegmentationImage.columns(buffer=np.stack(values).reshape(n, -1))
    if kind == "depth":
        return rr.DepthImage.columns(buffer=np.stack(values).reshape(n, -1))
    if kind == "place":  # window (origin x, origin y, cell size) per row
        v = np.asarray(values)
        return rr.Transform3D.columns(translation=np.c_[v[:, 0], v[:, 1], np.zeros(n)],
                                      scale=np.c_[v[:, 2], v[:, 2], np.ones(n)])
    if kind == "text":  # one filter-update message per row
        return rr.TextLog.columns(text=values, level=["INFO"] * n)
    return rr.Scalars.columns(scalars=np.asarray(values, np.float64))


def _serve_web_viewer(port: int, grpc_url: str) -> subprocess.Popen[bytes]:
    """Rerun's web viewer on 127.0.0.1:``port``, connecting to ``grpc_url`` (the rerun binary itself, not the
    Python shim, so that ending this process ends the server; ``rr.serve_web_viewer`` binds every interface)."""
    import rerun_cli

    binary = Path(rerun_cli.__file__).parent / "rerun"
    return subprocess.Popen([str(binary), "--serve-web", "--bind", "127.0.0.1", "--web-viewer-port", str(port),
                             grpc_url], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env={**os.environ, "RERUN_ANALYTICS": "0"})


class RerunLogger:
    """Writes one run to ``path`` (``.rrd``: written as ``path.partial`` and renamed when closed, unless
    ``atomic=False``; None: no file), streams it live to ``live`` (a running viewer and/or a gRPC server hosted on
    127.0.0.1, see :mod:`mcnkit.recording`) and, with ``notebook_viewer=True``, to ``.viewer`` (a
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
        self.rec = _Tee(APPLICATION_ID, recording_id)
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
                self._web = _serve_web_viewer(live.web_port, live.serve_url)
        self.viewer = self.rec.attach_notebook_viewer(blueprint, viewer_size) if notebook_viewer else None
        self.rec.log("/", rr.AnnotationContext([rr.AnnotationInfo(id=i, label=n, color=c) for i, n, c in _CLASSES]),
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
        self.rec.log(entity, rr.SegmentationImage(_ternary_classes(ternary.image), draw_order=-10.0), static=static)
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
                self._queue(f"{base}/window/{name}", "segmentation", step, stamp, _ternary_classes(image))
            # one byte per cell, drawn with a colour map (a third of an RGB image in the file)
            u8 = np.rint(np.clip(c.uncertainty[r], 0.0, 1.0) * 255).astype(np.uint8)
            self._queue(f"{base}/window/uncertainty", "depth", step, stamp, u8)
            self._queue(f"{base}/particle", "point", step, stamp, result.slam.poses[int(c.particles[r]), :2].copy())
        scores = dict(result.scores)
        scores["sample_diversity"] = float(c.diversity[0])
        for key, value in scores.items():
            if key in _METRICS and np.isfinite(value):
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
                color, label = _SERIES[entity.rsplit("/", 1)[-1]]
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
                self.rec.send_columns(entity, self._index(steps[sent:], stamps[sent:]), _columns(kind, values[sent:]),
                                      live=True)
                self._live_sent[entity] = len(steps)
            if steps and not live_only:
                if self.rec.file is not None:
                    self.rec.send_columns(entity, self._index(steps, stamps), _columns(kind, values), live=False)
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
