"""Experiments 2 and 3 on tiny inputs: a tiny U-net, few particles, short simulated runs."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
import pytest
import torch

from mcnkit.app.commands.experiment import experiment_config
from mcnkit.app.main import build_parser
from mcnkit.completion.checkpoint import save_checkpoint
from mcnkit.completion.nets import UNet, UNetConfig
from mcnkit.experiments import Exp2Config, Exp3Config, run_exp2, run_exp3
from mcnkit.experiments.common import aggregate, map_at, per_map_scores, run_slam
from mcnkit.experiments.rows import EXP2_COLUMNS, Exp2Row, Exp3Row, PerMapRow
from mcnkit.experiments.tables import columns, read_rows
from mcnkit.sim import SimConfig, plan_raster, simulate, write_sim_log
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.types import FREE, OCCUPIED, UNKNOWN

TINY = UNetConfig(base_channels=4, max_channels=8, depth=2, dropout=0.3)


@pytest.fixture(scope="module")
def tiny_net(tmp_path_factory: pytest.TempPathFactory) -> str:
    torch.manual_seed(0)
    path = tmp_path_factory.mktemp("nets") / "tiny"
    save_checkpoint(path, "unet", UNet(TINY))
    return str(path)


def _read(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with open(path, newline="") as fh:
        r = csv.DictReader(fh)
        return list(r.fieldnames or []), list(r)


def test_scores_of_perfect_and_trivial_predictions() -> None:
    truth = np.full((2, 8, 8), OCCUPIED, np.float32)
    truth[:, 2:6, 2:6] = FREE
    partial = np.full_like(truth, UNKNOWN)
    partial[:, 3, 3] = FREE
    per = per_map_scores(truth, truth, partial)
    assert np.allclose(per["f_measure"], 1.0) and np.allclose(per["miou_unknown"], 1.0)
    per = per_map_scores(partial, truth, partial)  # m_t alone: one free cell of 16
    assert np.allclose(per["precision"], 1.0) and np.allclose(per["recall"], 1 / 16)
    assert np.allclose(per["miou_unknown"], 0.0)
    # a sample stack (B, K, S, S) scores each map as the mean over its samples
    stack = np.stack([truth, partial], axis=1)
    per = per_map_scores(stack, truth, partial)
    assert np.allclose(per["recall"], (1 + 1 / 16) / 2)
    row = aggregate(stack, truth, partial, "free")
    assert row.n_maps == 2 and row.f_ci95 == pytest.approx(0.0)


def test_map_at_is_exact_and_remembers_the_best_particle() -> None:
    sim = simulate(plan_raster("procedural:1"), SimConfig(max_duration_s=20.0), seed=0)
    run = run_slam(sim.frames, SlamConfig(n_particles=4), np.random.default_rng(0))
    assert run.n_updates == run.slam.n_updates and run.n_scans == len(sim.frames)
    assert all(len(p) == k + 1 for k, p in enumerate(run.best_poses))
    last, ref = map_at(run, -1), run.slam.best_ternary()
    assert last.spec is not None and ref.spec is not None
    # same map: compare on the common placement (the reference is not cropped the same way)
    from mcnkit.grid import pool_to_window

    assert np.array_equal(pool_to_window(last, ref.spec), pool_to_window(ref, ref.spec))
    first = map_at(run, 0)
    assert (first.image != UNKNOWN).sum() < (last.image != UNKNOWN).sum()
    # best_poses[k] ends at the pose of the particle that was best *at* update k (same seed: same run)
    slam = FastSlam(SlamConfig(n_particles=4), np.random.default_rng(0))
    best_then = [s.best_pose for s in (slam.step(f) for f in sim.frames) if s.updated]
    assert np.allclose(np.stack([p[-1] for p in run.best_poses]), np.stack(best_then))


def test_exp2_writes_tables(tmp_path: Path, tiny_net: str, shared_data: Path) -> None:
    cfg = Exp2Config(out_dir=str(tmp_path / "a"), n_maps=2, samples=2, particles=3, models=(tiny_net,),
                     n_train=12, n_test_pool=4, houseexpo=str(shared_data / "houseexpo" / "json.tar.gz"),
                     cache_dir=str(tmp_path / "cache"), max_duration_s=25.0, n_examples=1, progress=False)
    md = run_exp2(cfg)
    out = Path(cfg.out_dir)
    cols, rows = _read(out / "exp2.csv")
    assert cols == list(EXP2_COLUMNS)
    methods = {(r["method"], r["variant"]) for r in rows}
    assert ("(C) SLAM alone", "-") in methods and ("(D) retrieval", "-") in methods
    assert ("unknown → all free", "-") in methods and ("unknown → all occupied", "-") in methods
    assert ("tiny", "mean of 2") in methods and ("tiny", "per sample") in methods
    # 2 iterations × (3 network variants + C + D + 2 fills) × 2 positive classes
    assert len(rows) == 2 * (3 + 4) * 2
    assert {r["iteration"] for r in rows} == {"1", "T-5"} and all(r["n_maps"] == "2" for r in rows)
    for r in rows:
        for k in ("accuracy", "precision", "recall", "f_measure"):
            assert 0.0 <= float(r[k]) <= 1.0
    get = {(r["iteration"], r["method"], r["positive_class"]): r for r in rows if r["variant"] in ("-", "mean of 2")}
    slam1 = get[("1", "(C) SLAM alone", "free")]
    assert float(slam1["miou_unknown"]) == 0.0 and float(slam1["precision"]) > 0.8
    assert float(get[("1", "unknown → all free", "free")]["recall"]) >= float(slam1["recall"])
    assert float(get[("T-5", "(C) SLAM alone", "free")]["recall"]) > float(slam1["recall"])  # the robot explored
    _, per_map = _read(out / "exp2_per_map.csv")
    assert len(per_map) == 2 * 2 * 7
    _, curve = _read(out / "exp2_curve.csv")
    end = [r for r in curve if r["method"] == "(C) SLAM alone" and float(r["fraction"]) == 1.0]
    assert float(end[0]["f_measure"]) == pytest.approx(1.0)  # m_t at the last update is m_T
    assert (out / "exp2_examples.png").is_file() and (out / "exp2_curve.png").is_file()
    assert "Where the unknown cells are" in md and "(C) SLAM alone" in md
    typed = read_rows(out / "exp2.csv", Exp2Row)  # the CSV reads back into the rows
    assert [(r.iteration, r.method, r.variant, r.scores.positive_class) for r in typed] == [
        (r["iteration"], r["method"], r["variant"], r["positive_class"]) for r in rows]
    assert [r.scores.f_measure for r in typed] == [float(r["f_measure"]) for r in rows]
    assert len(read_rows(out / "exp2_per_map.csv", PerMapRow)) == len(per_map)
    # deterministic: again from scratch (no cached runs) gives the same table
    run_exp2(Exp2Config(**{**cfg.__dict__, "out_dir": str(tmp_path / "b"), "reuse_runs": False, "curve": False,
                           "n_examples": 0}))
    assert _read(tmp_path / "b" / "exp2.csv") == (cols, rows)


def test_exp3_on_a_short_simulated_log(tmp_path: Path, tiny_net: str) -> None:
    sim = simulate(plan_raster("procedural:2"), SimConfig(max_duration_s=30.0), seed=1)
    bag = write_sim_log(sim, tmp_path / "short.bag")
    cfg = Exp3Config(out_dir=str(tmp_path / "out"), logs=(str(bag),), points=(0.0, 0.5, 1.0), window_m=8.0,
                     samples=2, models=(tiny_net,), particles=3, progress=False)
    md = run_exp3(cfg)
    cols, rows = _read(tmp_path / "out" / "exp3.csv")
    assert cols == columns(Exp3Row)
    assert len(rows) == 3 * (1 + 3 + 2) and {r["log"] for r in rows} == {"short"}
    slam = {float(r["point"]): r for r in rows if r["method"] == "(C) SLAM alone"}
    assert float(slam[1.0]["f_measure"]) == pytest.approx(1.0)  # at the end, m_t is m_T
    assert float(slam[0.0]["f_measure"]) < 1.0 and float(slam[0.0]["unknown_share"]) > float(slam[1.0]["unknown_share"])
    assert float(slam[0.0]["precision"]) > 0.8
    assert (tmp_path / "out" / "exp3_short.png").is_file() and (tmp_path / "out" / "exp3_short_overview.png").is_file()
    assert "short" in md and "Summary" in md


@pytest.mark.filterwarnings("ignore::mcnkit.io.LogWarning")  # the Intel log has 4 scans out of order
def test_exp3_converts_a_carmen_log(tmp_path: Path, tiny_net: str, shared_data: Path) -> None:
    log = shared_data / "reallab" / "intel" / "intel-corrected.log.gz"
    cfg = Exp3Config(out_dir=str(tmp_path), logs=(str(log),), points=(0.5,), samples=1, models=(tiny_net,),
                     particles=2, max_scans=120, progress=False)
    run_exp3(cfg)
    _, rows = _read(tmp_path / "exp3.csv")
    assert {r["log"] for r in rows} == {"intel-corrected"} and int(rows[0]["n_updates"]) > 3


def test_arguments_build_the_configs() -> None:
    c2 = experiment_config(build_parser("experiment").parse_args(["experiment", "exp2", "--out", "x", "--n-maps", "50",
                                                                   "--samples", "3"]))
    assert (c2.out_dir, c2.n_maps, c2.samples, c2.models) == ("x", 50, 3, ("pix2pix", "unet", "unet-explore"))
    c3 = experiment_config(build_parser("experiment").parse_args(["experiment", "exp3", "--out", "y", "--points", "0.2",
                                                                   "0.8"]))
    assert (c3.out_dir, c3.points, c3.logs) == ("y", (0.2, 0.8), ())
    with pytest.raises(ValueError):
        Exp3Config(points=(1.5,))
