"""Rerun recordings of exploration runs (:class:`ExploreRecorder`), laid out by
:func:`mcnkit.viz.blueprints.explore_blueprint`.

Timelines: ``step`` (frame number) and ``path_dm`` (the path driven so far, in decimetres: the coverage curve against
the path length).  Entities, in metres in the map frame (``/world`` flips y so +y points up):

| path | what |
|---|---|
| ``/world/map/gt``, ``/world/map/reachable`` | the plan, and the reachable free space coverage is measured on (static) |
| ``/world/map/seen`` | what the sensor has seen of it, at every planning step (0.1 m cells) |
| ``/world/map/estimate`` | the planning map (the best particle's SLAM map), at every planning step |
| ``/world/robot/estimate``, ``/world/robot/truth`` | estimated and true pose (arrows); ``…/trajectory`` their paths |
| ``/world/scan/hits`` | the scan, seen from the estimated pose |
| ``/world/robot/contacts`` | where the robot touched a wall (a refused move), in its estimated frame, from that frame on |
| ``/world/plan/frontiers`` | frontier cells, coloured by their segment's score (yellow best, purple worst) |
| ``/world/plan/viewpoints`` | one per segment, labelled with its gain, path cost and score |
| ``/world/plan/goal``, ``/world/plan/path`` | the chosen viewpoint and the path to it |
| ``/world/pred/window`` | ``mcn``: the completions' window (Transform3D); under it ``partial`` (the SLAM map on it), ``sample{k}``, ``disagreement`` (4·p·(1−p), magma) and ``view`` (the share of samples in which a scan from the goal sees each cell) |
| ``/metrics/coverage``, ``/metrics/path_length_m``, ``/metrics/plan_cpu_ms`` | scalars |
| ``/log`` | one line per planning step |
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
import rerun as rr
from numpy.typing import NDArray

from mcnkit.explore.gain import sample_walls, visible_mask
from mcnkit.geometry import transform_points
from mcnkit.types import FREE, OCCUPIED, GridSpec, TernaryMap
from mcnkit.viz.blueprints import explore_blueprint
from mcnkit.viz.columns import ternary_classes
from mcnkit.viz.logger import RerunLogger

if TYPE_CHECKING:
    from mcnkit.app.recording import LiveViewer
    from mcnkit.explore.loop import Explorer, FrameRecord
    from mcnkit.explore.planners import Decision

__all__ = ["ExploreRecorder", "score_colors"]

_PATHS_EVERY = 10
"""Frames between two re-sent trajectories (a whole path each time)."""


def score_colors(score: NDArray[np.floating]) -> NDArray[np.uint8]:
    """RGB (N, 3) of scores (N,) by rank: the best yellow, the worst purple (viridis' ends)."""
    n = len(score)
    u = np.zeros(n) if n < 2 else np.argsort(np.argsort(score)) / (n - 1)
    lo, hi = np.array([68, 1, 84]), np.array([253, 231, 37])
    return (lo + np.outer(u, hi - lo)).astype(np.uint8)


def _pooled_mask(mask: NDArray[np.bool_], f: int) -> NDArray[np.uint8]:
    h, w = mask.shape
    padded = np.zeros((-(-h // f) * f, -(-w // f) * f), bool)
    padded[:h, :w] = mask
    blocks = padded.reshape(padded.shape[0] // f, f, padded.shape[1] // f, f)
    return np.asarray(blocks.any(axis=(1, 3)), np.uint8)


class ExploreRecorder:
    """Records an :class:`~mcnkit.explore.loop.Explorer`'s run: call :meth:`on_frame` with every frame record,
    then :meth:`close` (see the module docstring for what is logged)."""

    def __init__(self, path: str | Path | None, explorer: Explorer, *, samples: int = 0, recording_id: str | None = None,
                 live: LiveViewer | None = None, config: dict[str, Any] | None = None,
                 notebook_viewer: bool = False) -> None:
        self.explorer = explorer
        self.logger = RerunLogger(path, recording_id, explore_blueprint(samples), live=live, config=config,
                                  notebook_viewer=notebook_viewer)
        self.rec = self.logger.rec
        raster = explorer.raster
        self._pool = max(1, int(round(0.1 / raster.grid.resolution_m)))
        self.logger.log_ground_truth(TernaryMap(np.where(raster.free, FREE, OCCUPIED).astype(np.float32), raster.grid))
        for entity, color in (("/world/map/reachable", (40, 200, 90, 60)), ("/world/map/seen", (40, 120, 255, 110))):
            self.rec.log(entity, rr.AnnotationContext([rr.AnnotationInfo(id=0, color=(0, 0, 0, 0)),
                                                       rr.AnnotationInfo(id=1, label=entity.rsplit("/", 1)[-1],
                                                                         color=color)]), static=True)
        self._place("/world/map/reachable", raster.grid, static=True)
        self.rec.log("/world/map/reachable", rr.SegmentationImage(explorer.reachable.astype(np.uint8), draw_order=-8.0),
                     static=True)
        g = raster.grid
        self._place("/world/map/seen", GridSpec(g.resolution_m * self._pool, g.origin_x_m, g.origin_y_m,
                                                -(-g.width // self._pool), -(-g.height // self._pool)), static=True)
        self.rec.log("/world/robot/truth", rr.Arrows2D.from_fields(colors=[[230, 40, 40]]), static=True)
        self.rec.log("/world/robot/estimate", rr.Arrows2D.from_fields(colors=[[30, 120, 230]]), static=True)
        self.rec.log("/world/scan/hits", rr.Points2D.from_fields(radii=[0.03], colors=[[255, 160, 0]]), static=True)
        self.rec.log("/metrics/coverage", rr.SeriesLines(names="coverage", colors=[[40, 160, 60]], widths=2), static=True)
        self.rec.log("/metrics/plan_cpu_ms", rr.SeriesPoints(names="CPU per planning step [ms]", colors=[[150, 60, 200]],
                                                             marker_sizes=2.0), static=True)
        self._n_plans = 0
        self._n_contacts = 0

    @property
    def viewer(self) -> Any:
        """The embedded notebook viewer (None unless made with ``notebook_viewer=True``)."""
        return self.logger.viewer

    def _place(self, entity: str, grid: GridSpec, static: bool = False) -> None:
        self.rec.log(entity, rr.Transform3D(translation=[grid.origin_x_m, grid.origin_y_m, 0.0],
                                            scale=[grid.resolution_m, grid.resolution_m, 1.0]), static=static)

    def on_frame(self, record: FrameRecord) -> None:
        """Logs one frame (and its planning step, if it made one)."""
        ex = self.explorer
        self.rec.set_time("step", sequence=record.index)
        self.rec.set_time("path_dm", sequence=int(round(record.path_length_m * 10)))
        heading = 0.4 * np.array([np.cos(record.estimate[2]), np.sin(record.estimate[2])])
        self.rec.log("/world/robot/estimate", rr.Arrows2D(origins=[record.estimate[:2]], vectors=[heading]))
        truth_heading = 0.4 * np.array([np.cos(record.truth[2]), np.sin(record.truth[2])])
        self.rec.log("/world/robot/truth", rr.Arrows2D(origins=[record.truth[:2]], vectors=[truth_heading]))
        scan = ex.last_frame.scan
        ok = scan.valid
        if ok.any():
            laser = transform_points(record.estimate, np.array([[scan.spec.base_to_laser.x_m, scan.spec.base_to_laser.y_m]]))[0]
            a = record.estimate[2] + scan.spec.base_to_laser.yaw_rad + scan.spec.angles_rad[ok]
            r = scan.ranges_m[ok].astype(np.float64)
            self.rec.log("/world/scan/hits", rr.Points2D(np.stack([laser[0] + r * np.cos(a), laser[1] + r * np.sin(a)], 1)))
        self.rec.log("/metrics/coverage", rr.Scalars(record.coverage))
        if len(ex.contacts) > self._n_contacts:
            self._n_contacts = len(ex.contacts)
            self.rec.log("/world/robot/contacts", rr.Points2D([xy for _, xy in ex.contacts], radii=0.06,
                                                             colors=[[255, 0, 0]]))
            self.rec.log("/log", rr.TextLog(f"collision {self._n_contacts}: the robot touched a wall at "
                                            f"({ex.contacts[-1][1][0]:.2f}, {ex.contacts[-1][1][1]:.2f}) m",
                                            level=rr.TextLogLevel.WARN))
        if record.index % _PATHS_EVERY == 0 or ex.done:
            recs = ex.records
            for name, color, pts in (("estimate", [30, 120, 230], [x.estimate[:2] for x in recs]),
                                     ("truth", [230, 40, 40], [x.truth[:2] for x in recs])):
                self.rec.log(f"/world/robot/{name}/trajectory", rr.LineStrips2D([np.asarray(pts)], radii=0.03,
                                                                               colors=[color]))
        if record.decision is not None:
            self.on_decision(record.decision)

    def on_decision(self, d: Decision) -> None:
        """Logs one planning step: the map, frontiers, scored viewpoints, goal, path and the prediction."""
        self._n_plans += 1
        grid = d.frontiers.grid
        self.logger.log_map("/world/map/estimate", TernaryMap(d.map_image, grid))
        self.rec.log("/world/map/seen", rr.SegmentationImage(_pooled_mask(self.explorer.seen & self.explorer.reachable,
                                                                          self._pool), draw_order=-7.0))
        f = d.frontiers
        seg_score = np.full(f.n_segments, -np.inf)
        seg_score[d.points.segment] = d.score
        self.rec.log("/world/plan/frontiers", rr.Points2D(f.xy_m(), radii=grid.resolution_m * 0.6,
                                                         colors=score_colors(seg_score)[f.segment] if f.n_segments else None))
        p = d.points
        labels = [f"{g:.1f} m² / {c:.1f} m → {s:.2f}" for g, c, s in zip(d.gain, p.cost_m, d.score, strict=True)]
        self.rec.log("/world/plan/viewpoints", rr.Points2D(p.xy_m, radii=0.08, colors=score_colors(d.score),
                                                          labels=labels, show_labels=False))
        goal = d.goal_xy_m
        if goal is not None and d.path_m is not None:
            self.rec.log("/world/plan/goal", rr.Points2D([goal], radii=0.2, colors=[[255, 40, 200]]))
            self.rec.log("/world/plan/path", rr.LineStrips2D([d.path_m], radii=0.04, colors=[[255, 40, 200]]))
        else:
            self.rec.log("/world/plan/goal", rr.Clear(recursive=False))
            self.rec.log("/world/plan/path", rr.Clear(recursive=False))
        self.rec.log("/metrics/plan_cpu_ms", rr.Scalars(1000.0 * d.cpu_s))
        what = (f"plan {self._n_plans}: {len(p)} viewpoints; {'kept' if d.kept else 'new'} goal ({goal[0]:.1f}, "
                f"{goal[1]:.1f}) m, gain "
                f"{d.gain[d.choice]:.1f} m², path cost {p.cost_m[d.choice]:.1f} m"
                if goal is not None and d.choice is not None else f"plan {self._n_plans}: no reachable frontier")
        self.rec.log("/log", rr.TextLog(f"{what}; CPU {1000 * d.cpu_s:.0f} ms"))
        if d.prediction is not None:
            self._prediction(d)

    def _prediction(self, d: Decision) -> None:
        pred = d.prediction
        assert pred is not None
        w = pred.window
        self._place("/world/pred/window", w)
        self.rec.log("/world/pred/window/partial", rr.SegmentationImage(ternary_classes(pred.partial), draw_order=-10.0))
        for k in range(len(pred.samples)):
            self.rec.log(f"/world/pred/window/sample{k}", rr.SegmentationImage(ternary_classes(pred.samples[k]),
                                                                                draw_order=-10.0))
        u8 = np.rint(np.clip(pred.disagreement, 0.0, 1.0) * 255).astype(np.uint8)
        self.rec.log("/world/pred/window/disagreement", rr.DepthImage(u8, meter=255.0, colormap="magma",
                                                                      depth_range=[0.0, 255.0]))
        goal = d.goal_xy_m
        if goal is None:
            return
        origin = w.world_to_cells_xy(np.asarray(goal, np.float64))
        walls = sample_walls(pred.samples, pred.partial, "unknown")
        reach = self.explorer.sim.lidar.range_max_m / w.resolution_m
        share = np.mean([visible_mask(walls[k], origin, 180, reach) for k in range(len(walls))], axis=0)
        self.rec.log("/world/pred/window/view", rr.DepthImage(np.rint(share * 255).astype(np.uint8), meter=255.0,
                                                              colormap="viridis", depth_range=[0.0, 255.0]))

    def close(self) -> None:
        """Finalises the recording (the file renamed into place)."""
        self.logger.close()
