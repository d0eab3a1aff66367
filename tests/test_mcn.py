"""MCN-SLAM: lineage maps, windows, completion inside the filter, its recording and the ``mcnkit run`` command."""

from __future__ import annotations

import argparse
import dataclasses
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from rerun.chunk import RrdReader

from mcnkit.app.main import main
from mcnkit.completion.nets import UNet, UNetConfig
from mcnkit.completion.sample import inference_net
from mcnkit.geometry import compose
from mcnkit.grid import pool_to_window
from mcnkit.mcn import McnConfig, McnSlam, load_model, map_window, robot_window
from mcnkit.sim import SimConfig, SimResult, plan_raster, simulate, write_sim_log
from mcnkit.slam import SlamConfig, ray_cast_counts
from mcnkit.slam.lineage import LineageMap
from mcnkit.types import OCCUPIED, UNKNOWN, GridSpec, TernaryMap
from mcnkit.viz import run_mcn

N_PARTICLES = 8


@pytest.fixture(scope="module")
def sim_run() -> SimResult:
    return simulate(plan_raster("procedural:1", 0.05, None), SimConfig(max_duration_s=15.0), seed=0)


@pytest.fixture(scope="module")
def truth(sim_run: SimResult) -> TernaryMap:
    return TernaryMap(np.where(sim_run.raster.free, 0.0, 1.0).astype(np.float32), sim_run.raster.grid)


def tiny_net() -> UNet:
    torch.manual_seed(0)
    return UNet(UNetConfig(base_channels=4, max_channels=16, depth=3, dropout=0.5)).eval()


def _lineage(angles: np.ndarray) -> LineageMap:
    return LineageMap(0.05, angles, np.zeros(3), max_range_m=8.0, usable_m=6.0, occ_thresh=0.25)


def test_a_lineage_map_synced_to_other_poses_equals_their_ray_cast_map() -> None:
    rng = np.random.default_rng(0)
    angles = np.linspace(-np.pi, np.pi, 90, endpoint=False)
    ranges = [rng.uniform(0.5, 9.0, 90).astype(np.float32) for _ in range(12)]
    ranges[3][:10] = np.nan  # invalid beams are skipped
    a = np.cumsum(rng.normal(0, 0.3, (12, 3)), axis=0)
    b = a.copy()
    b[7:] += [0.4, -0.2, 0.1]  # another lineage: shares the first 7 poses
    lm = _lineage(angles)
    assert lm.sync(a[:9], ranges) == 9
    assert lm.sync(b, ranges) == 2 * 2 + 3  # two changed scans out and in, three new
    spec, hits, passes = ray_cast_counts(b, np.stack(ranges), angles, 8.0, 6.0, 0.05)
    full = lm.ternary(crop=False)
    r0 = round((spec.origin_y_m - full.spec.origin_y_m) / 0.05)
    c0 = round((spec.origin_x_m - full.spec.origin_x_m) / 0.05)
    window = (slice(r0, r0 + spec.height), slice(c0, c0 + spec.width))
    np.testing.assert_array_equal(lm.hits[window], hits)
    np.testing.assert_array_equal(lm.passes[window], passes)
    assert int(lm.hits.sum()) == int(hits.sum()) and int(lm.passes.sum()) == int(passes.sum())


def test_the_network_window_is_the_map_pooled_with_walls_first() -> None:
    rng = np.random.default_rng(1)
    angles = np.linspace(-np.pi, np.pi, 180, endpoint=False)
    lm = _lineage(angles)
    lm.sync(np.array([[0.0, 0.0, 0.0], [1.0, 0.5, 0.3]]), [rng.uniform(1, 7, 180).astype(np.float32)] * 2)
    window = map_window(lm.seen_bounds_m(), 64, 0.0, 0.05)
    pooled = lm.pooled(window)
    np.testing.assert_array_equal(pooled, pool_to_window(lm.ternary(crop=False), window))
    x0, y0, x1, y1 = lm.seen_bounds_m()
    side = window.width * window.resolution_m
    assert side == pytest.approx(max(x1 - x0, y1 - y0))
    assert (pooled == OCCUPIED).any() and (pooled == UNKNOWN).any()
    full, coarse = lm.ternary(), lm.ternary(max_cells=1000)  # a big map is recorded pooled, walls first
    assert coarse.spec is not None and full.spec is not None
    assert coarse.image.size <= 1000 < full.image.size
    assert abs(coarse.spec.resolution_m / 0.05 - round(coarse.spec.resolution_m / 0.05)) < 1e-9
    assert (coarse.image == OCCUPIED).any()
    centred = robot_window(np.array([2.0, -1.0]), 64, 12.8)
    assert centred.origin_x_m + 6.4 == pytest.approx(2.0) and centred.resolution_m == pytest.approx(0.2)


def test_each_filter_update_completes_the_best_maps_in_one_forward_pass(sim_run: SimResult, truth: TernaryMap) -> None:
    net = tiny_net()
    calls: list[int] = []  # batch size of every forward pass (sampling runs the net's frozen inference copy)
    inference_net(net).register_forward_hook(lambda _m, inputs, _o: calls.append(int(inputs[0].shape[0])))
    mcn = McnSlam(SlamConfig(n_particles=N_PARTICLES), net, McnConfig(samples=4, ranks=3),
                  np.random.default_rng(0), ground_truth=truth)
    results = [mcn.step(f) for f in sim_run.frames]
    done = [r for r in results if r.completion is not None]
    assert len(done) == mcn.slam.n_updates == len(calls) and set(calls) == {3 * 4}
    c = done[-1].completion
    assert c is not None
    assert c.samples.shape == (3, 4, 64, 64) and c.partial.shape == (3, 64, 64)
    assert list(c.particles) == list(mcn.slam.ranking()[:3])
    observed = np.broadcast_to(c.partial[:, None], c.samples.shape)
    seen = observed != UNKNOWN
    assert np.array_equal(observed[seen], c.samples[seen])  # what was observed stays as observed
    assert (c.uncertainty >= 0).all() and (c.uncertainty <= 1).all() and c.uncertainty.max() > 0
    assert c.diversity[0] > 0  # dropout at inference: the samples differ
    assert {"f_slam", "f_completed", "miou_unknown"} <= set(done[-1].scores)
    assert done[-1].best_map is not None and done[-1].best_map.spec is not None
    assert all(r.completion is None for r in results if not r.slam.updated)


def test_the_shipped_unet_completes_the_first_view_of_an_apartment_better_than_slam_alone(
        sim_run: SimResult, truth: TernaryMap) -> None:
    mcn = McnSlam(SlamConfig(n_particles=N_PARTICLES), load_model("unet"), McnConfig(samples=2, ranks=1),
                  np.random.default_rng(0), ground_truth=truth)
    first = next(r for r in (mcn.step(f) for f in sim_run.frames) if r.completion is not None)
    assert first.scores["f_completed"] > first.scores["f_slam"] + 0.03


def test_completion_weighting_adds_a_term_to_the_particle_weights(sim_run: SimResult) -> None:
    plain = McnSlam(SlamConfig(n_particles=N_PARTICLES), tiny_net(), McnConfig(ranks=1), np.random.default_rng(3))
    weighted = McnSlam(SlamConfig(n_particles=N_PARTICLES), tiny_net(),
                       McnConfig(ranks=1, completion_weight=1.0), np.random.default_rng(3))
    assert len(weighted.lineages) == 0 and weighted.slam.extra_log_likelihood is not None
    for frame in sim_run.frames[:120]:
        plain.step(frame)
        weighted.step(frame)
    assert len(weighted.lineages) == N_PARTICLES
    assert not np.allclose(plain.slam.log_weight_sums, weighted.slam.log_weight_sums)


def test_the_completion_term_scores_end_points_by_the_completed_map() -> None:
    mcn = McnSlam(SlamConfig(n_particles=2), tiny_net(), McnConfig(completion_weight=2.0, hit_epsilon=0.1))
    window = GridSpec(1.0, 0.0, 0.0, 4, 4)
    p_occ = np.zeros((2, 4, 4), np.float32)
    p_occ[0, :, 3] = 1.0  # particle 0's completion has a wall at x in [3, 4)
    partial = np.full((2, 4, 4), UNKNOWN, np.float32)
    mcn._weighting = (p_occ, partial, (window, window))
    ends = np.array([[3.5, 1.5], [3.5, 2.5]])
    ll = mcn._completion_log_likelihood(np.zeros((2, 3)), ends)
    assert ll[0] == pytest.approx(2.0 * 2 * np.log(0.9)) and ll[1] == pytest.approx(2.0 * 2 * np.log(0.1))
    moved = mcn._completion_log_likelihood(np.array([[0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]), ends)
    assert moved[1] == pytest.approx(ll[1])  # particle 1 sees free space there too
    assert np.allclose(compose(np.zeros(3), np.array([1.0, 2.0, 0.0]))[:2], [1.0, 2.0])


def test_a_recording_holds_particles_samples_scores_and_the_blueprint(
        tmp_path: Path, sim_run: SimResult, truth: TernaryMap) -> None:
    path = tmp_path / "mcn.rrd"
    mcn = McnSlam(SlamConfig(n_particles=N_PARTICLES), tiny_net(), McnConfig(samples=3, ranks=2),
                  np.random.default_rng(0), ground_truth=truth)
    summary = run_mcn(sim_run.frames, mcn, rrd=path, recording_id="test-mcn", ground_truth=truth, progress=False)
    reader = RrdReader(path)
    assert len(reader.blueprints()) == 1
    store = reader.stream().collect()
    entities = {chunk.entity_path for chunk in store.stream()}
    expected = {"/world/particles", "/world/map/estimate", "/world/map/unknown_mask", "/world/map/gt",
                "/metrics/f_completed", "/metrics/f_slam", "/metrics/miou_unknown", "/metrics/sample_diversity"}
    expected |= {f"/world/mcn/rank{r}/window/{name}" for r in range(2)
                 for name in ("partial", "mean", "uncertainty", "sample0", "sample1", "sample2")}
    assert expected <= entities
    particles = store.reader(index="step", contents="/world/particles").to_arrow_table()
    assert particles.num_rows == summary.scans == len(sim_run.frames)
    positions = particles.column("/world/particles:Points2D:positions")
    assert all(len(positions[i].values) == N_PARTICLES for i in range(particles.num_rows))
    samples = []
    for k in range(3):
        t = store.reader(index="step", contents=f"/world/mcn/rank0/window/sample{k}").to_arrow_table()
        assert t.num_rows == summary.completions == mcn.slam.n_updates
        blob = t.column(f"/world/mcn/rank0/window/sample{k}:SegmentationImage:buffer")
        samples.append(np.asarray(blob[t.num_rows - 1].values[0].values))
    assert not np.array_equal(samples[0], samples[1]) or not np.array_equal(samples[1], samples[2])
    verify = subprocess.run([sys.executable, "-m", "rerun", "rrd", "verify", str(path)], capture_output=True, text=True)
    assert verify.returncode == 0, verify.stderr


def test_an_interrupted_mcn_run_still_leaves_a_readable_recording(tmp_path: Path, sim_run: SimResult) -> None:
    path = tmp_path / "interrupted.rrd"
    mcn = McnSlam(SlamConfig(n_particles=N_PARTICLES), tiny_net(), McnConfig(samples=2, ranks=1))

    def stop_at_30(_frame: object, result: object) -> None:
        if mcn.slam.n_scans == 30:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        run_mcn(sim_run.frames, mcn, rrd=path, progress=False, on_step=stop_at_30)
    table = RrdReader(path).stream().collect().reader(index="step", contents="/world/particles").to_arrow_table()
    assert table.num_rows == 30


def test_mcnkit_run_writes_a_recording_and_outputs(tmp_path: Path, sim_run: SimResult,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    log = write_sim_log(sim_run, tmp_path / "apartment.mcap", "mcap")
    code = main(["run", str(log), "--rrd", str(tmp_path / "run.rrd"), "--out", str(tmp_path / "out"),
                 "--samples", "2", "--ranks", "1", "--particles", "6", "--no-progress"])
    assert code == 0
    assert "completions (R=1 × K=2)" in capsys.readouterr().out
    for name in ("trajectory.tum", "map.png", "completion.png", "summary.json"):
        assert (tmp_path / "out" / name).is_file()
    assert (tmp_path / "run.rrd").stat().st_size > 0


def test_mcnkit_run_refuses_a_checkpoint_that_is_not_one(tmp_path: Path, sim_run: SimResult,
                                                         capsys: pytest.CaptureFixture[str]) -> None:
    bogus = tmp_path / "net.safetensors"
    bogus.write_bytes(b"not a checkpoint")
    code = main(["run", "whatever.mcap", "--model", str(bogus), "--rrd", str(tmp_path / "x.rrd")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "net" in err[0]


def test_mcnkit_run_takes_slam_and_mcn_flags_and_reruns_from_its_summary(tmp_path: Path, sim_run: SimResult) -> None:
    log = write_sim_log(sim_run, tmp_path / "apartment.mcap", "mcap")
    toml = tmp_path / "run.toml"
    toml.write_text("seed = 2\nmodel = 'unet'\n[mcn]\nsamples = 3\nranks = 1\ncompletion_weight = 0.5\n"
                    "[recording]\nflush_updates = 7\n")
    assert main(["run", str(log), "--config", str(toml), "--samples", "2", "--slam.n-particles", "5",
                 "--slam.updates.linear-m", "0.5", "--mcn.every", "2", "--mcn.window", "robot", "--no-progress",
                 "--out", str(tmp_path / "first"), "--rrd", str(tmp_path / "first.rrd")]) == 0
    summary = json.loads((tmp_path / "first" / "summary.json").read_text())
    assert summary["config"]["n_particles"] == 5 and summary["config"]["updates"]["linear_m"] == 0.5
    assert summary["seed"] == 2 and summary["interrupted"] is False and summary["model"] == "unet"
    mcn = summary["mcn"]  # file, then short flags, then --mcn.FIELD; run's own default for the map
    assert (mcn["samples"], mcn["ranks"], mcn["every"], mcn["window"], mcn["completion_weight"]) == (2, 1, 2, "robot", 0.5)
    assert mcn["full_map_every"] == 5 and len(mcn) == len(dataclasses.fields(McnConfig))
    assert summary["recording"]["flush_updates"] == 7
    table = RrdReader(tmp_path / "first.rrd").stream().collect().reader(index=None, contents="/config").to_arrow_table()
    document = json.loads(table.column("/config:TextDocument:text")[0].as_py()[0])
    assert {k: document[k] for k in ("config", "mcn", "recording", "model", "seed")} == \
        {k: summary[k] for k in ("config", "mcn", "recording", "model", "seed")}
    # the summary alone repeats the run: same settings, same model, same seed, same trajectory
    assert main(["run", str(log), "--config", str(tmp_path / "first" / "summary.json"), "--no-progress",
                 "--out", str(tmp_path / "again")]) == 0
    again = json.loads((tmp_path / "again" / "summary.json").read_text())
    assert (again["mcn"], again["config"], again["model"]) == (mcn, summary["config"], "unet")
    assert again["completions"] == summary["completions"]
    first_tum, again_tum = ((tmp_path / d / "trajectory.tum").read_bytes() for d in ("first", "again"))
    assert first_tum == again_tum
    other = tmp_path / "other"  # the MCN settings matter (completion weighting moves the particles)
    assert main(["run", str(log), "--config", str(tmp_path / "first" / "summary.json"), "--mcn.completion-weight",
                 "0", "--no-progress", "--out", str(other)]) == 0
    assert (other / "trajectory.tum").read_bytes() != first_tum


def test_every_mcn_and_recording_field_has_a_flag_and_bad_values_are_one_line(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from mcnkit.app.main import build_parser
    from mcnkit.app.recording import RecordingConfig

    parser = build_parser("run")
    run = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices["run"]
    options = {a.dest: a for a in run._actions}
    for section, cls in (("mcn", McnConfig), ("recording", RecordingConfig)):
        for f in dataclasses.fields(cls):
            action = options[f"{section}.{f.name}"]
            assert f"--{section}.{f.name.replace('_', '-')}" in action.option_strings
            assert action.help and "(default" in action.help
    assert options["mcn.window"].choices == ("map", "robot")
    bad = tmp_path / "bad.toml"
    bad.write_text("[mcn]\nwindow = 'room'\n")
    assert main(["run", "x.mcap", "--config", str(bad), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"mcnkit run: {bad}: window: expected one of 'map', 'robot', got 'room'", err
    assert main(["run", "x.mcap", "--mcn.samples", "0", "--no-progress"]) == 2
    assert capsys.readouterr().err.strip() == "mcnkit run: --mcn.samples must be >= 1, got 0"
