"""The closed loop: sensor → SLAM → (completion →) planner → motion, one frame at a time, until done.

:class:`Explorer` puts the simulator's robot (:mod:`mcnkit.sim`: its lidar, its carrot following, its drifting
odometry) in a plan at a random safe pose and runs, per frame (``1 / scan_rate_hz`` s):

1. a planning step (:func:`mcnkit.explore.planners.decide`) when there is no path, the goal is reached, or the
   robot drove ``replan_m`` since the last one (which keeps the goal while its frontier is there, and plans a new
   path to it on the new map; a goal chosen again after the robot turned away from it is kept until reached,
   ``keep_returned``); it plans on the best particle's map, from the robot's *estimated*
   pose (the best particle's pose at the last filter update plus the odometry since).  That map is the SLAM's own,
   but for one thing: a beam that returned nothing saw free space out to the sensor's range (the SLAM skips such
   beams; a robot looking down a long corridor would otherwise never know it can go there);
2. one frame of carrot following along the path from the estimated pose; the same commands move the true pose
   (a move that would put the robot's disc into a wall of the ground truth is not made: a collision; the robot
   backs off a frame (turning away where reversing would not free it), puts the point its bumper felt on its planning map for ``contact_keep_s`` (in its estimated
   frame), follows the next metre of its new path without cutting corners and plans again, so a map that draws a
   wall a little off, or a wall below the lidar's plane, does not wedge the robot against it);
3. the odometry measures the true motion with the simulator's noise, the lidar scans from the true pose;
4. FastSLAM steps on that frame; the coverage (:mod:`mcnkit.explore.coverage`) is updated from the true pose.

It stops when no frontier is reachable (``explored``), the path budget is spent (``budget``), the coverage reached
``stop_coverage`` (``coverage``), the time ran out (``time``: three times the budget at full speed) or the robot
stands where its map leaves it no room to move (``stuck``).  Goals the
robot reached without their frontier going away, or got no closer to along the path for ``stuck_s``, are blacklisted.

Randomness: one seed gives the start pose, the sensor and odometry noise, the SLAM's and the sampler's streams
(:class:`numpy.random.SeedSequence` children), the same for every planner.

Example:
    >>> ex = Explorer(plan_raster("procedural:1"), FrontierPlanner(), seed=0)  # doctest: +SKIP
    >>> result = ex.run()                                                    # doctest: +SKIP
    >>> result.stop_reason, result.coverage[-1]                              # doctest: +SKIP
    ('explored', 0.98)
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from mcnkit.explore.config import ExploreConfig
from mcnkit.explore.coverage import mark_seen, reachable_free
from mcnkit.explore.paths import mark_contacts
from mcnkit.explore.planners import Decision, Planner, decide, planning_view
from mcnkit.geometry import compose, relative
from mcnkit.sim import (
    PlanRaster,
    SimConfig,
    add_range_noise,
    cast_rays,
    draw_odometry_bias,
    drive,
    follow_step,
    integrate_odometry,
    noisy_motion,
    path_done,
    safe_region,
)
from mcnkit.slam.config import SlamConfig, UpdatesConfig
from mcnkit.slam.fastslam import FastSlam
from mcnkit.slam.lineage import LineageMap
from mcnkit.types import Frame, Pose2D, Scan

__all__ = ["EXPLORE_SLAM", "Explorer", "FrameRecord", "PlanStep", "planning_lineage", "seed_streams"]

F64 = NDArray[np.float64]
BoolArray = NDArray[np.bool_]

EXPLORE_SLAM = SlamConfig(updates=UpdatesConfig(linear_m=0.3, angular_rad=0.3))
"""The SLAM of an exploring robot: a filter update (and so a map that shows the last scan) every 0.3 m or 0.3 rad,
so a planning step sees what the robot saw where it stands."""


_CAREFUL_M = 1.0
_CAREFUL_LOOKAHEAD_M = 0.1
"""After a collision the robot follows its next path with this lookahead for ``_CAREFUL_M`` of driving: the carrot
0.4 m ahead cuts corners, which a map whose walls sit a little off does not leave room for."""


def seed_streams(seed: int) -> tuple[np.random.Generator, np.random.Generator, int]:
    """The world's generator (start pose, odometry, lidar), the SLAM's, and a seed for the sampler's."""
    world, slam, sampler = np.random.SeedSequence(seed).spawn(3)
    return np.random.default_rng(world), np.random.default_rng(slam), int(sampler.generate_state(1)[0])


def planning_lineage(slam: FastSlam) -> tuple[LineageMap, float]:
    """An empty :class:`LineageMap` with the ray casting of ``slam``'s maps (after its first frame), except that a
    beam of ``no_return_m`` (the range a planner gives a beam that returned nothing: the sensor saw no wall within
    its range) clears space out to just short of it and marks no wall; and that range."""
    lidar = slam.lidar
    if lidar is None:
        raise RuntimeError("no scan processed yet")
    max_range, usable = slam.beam_limits()
    lineage = LineageMap(slam.config.resolution_m, lidar.angles_rad, lidar.base_to_laser.as_array(),
                         max_range_m=max_range, usable_m=min(usable, max_range - 0.01),
                         occ_thresh=slam.config.map.occ_thresh)
    return lineage, max_range


@dataclass(frozen=True)
class FrameRecord:
    """One frame of the loop."""

    index: int
    truth: F64
    """(3,) true pose after the frame."""
    estimate: F64
    """(3,) the robot's estimated pose after the frame."""
    path_length_m: float
    """True distance driven so far."""
    coverage: float
    """Share of the reachable free space seen so far."""
    decision: Decision | None = None
    """The planning step made at the start of this frame, if any (only in the record :meth:`Explorer.step`
    returns: :attr:`Explorer.records` keep none)."""


@dataclass(frozen=True)
class PlanStep:
    """A planning step in brief."""

    frame: int
    """The frame it was made at."""
    cpu_s: float
    viewpoints: int
    """Frontier viewpoints it chose from."""
    frontiers: int
    """Frontier segments on the map, reachable or not (a step with none to choose from and some left: the robot
    cannot reach what is left to see)."""
    goal_xy_m: F64 | None
    gain_m2: float | None
    """The chosen viewpoint's expected gain (0 for the frontier planner); None without a goal."""
    cost_m: float | None

    @classmethod
    def of(cls, frame: int, d: Decision) -> PlanStep:
        """The brief of decision ``d``."""
        if d.choice is None:
            return cls(frame, d.cpu_s, len(d.points), d.frontiers.n_segments, None, None, None)
        return cls(frame, d.cpu_s, len(d.points), d.frontiers.n_segments, d.points.xy_m[d.choice].copy(),
                   float(d.gain[d.choice]), float(d.points.cost_m[d.choice]))


@dataclass
class _Goal:
    xy_m: F64
    best_dist_m: float
    """The least distance left to drive to it so far (along the path)."""
    since_progress_s: float = 0.0
    kept: bool = False
    """Kept until reached or given up: the robot turned away from it once before (``keep_returned``)."""


@dataclass
class Explorer:
    """The closed loop in one plan (see the module docstring); :meth:`step` one frame, :meth:`run` to the end."""

    raster: PlanRaster
    planner: Planner
    config: ExploreConfig = field(default_factory=ExploreConfig)
    sim: SimConfig = field(default_factory=SimConfig)
    slam_config: SlamConfig = EXPLORE_SLAM
    seed: int = 0
    low_obstacles: BoolArray | None = None
    """(H, W) cells of ``raster`` the robot cannot drive into but its lidar does not see (below the scan plane: a
    step, a low table, a chair's legs); None: none.  The coverage is still measured on the plan's reachable space."""

    def __post_init__(self) -> None:
        self.rng, slam_rng, self.sampler_seed = seed_streams(self.seed)
        start = self.config.start_m
        safe, _ = safe_region(self.raster, self.sim, np.asarray(start[:2]) if start else None)
        self._body_free = self.raster.free if self.low_obstacles is None else self.raster.free & ~self.low_obstacles
        """Where the robot's body can be (its collisions), as opposed to what the lidar sees (``raster.free``)."""
        self._clearance = ndimage.distance_transform_edt(self._body_free) * self.raster.grid.resolution_m
        safe &= self._clearance > self.sim.robot_radius_m + self.sim.margin_m
        if not safe.any():
            raise ValueError(f"{self.raster.name}: its low obstacles leave no place wide enough for the robot")
        # the reachable space: what the planner's clearance lets the robot get to (its start lies inside)
        cells = np.flatnonzero(safe)
        rc = np.array(divmod(int(cells[self.rng.integers(cells.size)]), safe.shape[1]), np.int64)
        xy = self.raster.grid.cell_to_world(rc)
        pose = np.array([xy[0], xy[1], self.rng.uniform(-np.pi, np.pi)])  # drawn either way: the same noise follows
        if start:
            xy = np.asarray(start[:2], np.float64)
            pose = np.array([xy[0], xy[1], math.radians(start[2]) if len(start) > 2 else pose[2]])
        reach_safe = safe_region(self.raster, replace(self.sim, margin_m=self.config.plan_margin_m), xy)[0]
        self.spec = self.sim.lidar.spec()
        self._mount = self.spec.base_to_laser.as_array()
        self._bias = draw_odometry_bias(self.sim.odometry, self.rng)
        self.reachable = reachable_free(self.raster, reach_safe | safe, xy, self.spec.range_max_m,
                                        self.config.coverage_rays, self.config.coverage_lattice_m)
        self._n_reachable = max(int(self.reachable.sum()), 1)
        self.seen = np.zeros_like(self.reachable)
        self.slam = FastSlam(self.slam_config, slam_rng)
        self.truth, self.odom, self.estimate = pose.copy(), pose.copy(), pose.copy()
        self._anchor = (pose.copy(), pose.copy())  # (best pose, odometry) at the last filter update
        self.path_length_m = 0.0
        self.n_frames = 0
        self.n_collisions = 0
        self.contacts: list[tuple[int, F64]] = []
        """(frame, point [m] in the estimated frame) of every collision: where the robot felt a wall."""
        self._wall_index: NDArray[np.intp] | None = None
        self.blacklist: list[F64] = []
        self.plans: list[PlanStep] = []
        """Every planning step in brief (its CPU time, goal, gain and cost)."""
        self.last_decision: Decision | None = None
        """The last planning step in full (a run keeps only that one: a decision holds whole maps)."""
        self.stop_reason: str | None = None
        self.lineage: LineageMap | None = None
        """The map the robot plans on: the best particle's, its no-return beams clearing space to the range."""
        self._planning_ranges: list[NDArray[np.float32]] = []
        self._no_return_m = 0.0
        self._path: F64 | None = None
        self._carrot = 0
        self._since_plan_m = 0.0
        self._careful_m = 0.0
        self._goal: _Goal | None = None
        self._left: list[F64] = []  # goals the robot turned away from before reaching or giving them up
        self._cpu_s = 0.0
        self.records: list[FrameRecord] = []
        self._sense()

    # -- the loop ---------------------------------------------------------------------------------------------

    @property
    def done(self) -> bool:
        """True once the run stopped (:attr:`stop_reason` says why)."""
        return self.stop_reason is not None

    @property
    def coverage(self) -> float:
        """Share of the reachable free space seen so far."""
        return float((self.seen & self.reachable).sum()) / self._n_reachable

    def run(self) -> list[FrameRecord]:
        """Steps until the run stops; every frame's record."""
        while not self.done:
            self.step()
        return self.records

    def step(self) -> FrameRecord:
        """One frame (see the module docstring); after the run stopped, the last record again."""
        if self.done:
            return self.records[-1]
        t0 = time.process_time()
        decision = self._maybe_plan()
        if self._path is not None and not self.done:
            self._move()
            self._sense()
        self._check_stop()
        self._cpu_s += time.process_time() - t0
        record = FrameRecord(self.n_frames - 1, self.truth.copy(), self.estimate.copy(), self.path_length_m,
                             self.coverage, decision)
        # kept without its decision (see last_decision); the last one repeats its frame when the run stopped at a
        # planning step
        self.records.append(replace(record, decision=None))
        return record

    @property
    def cpu_s(self) -> float:
        """CPU time of the loop so far (simulation included) [s]."""
        return self._cpu_s

    # -- internals --------------------------------------------------------------------------------------------

    def _maybe_plan(self) -> Decision | None:
        cfg = self.config
        goal = self._goal
        reached = goal is not None and float(np.hypot(*(goal.xy_m - self.estimate[:2]))) < cfg.goal_tolerance_m
        if self._path is not None and path_done(self.estimate, self._path, self._carrot):
            reached = True
        stuck = goal is not None and goal.since_progress_s > cfg.stuck_s
        if goal is not None and (reached or stuck):
            self.blacklist.append(goal.xy_m.copy())  # a frontier still there after this is one it cannot see
        if not (self._path is None or reached or stuck or self._since_plan_m >= cfg.replan_m):
            return None
        decision = self._plan(None if reached or stuck else goal)
        self.last_decision = decision
        self.plans.append(PlanStep.of(self.n_frames - 1, decision))
        if decision.choice is None or decision.path_m is None:
            self._path, self._goal = None, None
            self.stop_reason = "explored" if decision.field.start is not None else "stuck"
            return decision
        goal_xy = decision.points.xy_m[decision.choice]
        if self._goal is None or np.hypot(*(goal_xy - self._goal.xy_m)) > cfg.goal_tolerance_m:
            if self._goal is not None and not (reached or stuck):
                self._left.append(self._goal.xy_m.copy())
            back = cfg.keep_returned and any(np.hypot(*(goal_xy - g)) <= cfg.commit_m for g in self._left)
            self._goal = _Goal(goal_xy.copy(), np.inf, kept=back)
        path = decision.path_m
        self._path = path if len(path) > 1 else np.concatenate([path, path])
        self._carrot = 0
        self._since_plan_m = 0.0
        return decision

    def _plan(self, goal: _Goal | None) -> Decision:
        """One planning step on the current map; ``goal`` is the goal still being driven to (None when there is none
        or it was just reached or given up), which :func:`decide` keeps as its rules say."""
        t0 = time.process_time()
        if self.lineage is None:
            self.lineage, self._no_return_m = planning_lineage(self.slam)
        updates = self.slam.update_ranges
        for r in updates[len(self._planning_ranges) :]:
            self._planning_ranges.append(np.where(np.isfinite(r), r, np.float32(self._no_return_m)))
        self.lineage.sync(self.slam.update_poses(), self._planning_ranges)
        view = planning_view(self.lineage, self.estimate, self.config.plan_resolution_m, self.config.plan_max_cells)
        keep_frames = self.config.contact_keep_s * self.sim.scan_rate_hz
        felt = [xy for frame, xy in self.contacts if self.n_frames - frame <= keep_frames]
        if felt:
            view = replace(view, image=mark_contacts(view.image, view.grid, np.array(felt)))
        black = np.asarray(self.blacklist).reshape(-1, 2)
        d = decide(view, self.planner, self.config, self.sim.robot_radius_m, black,
                   None if goal is None else goal.xy_m, goal is not None and goal.kept)
        return replace(d, cpu_s=time.process_time() - t0)

    def _move(self) -> None:
        assert self._path is not None
        h = 1.0 / self.sim.scan_rate_hz / 5
        # after a collision the next metre is driven along the path itself, not cutting its corners
        sim = self.sim if self._careful_m <= 0 else replace(self.sim, lookahead_m=_CAREFUL_LOOKAHEAD_M)
        _, self._carrot, commands = follow_step(self.estimate, self._path, self._carrot, sim)
        truth = self.truth
        for v, w in commands:
            truth = drive(truth, v, w, h)
        rc = self.raster.grid.world_to_cell(truth[:2])
        inside = self.raster.grid.contains(rc)
        if not inside or self._clearance[rc[0], rc[1]] < self.sim.robot_radius_m:
            self.n_collisions += 1  # the robot stops short of the wall, backs off and plans again
            self.contacts.append((self.n_frames, self._contact(truth)))
            truth = self._back_off()
            self._path = None
            self._careful_m = _CAREFUL_M
        step = relative(self.truth, truth)
        moved = float(np.hypot(step[0], step[1]))
        self.path_length_m += moved
        self._careful_m -= moved
        self._since_plan_m += moved
        normals = self.rng.standard_normal((3, 1))
        self.odom = integrate_odometry(self.odom, *noisy_motion(step[None], normals, self._bias, self.sim.odometry))[-1]
        self.truth = truth
        if self._goal is not None:
            dist = self._to_goal_m()
            if dist < self._goal.best_dist_m - 0.1:
                self._goal.best_dist_m, self._goal.since_progress_s = dist, 0.0
            else:
                self._goal.since_progress_s += 1.0 / self.sim.scan_rate_hz

    def _to_goal_m(self) -> float:
        """How far the robot still has to drive to its goal: along its path from the carrot on (a path that leads
        away from the goal first, around a wall, is progress too), straight where it has no path."""
        assert self._goal is not None
        if self._path is None:
            return float(np.hypot(*(self._goal.xy_m - self.estimate[:2])))
        rest = self._path[self._carrot :]
        return float(np.hypot(*(rest[0] - self.estimate[:2])) + np.hypot(*np.diff(rest, axis=0).T).sum())

    def _back_off(self) -> F64:
        """The true pose after a bumper's recovery (the same plan from the same pose would drive into the same
        wall again): a frame of reversing at half speed where that brings no wall closer; else the move of a frame
        (reversing or creeping forward, turning either way) that brings the walls farthest; where none brings them
        farther (wedged between two), a frame of turning in place, so the next frame's moves point elsewhere."""
        dt = 1.0 / self.sim.scan_rate_hz
        v, w = 0.5 * self.sim.speed_m_s, self.sim.turn_rate_rad_s
        grid = self.raster.grid

        def room(pose: F64) -> float:
            rc = grid.world_to_cell(pose[:2])
            return float(self._clearance[rc[0], rc[1]]) if grid.contains(rc) else -1.0

        now = room(self.truth)
        ends = [drive(self.truth, a, b, dt) for a, b in ((-v, 0.0), (-v, w), (-v, -w), (v, w), (v, -w))]
        rooms = [room(p) for p in ends]
        if rooms[0] >= max(self.sim.robot_radius_m, now):
            return ends[0]
        best = int(np.argmax(rooms))
        if rooms[best] > now and rooms[best] >= self.sim.robot_radius_m:
            return ends[best]
        return drive(self.truth, 0.0, w, dt)

    def _contact(self, blocked: F64) -> F64:
        """Where the robot, trying to move to the true pose ``blocked``, touches the wall (the nearest wall cell of
        the ground truth, as its bumper feels it: on its body), in its estimated frame [m]."""
        if self._wall_index is None:
            self._wall_index = ndimage.distance_transform_edt(self._body_free, return_distances=False,
                                                              return_indices=True)
        grid = self.raster.grid
        rc = np.clip(grid.world_to_cell(blocked[:2]), 0, np.array(grid.shape) - 1)
        wall = grid.cell_to_world(self._wall_index[:, rc[0], rc[1]])
        on_body = relative(blocked, np.array([wall[0], wall[1], 0.0]))
        moved = relative(self.truth, blocked)
        return compose(compose(self.estimate, moved), on_body)[:2]

    def _sense(self) -> None:
        laser = compose(self.truth, self._mount)
        ranges = cast_rays(self.raster.free, self.raster.grid, laser[None], self.spec)
        add_range_noise(ranges, self.sim.lidar, self.rng)
        stamp = self.sim.start_stamp_ns + int(round(self.n_frames * 1e9 / self.sim.scan_rate_hz))
        self.last_frame = Frame(stamp, Scan(ranges[0], self.spec), Pose2D.from_array(self.odom))
        s = self.slam.step(self.last_frame)
        if s.updated:
            self._anchor = (s.best_pose.copy(), self.odom.copy())
        self.estimate = compose(self._anchor[0], relative(self._anchor[1], self.odom))
        mark_seen(self.raster.free, self.raster.grid, self.seen, laser[None, :2], self.spec.range_max_m,
                  self.config.coverage_rays)
        self.n_frames += 1
        if not self.records:
            self.records.append(FrameRecord(0, self.truth.copy(), self.estimate.copy(), 0.0, self.coverage))

    def _check_stop(self) -> None:
        if self.done:
            return
        cfg = self.config
        max_frames = int(3 * cfg.budget_m / self.sim.speed_m_s * self.sim.scan_rate_hz)
        if self.path_length_m >= cfg.budget_m:
            self.stop_reason = "budget"
        elif self.coverage >= cfg.stop_coverage:
            self.stop_reason = "coverage"
        elif self.n_frames >= max_frames:
            self.stop_reason = "time"
