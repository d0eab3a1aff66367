"""The robot simulator: determinism, exact lidar on a hand-made room, drifting odometry, logs read back."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy import ndimage

from mcnkit.app.commands.simulate import add_simulate_parser
from mcnkit.geometry import compose, relative
from mcnkit.io import open_log
from mcnkit.sim import (
    LidarConfig,
    OdometryNoise,
    PlanRaster,
    SimConfig,
    SimResult,
    cast_rays,
    draw_odometry_bias,
    follow_step,
    integrate_odometry,
    noisy_motion,
    path_done,
    plan_raster,
    simulate,
    write_sim_log,
)
from mcnkit.types import GridSpec, LidarSpec

SHORT = SimConfig(max_duration_s=30.0)


@pytest.fixture(scope="module")
def run() -> SimResult:
    return simulate(plan_raster("procedural:4"), SHORT, seed=1)


def _room() -> PlanRaster:
    """A 4 m × 3 m room of free cells [0, 4) × [0, 3) with 1 m of occupied exterior, at 0.05 m."""
    grid = GridSpec(0.05, -1.0, -1.0, 120, 100)
    free = np.zeros(grid.shape, bool)
    free[20:80, 20:100] = True
    return PlanRaster("room", free, grid, np.array([[2.0, 1.5]]))


def test_lidar_matches_exact_ray_casting_in_a_room() -> None:
    room = _room()
    spec = LidarSpec(-np.pi, 2 * np.pi / 360, 360, 0.1, 8.0)
    pose = np.array([[1.3, 1.1, 0.4]])
    ranges = cast_rays(room.free, room.grid, pose, spec)[0].astype(np.float64)
    a = pose[0, 2] + spec.angles_rad
    dx, dy = np.cos(a), np.sin(a)
    with np.errstate(divide="ignore"):
        tx = np.where(dx > 0, (4.0 - 1.3) / dx, (0.0 - 1.3) / dx)
        ty = np.where(dy > 0, (3.0 - 1.1) / dy, (0.0 - 1.1) / dy)
    expected = np.minimum(np.abs(tx), np.abs(ty))
    np.testing.assert_allclose(ranges, expected, atol=1e-4)
    short = LidarSpec(-np.pi, 2 * np.pi / 360, 360, 0.1, 1.5)
    far = cast_rays(room.free, room.grid, pose, short)[0]
    assert np.all(np.isinf(far[expected > 1.5])) and np.allclose(
        far[expected < 1.45], expected[expected < 1.45], atol=1e-4
    )


def test_a_slanted_wall_one_pixel_thick_stops_every_beam() -> None:
    room = _room()
    free = room.free.copy()
    k = np.arange(60)
    free[20 + k, 99 - k] = False  # a wall at 45° across the room, its pixels touching only at their corners
    spec = LidarSpec(-np.pi, 2 * np.pi / 7200, 7200, 0.1, 8.0)
    for pose in ([1.0, 0.8, 0.0], [0.4, 2.1, 1.0], [2.3, 0.3, -2.0]):
        ranges = cast_rays(free, room.grid, np.array([pose]), spec)[0].astype(np.float64)
        a = pose[2] + spec.angles_rad
        x, y = pose[0] + ranges * np.cos(a), pose[1] + ranges * np.sin(a)
        # the wall's pixels span x + y in [3.95, 4.05]; its near side, corners included, x + y in [3.95, 4.0]
        assert np.isfinite(ranges).all() and (x + y).max() <= 4.0 + 1e-6
        assert ((x + y) >= 3.95 - 1e-6).sum() > 1000  # the wall is seen, not only the room's walls before it


def test_deterministic_per_seed(run: SimResult) -> None:
    again = simulate(plan_raster("procedural:4"), SHORT, seed=1)
    other = simulate(plan_raster("procedural:4"), SHORT, seed=2)
    np.testing.assert_array_equal(run.ground_truth.poses, again.ground_truth.poses)
    np.testing.assert_array_equal(run.odometry.poses, again.odometry.poses)
    for f, g in zip(run.frames, again.frames, strict=True):
        np.testing.assert_array_equal(f.scan.ranges_m, g.scan.ranges_m)
        assert f.stamp_ns == g.stamp_ns and f.odom == g.odom
    assert not np.array_equal(run.ground_truth.poses[:10], other.ground_truth.poses[:10])


def test_ground_truth_collision_free_and_moving(run: SimResult) -> None:
    r = run.raster
    clearance = ndimage.distance_transform_edt(r.free) * r.grid.resolution_m
    rc = r.grid.world_to_cell(run.ground_truth.poses[:, :2])
    assert clearance[rc[:, 0], rc[:, 1]].min() > SHORT.robot_radius_m
    steps = np.hypot(*np.diff(run.ground_truth.poses[:, :2], axis=0).T)
    assert steps.max() <= SHORT.speed_m_s / SHORT.scan_rate_hz + 1e-9
    assert steps.sum() > 5.0
    assert len(run.frames) == 300 and np.all(np.diff(run.ground_truth.stamps_ns) == 100_000_000)


def test_scans_agree_with_the_map(run: SimResult) -> None:
    r = run.raster
    hits = []
    for frame, pose in zip(run.frames[::10], run.ground_truth.poses[::10], strict=True):
        spec = frame.scan.spec
        laser = compose(pose, spec.base_to_laser.as_array())
        ok = frame.scan.valid
        a = laser[2] + spec.angles_rad[ok]
        rng = frame.scan.ranges_m[ok] + 0.03  # just behind the surface
        pts = laser[:2] + np.stack([rng * np.cos(a), rng * np.sin(a)], 1)
        rc = r.grid.world_to_cell(pts)
        hits.append(~r.free[rc[:, 0], rc[:, 1]])
    assert np.concatenate(hits).mean() > 0.95


def test_odometry_drifts(run: SimResult) -> None:
    gt, odo = run.ground_truth.poses, run.odometry.poses
    np.testing.assert_array_equal(odo[0], gt[0])
    err = np.hypot(*(odo[:, :2] - gt[:, :2]).T)
    assert err[-1] > 0.01 and err[-1] < 0.15 * np.hypot(*np.diff(gt[:, :2], axis=0).T).sum()
    perfect = simulate(
        plan_raster("procedural:4"),
        SimConfig(max_duration_s=30.0, odometry=OdometryNoise(0, 0, 0, 0, 0, 0)),
        seed=1,
    )
    np.testing.assert_allclose(perfect.odometry.poses, perfect.ground_truth.poses, atol=1e-9)


def test_lidar_config() -> None:
    spec = LidarConfig(n_beams=181, fov_deg=180.0).spec()
    assert spec.angle_min_rad == pytest.approx(-np.pi / 2) and spec.angle_max_rad == pytest.approx(np.pi / 2)
    full = LidarConfig(n_beams=360, fov_deg=360.0).spec()
    assert full.angle_max_rad == pytest.approx(np.pi - np.deg2rad(1.0))


@pytest.mark.parametrize("name", ["run.bag", "run.mcap", "run_dir"])
def test_written_and_read_back(run: SimResult, tmp_path: Path, name: str) -> None:
    path = write_sim_log(run, tmp_path / name)
    with open_log(path) as log:
        topics = {t.name: t.count for t in log.topics}
        frames = list(log.frames())
        gt = log.ground_truth()
        gmap = log.ground_truth_map()
    assert topics["/scan"] == topics["/odom"] == topics["/ground_truth"] == len(run.frames)
    assert topics["/tf_static"] == 1 and topics["/map_gt"] == 1 and topics["/tf"] >= len(run.frames)
    assert len(frames) == len(run.frames)
    for a, b in zip(frames, run.frames, strict=True):
        assert a.stamp_ns == b.stamp_ns
        np.testing.assert_array_equal(a.scan.ranges_m, b.scan.ranges_m)
        assert a.odom.x_m == pytest.approx(b.odom.x_m) and a.odom.yaw_rad == pytest.approx(b.odom.yaw_rad)
    assert gt is not None and gmap is not None
    np.testing.assert_allclose(gt.poses, run.ground_truth.poses, atol=1e-9)
    np.testing.assert_array_equal(gmap.data, run.gt_map.data)


def test_houseexpo_plan(shared_data: Path) -> None:
    archive = shared_data / "houseexpo" / "json.tar.gz"
    raster = plan_raster("houseexpo:d398cc42034810e0bef66fe9c27e282e", 0.05, archive)
    result = simulate(raster, SimConfig(max_duration_s=10.0), seed=0)
    assert len(result.frames) == 100 and result.gt_map.data.shape == raster.free.shape
    with pytest.raises(ValueError, match="unknown id"):
        plan_raster("houseexpo:0123", 0.05, archive)


def _cli(argv: list[str]) -> int:
    parser = argparse.ArgumentParser()
    add_simulate_parser(parser.add_subparsers(dest="command"))
    args = parser.parse_args(argv)
    return int(args.func(args))


def test_cli(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "sim.mcap"
    assert _cli(["simulate", "--map", "procedural:2", "--out", str(out), "--duration", "5", "--beams", "90"]) == 0
    with open_log(out) as log:
        assert log.lidar_spec.n_beams == 90
    pixels = np.zeros((50, 70), np.uint8)
    pixels[5:45, 5:65] = 255
    png = _image(tmp_path / "plan.png", pixels)
    assert _cli(["simulate", "--map", f"image:{png}", "--out", str(tmp_path / "img.mcap"), "--duration", "2",
                 "--resolution", "0.1"]) == 0
    with open_log(tmp_path / "img.mcap") as log:
        gmap = log.ground_truth_map()
        assert gmap is not None and gmap.resolution_m == pytest.approx(0.1)
    assert _cli(["simulate", "--map", "nowhere:1", "--out", str(tmp_path / "x.bag")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "houseexpo:ID, procedural:SEED or image:FILE" in err[0]


def test_one_frame_at_a_time_is_the_same_robot(run: SimResult) -> None:
    """The step functions a planning robot uses drive and measure exactly as the batch simulation does."""
    truth = run.ground_truth.poses
    path = truth[::5, :2]
    pose, k, commands = follow_step(truth[0], path, 0, SHORT)
    assert commands.shape[1] == 2 and len(commands) <= 5 and k >= 0
    assert np.hypot(*(pose[:2] - truth[0, :2])) <= SHORT.speed_m_s / SHORT.scan_rate_hz + 1e-9
    assert not path_done(truth[0], path, 0) and path_done(np.array([*path[-1], 0.0]), path, len(path) - 1)
    noise = SHORT.odometry
    rng = np.random.default_rng(7)
    bias = draw_odometry_bias(noise, rng)
    normals = rng.standard_normal((3, len(truth) - 1))
    step = relative(truth[:-1], truth[1:])
    batch = integrate_odometry(truth[0], *noisy_motion(step, normals, bias, noise))
    odo = truth[0]
    for i in range(len(step)):
        odo = integrate_odometry(odo, *noisy_motion(step[i : i + 1], normals[:, i : i + 1], bias, noise))[-1]
    np.testing.assert_allclose(odo, batch[-1], atol=1e-12)


def _image(path: Path, pixels: np.ndarray) -> Path:
    Image.fromarray(pixels.astype(np.uint8)).save(path)
    return path


def test_image_plan_without_yaml(tmp_path: Path) -> None:
    pixels = np.zeros((40, 60), np.uint8)  # walls
    pixels[5:35, 5:55] = 255  # a 5 m × 3 m room at 0.1 m
    pixels[5, 5] = 205  # map_server's "unknown" grey: not free
    png = _image(tmp_path / "room.png", pixels)
    raster = plan_raster(f"image:{png}", 0.1)
    border = 10
    assert raster.grid.resolution_m == 0.1 and raster.free.shape == (40 + 2 * border, 60 + 2 * border)
    assert raster.grid.origin_x_m == pytest.approx(-1.0) and raster.free.sum() == 30 * 50 - 1
    top_left = raster.grid.world_to_cell(np.array([0.55, 3.45]))  # image row 5 is the room's top (highest y)
    assert not raster.free[top_left[0], top_left[1]] and raster.free[top_left[0], top_left[1] + 1]
    result = simulate(raster, SimConfig(max_duration_s=3.0), seed=0)
    assert len(result.frames) == 30 and np.isfinite(result.frames[0].scan.ranges_m).any()


def test_image_plan_with_a_map_server_yaml(tmp_path: Path) -> None:
    pixels = np.full((30, 30), 255, np.uint8)
    pixels[10:20, 10:20] = 0  # negated below: this square is the free space
    pgm = _image(tmp_path / "lab.pgm", pixels)
    (tmp_path / "lab.yaml").write_text("image: lab.pgm\nresolution: 0.05\norigin: [2.0, -1.0, 0.0]\nnegate: 1\n"
                                       "occupied_thresh: 0.65\nfree_thresh: 0.196\n")
    raster = plan_raster(f"image:{pgm}", 0.2)
    assert raster.grid.resolution_m == 0.05 and raster.free.sum() == 100
    assert raster.grid.origin_x_m == pytest.approx(1.0) and raster.grid.origin_y_m == pytest.approx(-2.0)
    (tmp_path / "lab.yaml").write_text("image: lab.pgm\norigin: [0, 0, 0]\n")
    with pytest.raises(ValueError, match="resolution"):
        plan_raster(f"image:{pgm}")
    with pytest.raises(ValueError, match="not a readable occupancy image"):
        plan_raster(f"image:{tmp_path / 'missing.png'}")
    with pytest.raises(ValueError, match="no free pixel"):
        plan_raster(f"image:{_image(tmp_path / 'black.png', np.zeros((5, 5)))}")


def test_an_image_plan_on_a_light_background_is_its_inside(tmp_path: Path) -> None:
    """A floor plan drawn black on white is white outside the building too: that space is left out (with a warning),
    so the robot starts and drives inside, never round the outside walls."""
    pixels = np.full((80, 100), 255, np.uint8)  # 10 × 8 m at 0.1 m
    pixels[20:60, 20:80] = 0
    pixels[21:59, 21:79] = 255  # a 5.8 × 3.8 m room, walls one pixel thick
    pixels[59, 40:48] = 255  # its door, 0.8 m, to the outside
    png = _image(tmp_path / "plan.png", pixels)
    with pytest.warns(UserWarning, match="outside the building's walls"):
        raster = plan_raster(f"image:{png}", 0.1)
    border = 10
    room = np.zeros((80, 100), bool)
    room[21:59, 21:79] = True
    inside = raster.free[border:-border, border:-border][::-1]  # back to image rows
    assert not (inside & ~room).any() and inside[room].mean() > 0.97  # the room, but for its doorway
    result = simulate(raster, SimConfig(max_duration_s=5.0), seed=3)
    xy = result.ground_truth.poses[:, :2]
    assert ((xy > [2.1, 2.1]) & (xy < [7.9, 5.9])).all()
