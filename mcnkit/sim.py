"""A 2D robot simulator on a floor plan: exploration path, lidar, drifting odometry, ground truth.

Given a plan raster (HouseExpo id, procedural seed or occupancy image, :func:`plan_raster`) the robot

1. starts at a random pose in the largest connected region where its disc fits (``seed``);
2. visits goals greedily, nearest first by path cost: room-box centres snapped to the clearest cell within 1.5 m,
   plus the clearest cell of every 3 m tile that no goal within 3 m covers already; each leg is a minimum-cost
   path (skimage ``MCP_Geometric``, 8-connected) over the cells whose wall clearance exceeds the robot radius
   plus a margin, with a cost that grows near walls;
3. follows the path with a carrot 0.4 m ahead (pure pursuit, turning in place on sharp turns), one frame every ``1/scan_rate_hz`` s;
4. scans with a 2D lidar cast on the raster (vectorised sampling along every beam; the range is then made exact
   with a slab intersection against the first occupied cell), Gaussian range noise, optional dropouts;
5. integrates odometry like a wheel base: the true motion per frame as (rot1, trans, rot2) with noise
   proportional to the motion (Thrun's odometry model), a per-run wheel-scale error and a yaw bias per metre.

Odometry starts at the true start pose (so a SLAM map built in the odometry's first frame is aligned with the
ground-truth map).  Everything is deterministic per seed.  Steps 3-5 are also pure functions of one frame
(:func:`follow_step`, :func:`drive`, :func:`noisy_motion`, :func:`integrate_odometry`, :func:`cast_rays`,
:func:`add_range_noise`) for a robot whose path is planned as it goes (:mod:`mcnkit.explore`).  :func:`write_sim_log` writes a bag/MCAP/rosbag2 with
/scan, /odom, /tf, /tf_static, /ground_truth and /map_gt (see :mod:`mcnkit.io.writers`).

Example:
    >>> raster = plan_raster("procedural:1")
    >>> result = simulate(raster, SimConfig(max_duration_s=5.0), seed=0)
    >>> len(result.frames)
    50
"""

from __future__ import annotations

import os
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from skimage.graph import MCP_Geometric

from mcnkit.datasets.floorplans import generate_apartment, rasterize_apartment
from mcnkit.datasets.houseexpo import FloorPlan, load_plan, rasterize_plan
from mcnkit.datasets.houseexpo import houseexpo_source as find_houseexpo_source
from mcnkit.datasets.images import outside_walls, read_occupancy_image
from mcnkit.geometry import compose, relative, wrap_angle
from mcnkit.io import GroundTruthMap, LogContent, write_log
from mcnkit.types import Frame, GridSpec, LidarSpec, Pose2D, Scan, Trajectory

__all__ = [
    "LidarConfig",
    "OdometryBias",
    "OdometryNoise",
    "PlanRaster",
    "SimConfig",
    "SimResult",
    "add_range_noise",
    "cast_rays",
    "draw_odometry_bias",
    "drive",
    "follow_step",
    "houseexpo_raster",
    "integrate_odometry",
    "noisy_motion",
    "path_done",
    "plan_raster",
    "safe_region",
    "simulate",
    "write_sim_log",
]

F64 = NDArray[np.float64]
BoolArray = NDArray[np.bool_]


@dataclass(frozen=True)
class LidarConfig:
    """The simulated scanner: beams over ``fov_deg`` (centred ahead), range interval, noise, mount on the base."""

    n_beams: int = 360
    fov_deg: float = 360.0
    range_min_m: float = 0.1
    range_max_m: float = 8.0
    noise_std_m: float = 0.01
    dropout_prob: float = 0.0
    mount: Pose2D = field(default_factory=lambda: Pose2D(0.1, 0.0, 0.0))

    def spec(self) -> LidarSpec:
        """The :class:`LidarSpec` of this scanner (a 360° scan does not repeat its first beam)."""
        fov = np.deg2rad(self.fov_deg)
        full = self.fov_deg >= 360.0 - 1e-9
        inc = fov / self.n_beams if full else fov / max(self.n_beams - 1, 1)
        return LidarSpec(-fov / 2, inc, self.n_beams, self.range_min_m, self.range_max_m, self.mount)


@dataclass(frozen=True)
class OdometryNoise:
    """Wheel odometry errors: Thrun's alphas per frame, plus a per-run scale error and yaw bias (drawn once)."""

    rot_per_rot: float = 0.05
    rot_per_m: float = 0.02
    trans_per_m: float = 0.05
    trans_per_rot: float = 0.01
    scale_std: float = 0.01
    yaw_bias_std_rad_per_m: float = 0.005


@dataclass(frozen=True)
class SimConfig:
    """Simulation settings (metres, seconds, radians)."""

    resolution_m: float = 0.05
    robot_radius_m: float = 0.2
    margin_m: float = 0.1
    speed_m_s: float = 0.4
    turn_rate_rad_s: float = 1.0
    lookahead_m: float = 0.4
    scan_rate_hz: float = 10.0
    max_duration_s: float = 600.0
    start_stamp_ns: int = 1_600_000_000_000_000_000
    lidar: LidarConfig = field(default_factory=LidarConfig)
    odometry: OdometryNoise = field(default_factory=OdometryNoise)


@dataclass(frozen=True)
class PlanRaster:
    """A plan on a grid: ``free`` (H, W) bool, its :class:`GridSpec` and room goals (K, 2) in metres."""

    name: str
    free: BoolArray
    grid: GridSpec
    goals_m: F64


@dataclass(frozen=True)
class SimResult:
    """A simulated run: frames (scan + drifting odometry), ground truth trajectory and map, the plan raster."""

    frames: list[Frame]
    ground_truth: Trajectory
    odometry: Trajectory
    gt_map: GroundTruthMap
    raster: PlanRaster
    seed: int

    def to_log_content(self) -> LogContent:
        """What :func:`mcnkit.io.write_log` writes for this run."""
        return LogContent(frames=self.frames, ground_truth=self.ground_truth, ground_truth_map=self.gt_map)


def plan_raster(
    map_spec: str, resolution_m: float = 0.05, houseexpo_source: str | os.PathLike[str] | None = None
) -> PlanRaster:
    """Rasterizes ``houseexpo:<id>``, ``procedural:<seed>`` or ``image:<file>`` with a 1 m occupied border.

    ``image:<file>``: a PNG/PGM occupancy image (dark = wall, light = free), its pixel size and origin from a ROS
    map_server YAML beside it, else ``resolution_m`` (:func:`mcnkit.datasets.images.read_occupancy_image`); it has
    no room boxes (the exploration path's goals are its 3 m tiles).  Light space outside the building's walls (a
    plan drawn on a light background) is left out with a warning (:func:`mcnkit.datasets.images.outside_walls`).

    Raises:
        ValueError: a malformed spec, a missing HouseExpo archive, or an unknown/invalid plan id.
    """
    kind, _, arg = map_spec.partition(":")
    border = int(np.ceil(1.0 / resolution_m))
    if kind == "procedural":
        try:
            apartment = generate_apartment(int(arg))
        except ValueError:
            raise ValueError(f"procedural:SEED needs an integer seed, got {arg!r}") from None
        free, grid = rasterize_apartment(apartment, resolution_m, border)
        return PlanRaster(map_spec, free, grid, apartment.room_centres_m)
    if kind == "houseexpo":
        source = find_houseexpo_source(houseexpo_source)
        if source is None:
            raise ValueError("HouseExpo is not installed: run `mcnkit data install houseexpo --from PATH_OR_URL` "
                             "(or set MCNKIT_SHARED_DATA to a folder holding houseexpo/json.tar.gz)")
        return houseexpo_raster(load_plan(source, arg), resolution_m)  # PlanError is a ValueError
    if kind == "image":
        if not arg:
            raise ValueError("image:FILE needs a PNG/PGM path")
        free, grid = read_occupancy_image(arg, resolution_m)
        outside = outside_walls(free, grid.resolution_m)
        if outside.any():
            warnings.warn(f"{arg}: {outside.sum() * grid.resolution_m ** 2:.0f} m² of light space joined to the "
                          "image's edge is outside the building's walls and not part of the plan (draw the edge dark "
                          "to keep it)", stacklevel=2)
            free = free & ~outside
        border = int(np.ceil(1.0 / grid.resolution_m))
        padded = np.pad(free, border, constant_values=False)
        g = GridSpec(grid.resolution_m, grid.origin_x_m - border * grid.resolution_m,
                     grid.origin_y_m - border * grid.resolution_m, padded.shape[1], padded.shape[0])
        return PlanRaster(map_spec, padded, g, np.zeros((0, 2)))
    raise ValueError(f"map spec must be houseexpo:ID, procedural:SEED or image:FILE, got {map_spec!r}")


def houseexpo_raster(plan: FloorPlan, resolution_m: float = 0.05) -> PlanRaster:
    """A HouseExpo plan as ``houseexpo:<id>`` rasterizes (1 m occupied border, room-box centres as goals)."""
    free, grid = rasterize_plan(plan, resolution_m, int(np.ceil(1.0 / resolution_m)))
    boxes = plan.room_boxes_m
    return PlanRaster(f"houseexpo:{plan.id}", free, grid,
                      np.stack([boxes[:, [0, 2]].mean(1), boxes[:, [1, 3]].mean(1)], 1))


def cast_rays(free: BoolArray, grid: GridSpec, laser_poses: F64, spec: LidarSpec) -> NDArray[np.float32]:
    """Exact noise-free ranges (F, B) from laser poses (F, 3) on the raster; ``inf`` where nothing is in range.

    Cells outside the grid count as occupied.  Every beam is sampled every ``resolution/4`` (in blocks; beams that
    hit stop); the first occupied sample's cell is then intersected exactly with the ray (slab method).  A beam that
    steps diagonally between two occupied cells touching at a corner (a wall one pixel thick drawn at a slant) ends
    at that corner: a drawn wall is closed where its pixels touch.
    """
    res = grid.resolution_m
    angles = laser_poses[:, 2:3] + spec.angles_rad[None, :]  # (F, B)
    dx, dy = np.cos(angles).ravel(), np.sin(angles).ravel()  # (F·B,)
    ox = np.repeat((laser_poses[:, 0] - grid.origin_x_m) / res, angles.shape[1])  # (F·B,) in cells
    oy = np.repeat((laser_poses[:, 1] - grid.origin_y_m) / res, angles.shape[1])
    t_all = np.arange(0.0, spec.range_max_m / res + 1.0, 0.25)  # samples along a beam, in cells
    hit = np.zeros(dx.shape, bool)
    hr = np.zeros(dx.shape, np.int64)
    hc = np.zeros(dx.shape, np.int64)
    t_corner = np.full(dx.shape, np.inf)  # where a beam squeezed between two corner-touching occupied cells

    def occupied(rows: NDArray[np.int64], cols: NDArray[np.int64]) -> BoolArray:
        inside = (rows >= 0) & (rows < grid.height) & (cols >= 0) & (cols < grid.width)
        occ = ~inside
        occ[inside] = ~free[rows[inside], cols[inside]]
        return occ

    active = np.arange(dx.size)
    for b0 in range(0, t_all.size, 64):  # march in blocks; beams that hit drop out
        t = t_all[max(b0 - 1, 0) : b0 + 64][None, :]  # from the block before's last sample (free: the beam went on)
        cols = np.floor(ox[active, None] + dx[active, None] * t).astype(np.int64)  # (A, S)
        rows = np.floor(oy[active, None] + dy[active, None] * t).astype(np.int64)
        occ = occupied(rows, cols)
        r0, c0, r1, c1 = rows[:, :-1], cols[:, :-1], rows[:, 1:], cols[:, 1:]
        squeeze = (r0 != r1) & (c0 != c1)  # (A, S-1): a diagonal step into sample 1..S-1 ...
        squeeze[squeeze] = occupied(r0[squeeze], c1[squeeze]) & occupied(r1[squeeze], c0[squeeze])  # ... squeezed
        event = occ.copy()
        event[:, 1:] |= squeeze
        any_hit = event.any(axis=1)
        first = np.argmax(event, axis=1)[any_hit]
        idx = active[any_hit]
        hit[idx] = True
        hr[idx] = rows[any_hit, first]
        hc[idx] = cols[any_hit, first]
        sq = np.zeros(first.shape, bool)
        sq[first > 0] = squeeze[any_hit, :][first > 0, first[first > 0] - 1]
        if sq.any():  # the corner the two cells share, projected on the beam; the slab search starts at one of them
            j = first[sq]
            rows_h, cols_h = rows[any_hit][sq], cols[any_hit][sq]
            rp, cp = rows_h[np.arange(j.size), j - 1], cols_h[np.arange(j.size), j - 1]
            rn, cn = rows_h[np.arange(j.size), j], cols_h[np.arange(j.size), j]
            b = idx[sq]
            t_corner[b] = (np.maximum(cp, cn) - ox[b]) * dx[b] + (np.maximum(rp, rn) - oy[b]) * dy[b]
            hr[b], hc[b] = rp, cn
        active = active[~any_hit]
        if active.size == 0:
            break
    # The samples may step over the corner of an occupied cell just before the first occupied sample: the
    # exact range is the earliest slab entry among the hit cell and its 8 neighbours that the ray crosses.
    enter = np.full(dx.shape, np.inf)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            r, c = hr + dr, hc + dc
            ok = (r >= 0) & (r < grid.height) & (c >= 0) & (c < grid.width)
            occ_rc = np.ones(dx.shape, bool)
            occ_rc[ok] = ~free[r[ok], c[ok]]
            with np.errstate(divide="ignore", invalid="ignore"):
                tx0, tx1 = (c - ox) / dx, (c + 1 - ox) / dx
                ty0, ty1 = (r - oy) / dy, (r + 1 - oy) / dy
            # A zero direction component: inside the slab for all t, or never.
            in_x = (ox >= c) & (ox < c + 1)
            in_y = (oy >= r) & (oy < r + 1)
            lo_x = np.where(dx == 0, np.where(in_x, -np.inf, np.inf), np.minimum(tx0, tx1))
            hi_x = np.where(dx == 0, np.where(in_x, np.inf, -np.inf), np.maximum(tx0, tx1))
            lo_y = np.where(dy == 0, np.where(in_y, -np.inf, np.inf), np.minimum(ty0, ty1))
            hi_y = np.where(dy == 0, np.where(in_y, np.inf, -np.inf), np.maximum(ty0, ty1))
            t_in, t_out = np.maximum(lo_x, lo_y), np.minimum(hi_x, hi_y)
            crossed = occ_rc & hit & (t_in <= t_out) & (t_out >= 0)
            enter = np.where(crossed, np.minimum(enter, t_in), enter)
    enter = np.minimum(enter, t_corner)
    ranges = np.maximum(enter, 0.0) * res
    ranges = np.where(hit & (ranges <= spec.range_max_m), ranges, np.inf)
    return ranges.reshape(angles.shape).astype(np.float32)


def _goals(raster: PlanRaster, safe: BoolArray, clearance: F64) -> list[tuple[int, int]]:
    """Room goals snapped to the clearest safe cell within 1.5 m, then one goal per 3 m tile far from them."""
    grid = raster.grid
    score = np.where(safe, clearance, -1.0)
    half = int(np.ceil(1.5 / grid.resolution_m))
    rooms = grid.world_to_cell(raster.goals_m) if len(raster.goals_m) else np.zeros((0, 2), np.int64)
    rr, cc = np.meshgrid(np.arange(half, grid.height, 2 * half), np.arange(half, grid.width, 2 * half))
    tiles = np.stack([rr.ravel(), cc.ravel()], 1)
    goals: list[tuple[int, int]] = []
    for k, (r, c) in enumerate(np.concatenate([rooms, tiles])):
        win = score[max(r - half, 0) : r + half + 1, max(c - half, 0) : c + half + 1]
        if not (win.size and win.max() > 0):
            continue
        wr, wc = np.unravel_index(int(np.argmax(win)), win.shape)
        g = (int(wr) + max(int(r) - half, 0), int(wc) + max(int(c) - half, 0))
        if k >= len(rooms) and goals and np.hypot(*(np.asarray(goals) - g).T).min() <= 2 * half:
            continue  # a tile already covered by a goal within 3 m
        goals.append(g)
    return list(dict.fromkeys(goals))


def safe_region(raster: PlanRaster, config: SimConfig, at_xy_m: F64 | None = None) -> tuple[BoolArray, F64]:
    """Where the robot may be: the connected region (H, W) of cells whose wall clearance exceeds the robot radius
    plus the margin that holds ``at_xy_m`` (2,), or the largest such region without it, and the clearance (H, W) in
    metres to the nearest occupied cell centre.

    Raises:
        ValueError: no cell is wide enough for the robot, or ``at_xy_m`` is not one of them.
    """
    clearance = ndimage.distance_transform_edt(raster.free) * raster.grid.resolution_m
    safe = clearance > config.robot_radius_m + config.margin_m
    labels, n = ndimage.label(safe)
    if n == 0:
        raise ValueError(f"{raster.name}: no place wide enough for a robot of radius {config.robot_radius_m} m")
    if at_xy_m is None:
        return labels == 1 + int(np.argmax(ndimage.sum(safe, labels, range(1, n + 1)))), clearance
    rc = raster.grid.world_to_cell(np.asarray(at_xy_m, np.float64))
    row, col = int(rc[0]), int(rc[1])
    if not (raster.grid.contains(rc) and safe[row, col]):
        cells = np.argwhere(safe)
        near = raster.grid.cell_to_world(cells[np.argmin(np.hypot(*(cells - [row, col]).T))])
        raise ValueError(f"{raster.name}: a robot of radius {config.robot_radius_m:g} m (and {config.margin_m:g} m "
                         f"to spare) does not fit at ({at_xy_m[0]:g}, {at_xy_m[1]:g}) m; the nearest place it fits is "
                         f"({near[0]:.2f}, {near[1]:.2f}) m")
    return labels == labels[row, col], clearance


def _plan_path(raster: PlanRaster, config: SimConfig, rng: np.random.Generator) -> F64:
    """A collision-free exploration path (P, 2) in metres through the room goals, nearest goal first."""
    safe, clearance = safe_region(raster, config)
    pref = config.robot_radius_m + 0.4
    cost = np.where(safe, 1.0 + 4.0 * np.clip((pref - clearance) / 0.4, 0.0, 1.0), np.inf)
    cells = np.flatnonzero(safe)
    cur = divmod(int(cells[rng.integers(cells.size)]), raster.free.shape[1])
    pending = [g for g in _goals(raster, safe, clearance) if safe[g]]
    path = [cur]
    while pending:
        mcp = MCP_Geometric(cost)
        costs, _ = mcp.find_costs([cur], ends=pending, find_all_ends=False)
        best = min(pending, key=lambda g: costs[g])
        if not np.isfinite(costs[best]):
            break
        path += [tuple(p) for p in mcp.traceback(best)[1:]]
        pending = [g for g in pending if g != best]
        cur = best
    return raster.grid.cell_to_world(np.asarray(path, dtype=np.int64))


def drive(pose: F64, v_m_s: float, w_rad_s: float, dt_s: float) -> F64:
    """The pose (3,) after driving ``dt_s`` at speed ``v_m_s`` and turn rate ``w_rad_s`` (one Euler step)."""
    out = pose + np.array([v_m_s * np.cos(pose[2]) * dt_s, v_m_s * np.sin(pose[2]) * dt_s, w_rad_s * dt_s])
    out[2] = float(wrap_angle(out[2]))
    return out


def path_done(pose: F64, path_m: F64, carrot: int) -> bool:
    """True once the carrot sits on the path's last point and the robot is within 0.1 m of it."""
    last = len(path_m) - 1
    return carrot == last and bool(np.hypot(*(path_m[last] - pose[:2])) < 0.1)


def follow_step(pose: F64, path_m: F64, carrot: int, config: SimConfig) -> tuple[F64, int, F64]:
    """One frame of carrot following from ``pose`` (3,) along ``path_m`` (P, 2): the pose after the frame, the
    carrot's index, and the commands ``[v_m_s, w_rad_s]`` (S, 2) of the frame's S substeps (each ``1 / (S ·
    scan_rate_hz)`` s; fewer when the carrot is reached).

    The carrot moves monotonically along the path, staying ``lookahead_m`` ahead of the robot; the robot turns
    in place when the carrot is more than 0.6 rad off its heading, else drives toward it.
    """
    substeps = 5
    h = 1.0 / config.scan_rate_hz / substeps
    last = len(path_m) - 1
    commands: list[tuple[float, float]] = []
    for _ in range(substeps):
        while carrot < last and np.hypot(*(path_m[carrot] - pose[:2])) < config.lookahead_m:
            carrot += 1
        target = path_m[carrot]
        dist = float(np.hypot(*(target - pose[:2])))
        if dist < 0.02:
            break
        err = float(wrap_angle(np.arctan2(target[1] - pose[1], target[0] - pose[0]) - pose[2]))
        v = 0.0 if abs(err) > 0.6 else min(config.speed_m_s * np.cos(err), dist / h)
        w = float(np.clip(2.0 * err, -config.turn_rate_rad_s, config.turn_rate_rad_s))
        commands.append((v, w))
        pose = drive(pose, v, w, h)
    return pose, carrot, np.asarray(commands, np.float64).reshape(-1, 2)


def _follow(path_m: F64, config: SimConfig, rng: np.random.Generator) -> F64:
    """Carrot following along the path (:func:`follow_step`): true poses (N, 3), one per frame."""
    n_max = int(config.max_duration_s * config.scan_rate_hz)
    start_dir = path_m[min(5, len(path_m) - 1)] - path_m[0]
    yaw0 = float(np.arctan2(start_dir[1], start_dir[0])) if np.any(start_dir) else float(rng.random() * 2 * np.pi)
    pose = np.array([path_m[0, 0], path_m[0, 1], yaw0])
    k, poses = 0, [pose.copy()]
    while len(poses) < n_max:
        if path_done(pose, path_m, k):
            break
        pose, k, _ = follow_step(pose, path_m, k, config)
        poses.append(pose.copy())
    return np.asarray(poses)


@dataclass(frozen=True)
class OdometryBias:
    """A run's systematic odometry errors, drawn once (:func:`draw_odometry_bias`)."""

    scale: float
    """Factor on every translation (1: none)."""
    yaw_bias_rad_per_m: float
    """Heading error added per metre driven."""


def draw_odometry_bias(noise: OdometryNoise, rng: np.random.Generator) -> OdometryBias:
    """A run's wheel-scale error and yaw bias per metre (two standard normals from ``rng``)."""
    scale = 1.0 + noise.scale_std * rng.standard_normal()
    return OdometryBias(scale, noise.yaw_bias_std_rad_per_m * rng.standard_normal())


def noisy_motion(step: F64, normals: F64, bias: OdometryBias, noise: OdometryNoise) -> tuple[F64, F64, F64]:
    """Thrun's odometry model: the true motions (N, 3) in the robot frame as measured (rot1, trans, rot2), each
    (N,), given standard normals (3, N) for rot1, rot2 and trans, and the run's bias."""
    trans = np.hypot(step[:, 0], step[:, 1])
    rot1 = np.where(trans > 1e-6, np.arctan2(step[:, 1], step[:, 0]), 0.0)
    rot2 = wrap_angle(step[:, 2] - rot1)
    rot1_n = rot1 + normals[0] * (noise.rot_per_rot * np.abs(rot1) + noise.rot_per_m * trans)
    rot2_n = rot2 + normals[1] * (noise.rot_per_rot * np.abs(rot2) + noise.rot_per_m * trans)
    sd_t = noise.trans_per_m * trans + noise.trans_per_rot * (np.abs(rot1) + np.abs(rot2))
    trans_n = bias.scale * trans + normals[2] * sd_t
    rot2_n = rot2_n + bias.yaw_bias_rad_per_m * trans
    return rot1_n, trans_n, rot2_n


def integrate_odometry(start: F64, rot1: F64, trans: F64, rot2: F64) -> F64:
    """Odometry poses (N + 1, 3) from ``start`` (3,) and N measured motions (each (N,), see :func:`noisy_motion`)."""
    odo = [start]
    for k in range(len(trans)):
        d = np.array([trans[k] * np.cos(rot1[k]), trans[k] * np.sin(rot1[k]), rot1[k] + rot2[k]])
        odo.append(compose(odo[-1], d))
    return np.asarray(odo)


def _odometry(truth: F64, noise: OdometryNoise, rng: np.random.Generator) -> F64:
    """Drifting odometry (N, 3) from true poses, starting at the true start pose."""
    bias = draw_odometry_bias(noise, rng)
    step = relative(truth[:-1], truth[1:])  # (N-1, 3) true motion in the robot frame
    n = len(step)
    normals = np.stack([rng.normal(0.0, 1.0, n) for _ in range(3)])  # rot1, rot2, trans
    return integrate_odometry(truth[0], *noisy_motion(step, normals, bias, noise))


def add_range_noise(ranges_m: NDArray[np.float32], lidar: LidarConfig, rng: np.random.Generator) -> None:
    """Adds Gaussian noise to the finite ranges (F, B), in place, then drops beams (``dropout_prob``) and those
    outside the range interval (set to ``inf``)."""
    finite = np.isfinite(ranges_m)
    ranges_m[finite] += rng.normal(0.0, lidar.noise_std_m, int(finite.sum())).astype(np.float32)
    drop = rng.random(ranges_m.shape) < lidar.dropout_prob
    ranges_m[drop | (ranges_m < lidar.range_min_m) | (ranges_m > lidar.range_max_m)] = np.inf


def simulate(raster: PlanRaster, config: SimConfig | None = None, seed: int = 0) -> SimResult:
    """Runs the robot through the plan (see the module docstring); deterministic per ``seed``."""
    cfg = config or SimConfig()
    rng = np.random.default_rng(seed)
    truth = _follow(_plan_path(raster, cfg, rng), cfg, rng)  # (N, 3)
    odo = _odometry(truth, cfg.odometry, rng)
    spec = cfg.lidar.spec()
    laser = compose(truth, spec.base_to_laser.as_array()[None, :])
    ranges = np.concatenate(
        [cast_rays(raster.free, raster.grid, laser[i : i + 16], spec) for i in range(0, len(laser), 16)]
    )
    add_range_noise(ranges, cfg.lidar, rng)
    stamps = cfg.start_stamp_ns + (np.arange(len(truth)) * (1e9 / cfg.scan_rate_hz)).astype(np.int64)
    frames = [
        Frame(int(stamps[i]), Scan(ranges[i].astype(np.float32), spec), Pose2D.from_array(odo[i]))
        for i in range(len(truth))
    ]
    g = raster.grid
    gt_map = GroundTruthMap(
        int(stamps[0]), g.resolution_m, g.origin_x_m, g.origin_y_m, np.where(raster.free, 0, 100).astype(np.int8)
    )
    return SimResult(frames, Trajectory(stamps, truth), Trajectory(stamps.copy(), odo), gt_map, raster, seed)


def write_sim_log(
    result: SimResult, path: str | os.PathLike[str], fmt: str | None = None, overwrite: bool = False
) -> Path:
    """Writes a simulated run with :func:`mcnkit.io.write_log` (format from the suffix unless ``fmt``; parents made)."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    return write_log(out, result.to_log_content(), fmt, overwrite=overwrite)
