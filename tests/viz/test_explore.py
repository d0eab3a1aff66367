"""Exploration recordings, their blueprint, figures and the notebook stepper, on two small rooms."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import rerun as rr
import torch
from rerun.chunk import RrdReader

from mcnkit.completion.nets import UNet, UNetConfig
from mcnkit.explore import ExploreConfig, Explorer, FrontierPlanner, GainConfig, McnPlanner
from mcnkit.sim import PlanRaster
from mcnkit.viz.blueprints import recording_blueprint
from mcnkit.viz.explore import ExploreRecorder, score_colors
from mcnkit.viz.widgets import ExploreStepper
from tests.explore.conftest import rooms

__all__ = ["rooms"]


def _mcn(rooms: PlanRaster, budget_m: float = 3.0) -> Explorer:
    net = UNet(UNetConfig(base_channels=4, depth=2, dropout=0.5, size=64)).eval()
    planner = McnPlanner(net, GainConfig(samples=2, beams=60), 8.0, torch.Generator().manual_seed(0))
    return Explorer(rooms, planner, ExploreConfig(budget_m=budget_m), seed=1)


def test_a_recording_holds_frames_plans_and_samples(tmp_path: Path, rooms: PlanRaster) -> None:
    rr.set_strict_mode(True)
    ex = _mcn(rooms)
    path = tmp_path / "explore.rrd"
    rec = ExploreRecorder(path, ex, samples=2, recording_id="test")
    rec.on_frame(ex.records[0])
    while not ex.done:
        rec.on_frame(ex.step())
    rec.close()
    store = RrdReader(path).stream().collect()
    entities = {chunk.entity_path for chunk in store.stream()}
    assert {"/world/map/gt", "/world/map/reachable", "/world/map/seen", "/world/map/estimate", "/world/plan/frontiers",
            "/world/plan/viewpoints", "/world/plan/goal", "/world/plan/path", "/world/pred/window/partial",
            "/world/pred/window/sample0", "/world/pred/window/sample1", "/world/pred/window/disagreement",
            "/world/pred/window/view", "/world/robot/estimate", "/world/robot/truth", "/metrics/coverage",
            "/metrics/plan_cpu_ms", "/log"} <= entities
    coverage = store.reader(index="step", contents="/metrics/coverage").to_arrow_table()
    assert coverage.num_rows == ex.n_frames
    log = store.reader(index="step", contents="/log").to_arrow_table()
    assert log.num_rows == len(ex.plans) and "viewpoints" in str(log.column("/log:TextLog:text")[0])
    verify = subprocess.run([sys.executable, "-m", "rerun", "rrd", "verify", str(path)], capture_output=True, text=True)
    assert verify.returncode == 0, verify.stderr
    blueprint = recording_blueprint(entities)
    assert blueprint is not None


def test_score_colours_rank_the_scores() -> None:
    colors = score_colors(np.array([0.5, -2.0, 3.0]))
    assert colors.shape == (3, 3) and colors.dtype == np.uint8
    assert tuple(colors[2]) == (253, 231, 37) and tuple(colors[1]) == (68, 1, 84)


def test_the_stepper_shows_both_planners_and_why(rooms: PlanRaster, tmp_path: Path) -> None:
    stepper = ExploreStepper({"frontier": Explorer(rooms, FrontierPlanner(), ExploreConfig(budget_m=3.0), seed=1),
                              "mcn": _mcn(rooms)}, tmp_path / "explore")
    stepper.next_plan()
    assert all(d is not None for d in stepper.decisions.values())
    why = stepper.why("mcn")
    assert "gain [m²]" in why and "<b>" in why
    fig = stepper.figure()
    assert len(fig.axes) >= 3 + 3  # two plans and the coverage; the window, the disagreement, a sample
    stepper.step(5)
    stepper.run()
    assert stepper.done and ("budget" in stepper.status() or "coverage" in stepper.status())
    assert (tmp_path / "explore_mcn.rrd").is_file() and (tmp_path / "explore_frontier.rrd").is_file()
    assert len(stepper.coverage().axes) == 1
    widget = stepper.widget()
    assert len(widget.children) == 4


def test_a_collision_is_recorded_where_the_robot_felt_the_wall(tmp_path: Path, rooms: PlanRaster) -> None:
    low = np.zeros_like(rooms.free)
    low[38:62, 99:103] = True  # the door barred below the lidar's plane
    ex = Explorer(rooms, FrontierPlanner(), ExploreConfig(budget_m=6.0), seed=2, low_obstacles=low)
    path = tmp_path / "bump.rrd"
    rec = ExploreRecorder(path, ex, recording_id="bump")
    while not ex.done:
        rec.on_frame(ex.step())
    rec.close()
    assert ex.n_collisions > 0
    store = RrdReader(path).stream().collect()
    contacts = store.reader(index="step", contents="/world/robot/contacts").to_arrow_table()
    assert contacts.num_rows == len({frame for frame, _ in ex.contacts})
    log = store.reader(index="step", contents="/log").to_arrow_table()
    assert sum("collision" in str(t) for t in log.column("/log:TextLog:text").to_pylist()) == ex.n_collisions
