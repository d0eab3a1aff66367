"""Experiment 2's house runs and their cache: named fields, refused when stale, foreign or damaged."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from mcnkit.experiments.config import Exp2Config
from mcnkit.experiments.houses import CACHE_VERSION, HouseRun, RunCacheError, cache_key, cache_path, run_house
from mcnkit.types import GridSpec


def _house(s: int = 8) -> HouseRun:
    rng = np.random.default_rng(0)
    return HouseRun("houseexpo:abc", GridSpec(0.05, -1.0, 2.0, s, s), rng.random((s, s), dtype=np.float32),
                    rng.random((s, s)) > 0.5, (0, 3, 7), rng.random((3, s, s), dtype=np.float32), 9, 40, 1.5, 2.5,
                    0.25)


def test_a_run_round_trips_through_its_cache(tmp_path: Path) -> None:
    h = _house()
    key = cache_key(Exp2Config(), h.name)
    path = cache_path(tmp_path, key)
    h.save(path, key)
    with np.load(path) as z:
        assert {"version", "key", "name", "window_width", "truth", "partials", "updates", "sim_s"} <= set(z.files)
        assert int(z["version"]) == CACHE_VERSION
    back = HouseRun.load(path, key)
    assert (back.name, back.window, back.updates, back.n_updates, back.n_scans) == (
        h.name, h.window, h.updates, h.n_updates, h.n_scans)
    assert np.array_equal(back.truth, h.truth) and np.array_equal(back.exterior, h.exterior)
    assert np.array_equal(back.partial_at(3), h.partials[1]) and back.late_update(5) == 3
    assert not list(tmp_path.glob("*.tmp.npz"))


def test_the_key_changes_with_the_settings_that_shape_a_run() -> None:
    base = cache_key(Exp2Config(), "houseexpo:a")
    assert cache_key(Exp2Config(particles=5), "houseexpo:a") != base
    assert cache_key(Exp2Config(), "houseexpo:b") != base
    assert cache_key(Exp2Config(samples=3, out_dir="elsewhere"), "houseexpo:a") == base  # scoring only


def test_a_stale_a_foreign_and_a_damaged_cache_are_refused(tmp_path: Path) -> None:
    h = _house()
    key = cache_key(Exp2Config(), h.name)
    path = tmp_path / "run.npz"
    h.save(path, key)
    with pytest.raises(RunCacheError, match="other settings"):
        HouseRun.load(path, cache_key(Exp2Config(particles=5), h.name))
    with np.load(path) as z:
        fields = {k: z[k] for k in z.files}
    np.savez(tmp_path / "old.npz", **{**fields, "version": np.int64(CACHE_VERSION - 1)})
    with pytest.raises(RunCacheError, match=r"old.npz: a stale cache \(version 2"):
        HouseRun.load(tmp_path / "old.npz", key)
    legacy = {k: v for k, v in fields.items() if k not in ("version", "name")}  # the version-2 layout had neither
    np.savez(tmp_path / "legacy.npz", **legacy)
    with pytest.raises(RunCacheError, match=r"not a cached house run of Experiment 2 .no name, version"):
        HouseRun.load(tmp_path / "legacy.npz", key)
    (tmp_path / "text.npz").write_text("not an archive")
    with pytest.raises(RunCacheError, match=r"text\.npz: not a cached house run"):
        HouseRun.load(tmp_path / "text.npz", key)
    replace(h, partials=h.partials[:2]).save(tmp_path / "short.npz", key)
    with pytest.raises(RunCacheError, match=r"damaged .*m_t is float32 \(2, 8, 8\), expected \(3, 8, 8\)"):
        HouseRun.load(tmp_path / "short.npz", key)
    replace(h, truth=h.truth[:4]).save(tmp_path / "truth.npz", key)
    with pytest.raises(RunCacheError, match=r"damaged .*m_T is float32"):
        HouseRun.load(tmp_path / "truth.npz", key)


def test_run_house_reuses_its_cache_and_refuses_a_bad_one(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from mcnkit.app.main import main

    cfg = Exp2Config(out_dir=str(tmp_path), maps=("procedural:1",))
    h = replace(_house(), name="procedural:1")
    key = cache_key(cfg, h.name)
    h.save(cache_path(tmp_path, key), key)
    assert run_house(cfg, h.name, 0, tmp_path).n_scans == h.n_scans  # read back, not simulated
    with np.load(cache_path(tmp_path, key)) as z:
        fields = {k: z[k] for k in z.files}
    np.savez(cache_path(tmp_path, key), **{**fields, "version": np.int64(CACHE_VERSION + 1)})
    with pytest.raises(RunCacheError, match="stale"):
        run_house(cfg, h.name, 0, tmp_path)
    # the command reports it in one line (a house that cannot be simulated would be skipped, this is not)
    runs = tmp_path / "out" / "runs"
    runs.mkdir(parents=True)
    (cache_path(runs, cache_key(Exp2Config(), h.name))).write_text("garbage")  # the key: the run's settings only
    code = main(["experiment", "exp2", "--out", str(tmp_path / "out"), "--maps", "procedural:1", "--models", "unet",
                 "--houseexpo", str(tmp_path / "none.tar.gz"), "--quiet"])
    assert code == 2 and "not a cached house run" in capsys.readouterr().err
