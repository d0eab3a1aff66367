"""Rerun recordings of SLAM runs, read back with rerun's own reader."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rerun as rr
from rerun.chunk import RrdReader

from mcnkit.sim import SimConfig, plan_raster, simulate
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.types import TernaryMap
from mcnkit.viz import RerunLogger

N_PARTICLES = 8


@pytest.fixture(scope="module")
def sim_run():  # type: ignore[no-untyped-def]
    return simulate(plan_raster("procedural:1", 0.05, None), SimConfig(max_duration_s=12.0), seed=0)


def _record(path: Path, sim_run, stop_after: int | None = None) -> tuple[int, int]:  # type: ignore[no-untyped-def]
    """Records a FastSLAM run; returns (steps, filter updates)."""
    rr.set_strict_mode(True)
    slam = FastSlam(SlamConfig(n_particles=N_PARTICLES), np.random.default_rng(0))
    n = 0
    with RerunLogger(path, recording_id="test-run") as viz:
        raster = sim_run.raster
        viz.log_ground_truth(TernaryMap(np.where(raster.free, 0.0, 1.0).astype(np.float32), raster.grid))
        for frame in sim_run.frames:
            if stop_after is not None and n == stop_after:
                raise KeyboardInterrupt
            step = slam.step(frame)
            viz.log_slam_step(frame, step, slam.trajectory().poses[:, :2] if step.updated else None)
            if step.updated:
                viz.log_map("/world/map/estimate", slam.best_ternary(), mask=True)
            n += 1
    return n, slam.n_updates


def test_a_recording_holds_every_step_and_its_blueprint(tmp_path: Path, sim_run) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "run.rrd"
    n, updates = _record(path, sim_run)
    reader = RrdReader(path)
    assert [s.application_id for s in reader.recordings()] == ["mcnkit"]
    assert len(reader.blueprints()) == 1
    store = reader.stream().collect()
    entities = {chunk.entity_path for chunk in store.stream()}
    assert {"/world/particles", "/world/robot/pose", "/world/scan/hits", "/world/map/estimate",
            "/world/map/gt", "/metrics/n_eff", "/log"} <= entities
    table = store.reader(index="step", contents="/world/particles").to_arrow_table()
    assert table.num_rows == n == len(sim_run.frames)
    positions = table.column("/world/particles:Points2D:positions")
    assert all(len(positions[i].values) == N_PARTICLES for i in range(table.num_rows))
    weights = table.column("/world/particles:weight")
    assert np.isclose(np.asarray(weights[0].values).sum(), 1.0)
    # one N_eff value and one text line per filter update, on the steps of those updates
    n_eff = store.reader(index="step", contents="/metrics/n_eff").to_arrow_table()
    log = store.reader(index="step", contents="/log").to_arrow_table()
    assert n_eff.num_rows == log.num_rows == updates
    assert "filter update" in str(log.column("/log:TextLog:text")[0])
    verify = subprocess.run([sys.executable, "-m", "rerun", "rrd", "verify", str(path)], capture_output=True, text=True)
    assert verify.returncode == 0, verify.stderr


def test_an_interrupted_run_still_leaves_a_readable_recording(tmp_path: Path, sim_run) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "interrupted.rrd"
    with pytest.raises(KeyboardInterrupt):
        _record(path, sim_run, stop_after=25)
    store = RrdReader(path).stream().collect()
    table = store.reader(index="step", contents="/world/particles").to_arrow_table()
    assert table.num_rows == 25
