"""Pair building and the cache manifest."""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from mcnkit.datasets.pairs import PairConfig, load_or_build_houseexpo_pairs, pair_stats, procedural_pairs
from mcnkit.datasets.pseudoslam import PseudoSlamConfig
from mcnkit.types import FREE, OCCUPIED, UNKNOWN


def _cfg(n_train: int = 3, seed: int = 0, size: int = 64) -> PairConfig:
    return PairConfig(n_train=n_train, n_val=1, n_test=2, seed=seed, size=size)


def test_build_counts_and_skips(tiny_houseexpo: Path, tmp_path: Path) -> None:
    splits, rebuilt = load_or_build_houseexpo_pairs(tiny_houseexpo, tmp_path / "cache", _cfg(), progress=False)
    assert rebuilt
    assert (len(splits.train), len(splits.val), len(splits.test)) == (3, 1, 2)
    assert set(splits.test.ids) == {"good6", "good7"}
    assert not set(splits.train.ids) & set(splits.val.ids)
    assert splits.train.partial.shape == (3, 64, 64) and splits.train.partial.dtype == np.float32
    assert set(np.unique(splits.train.partial)) <= {FREE, UNKNOWN, OCCUPIED}
    assert set(np.unique(splits.train.target)) <= {FREE, OCCUPIED}
    np.testing.assert_array_equal(splits.train.partial_mask, splits.train.partial == UNKNOWN)
    # Whatever m_t knows as free is free in m_T; m_t observes a part of the room only.
    st = pair_stats(splits.train)
    assert 0.0 < st.observed_share < 1.0 and 0.3 < st.free_fraction <= 1.0


def test_skip_reasons_recorded(tiny_houseexpo: Path, tmp_path: Path) -> None:
    cfg = PairConfig(n_train=6, n_val=2, n_test=3)  # asks for more than exists: takes what is valid
    splits, _ = load_or_build_houseexpo_pairs(tiny_houseexpo, tmp_path / "c", cfg, progress=False)
    assert len(splits.train) + len(splits.val) == 6 and len(splits.test) == 2
    reasons = splits.manifest["skip_reasons"]
    assert reasons == {"malformed json": 1, "self-intersecting outline": 1, "unknown id": 2}


def test_cache_reused_and_invalidated(tiny_houseexpo: Path, tmp_path: Path, archive_tools: tuple[Any, Any]) -> None:
    square_json, write_archive = archive_tools
    cache = tmp_path / "cache"
    first, rebuilt = load_or_build_houseexpo_pairs(tiny_houseexpo, cache, _cfg(), progress=False)
    assert rebuilt
    manifest = json.loads((cache / "houseexpo-pairs.manifest.json").read_text())
    assert manifest["key"]["seed"] == 0 and len(manifest["key"]["source_sha256"]) == 64
    again, rebuilt = load_or_build_houseexpo_pairs(tiny_houseexpo, cache, _cfg(), progress=False)
    assert not rebuilt
    np.testing.assert_array_equal(first.train.partial, again.train.partial)
    assert first.train.ids == again.train.ids
    # A new seed, a new config or a changed source each rebuild.
    _, rebuilt = load_or_build_houseexpo_pairs(tiny_houseexpo, cache, _cfg(seed=1), progress=False)
    assert rebuilt
    _, rebuilt = load_or_build_houseexpo_pairs(tiny_houseexpo, cache, _cfg(seed=1, size=32), progress=False)
    assert rebuilt
    src2 = tmp_path / "v2"
    src2.mkdir()
    shutil.copy(tiny_houseexpo.parent / "map_id_train.txt", src2)
    shutil.copy(tiny_houseexpo.parent / "map_id_test.txt", src2)
    members = {f"good{i}.json": square_json(f"good{i}", 2.0 + i) for i in range(8)}
    write_archive(src2 / "json.tar.gz", members)
    changed, rebuilt = load_or_build_houseexpo_pairs(src2 / "json.tar.gz", cache, _cfg(seed=1, size=32), progress=False)
    assert rebuilt and changed.manifest["key"]["source_sha256"] != manifest["key"]["source_sha256"]
    # A corrupted cache file is rebuilt, not trusted.
    (cache / "houseexpo-pairs.npz").write_bytes(b"garbage")
    _, rebuilt = load_or_build_houseexpo_pairs(src2 / "json.tar.gz", cache, _cfg(seed=1, size=32), progress=False)
    assert rebuilt


def test_pairs_do_not_depend_on_other_pairs(tiny_houseexpo: Path, tmp_path: Path) -> None:
    a, _ = load_or_build_houseexpo_pairs(tiny_houseexpo, tmp_path / "a", _cfg(), progress=False)
    b, _ = load_or_build_houseexpo_pairs(tiny_houseexpo, tmp_path / "b", _cfg(n_train=5), progress=False)
    for pid, img in zip(a.test.ids, a.test.partial, strict=True):
        np.testing.assert_array_equal(img, b.test.partial[b.test.ids.index(pid)])


def test_procedural_pairs() -> None:
    splits = procedural_pairs(4, 2, 2, seed=3)
    again = procedural_pairs(4, 2, 2, seed=3)
    np.testing.assert_array_equal(splits.train.partial, again.train.partial)
    assert splits.train.ids[0] == "procedural:0" and splits.test.ids[0] == "procedural:2000000"
    masked = splits.train.partial_mask.mean(axis=(1, 2))
    assert np.all(masked >= 0.1) and np.all(masked <= 0.55)
    known = splits.train.partial != UNKNOWN
    np.testing.assert_array_equal(splits.train.partial[known], splits.train.target[known])


def test_real_pairs_small(shared_data: Path, tmp_path: Path) -> None:
    archive = shared_data / "houseexpo" / "json.tar.gz"
    splits, _ = load_or_build_houseexpo_pairs(archive, tmp_path, PairConfig(100, 10, 20), progress=False)
    st = pair_stats(splits.train)
    assert (len(splits.train), len(splits.val), len(splits.test)) == (100, 10, 20)
    assert 0.45 < st.free_fraction < 0.65 and 0.03 < st.observed_share < 0.1


def test_exploration_pairs_see_more_and_keep_the_paper_cache_key(shared_data: Path, tmp_path: Path) -> None:
    archive = shared_data / "houseexpo" / "json.tar.gz"
    paper = PairConfig(40, 5, 5)
    explore = PairConfig(40, 5, 5, pseudoslam=PseudoSlamConfig(range_m=8.0, fov_deg=360.0), max_scans=12)
    first, _ = load_or_build_houseexpo_pairs(archive, tmp_path / "a", paper, progress=False)
    many, _ = load_or_build_houseexpo_pairs(archive, tmp_path / "b", explore, progress=False)
    assert first.train.ids == many.train.ids and first.train.target.tobytes() == many.train.target.tobytes()
    # Several 360° scans see several times more of the house than one 180°, 2 m scan.
    assert pair_stats(many.train).observed_share > 3 * pair_stats(first.train).observed_share
    # Pooling keeps the first wall pixel a scan hits: whatever m_t shows occupied is occupied in m_T.
    assert np.all(many.train.target[many.train.partial == OCCUPIED] == OCCUPIED)
    # The paper's pairs keep the cache key they had before max_scans existed (no rebuild of existing caches).
    key = json.loads((tmp_path / "a" / "houseexpo-pairs.manifest.json").read_text())["key"]
    assert "max_scans" not in key["config"]
    assert json.loads((tmp_path / "b" / "houseexpo-pairs.manifest.json").read_text())["key"]["config"]["max_scans"] == 12


def test_seen_window_pairs_frame_what_the_robot_has_seen(shared_data: Path, tmp_path: Path) -> None:
    archive = shared_data / "houseexpo" / "json.tar.gz"
    lidar = PseudoSlamConfig(range_m=8.0, fov_deg=360.0)
    plan_box = PairConfig(40, 5, 5, pseudoslam=lidar, max_scans=12)
    seen = PairConfig(40, 5, 5, pseudoslam=lidar, max_scans=12, seen_window=(2.0, 8.0, 30.0))
    boxed, _ = load_or_build_houseexpo_pairs(archive, tmp_path / "a", plan_box, progress=False)
    framed, _ = load_or_build_houseexpo_pairs(archive, tmp_path / "b", seen, progress=False)
    assert framed.train.ids == boxed.train.ids  # the same plans and scans, another frame
    m_t, m_T = framed.train.partial, framed.train.target
    # The seen part plus 2 m: no map touches the frame's edge with a seen cell (unless wider than 30 m) ...
    edge = np.concatenate([m_t[:, 0], m_t[:, -1], m_t[:, :, 0], m_t[:, :, -1]], axis=1)
    assert np.mean(np.all(edge == UNKNOWN, axis=1)) > 0.8
    # ... and the plan no longer fills the frame: more exterior, and part of the house lies outside it.
    assert pair_stats(framed.train).free_fraction < pair_stats(boxed.train).free_fraction
    assert np.all(m_T[m_t == OCCUPIED] == OCCUPIED) and not np.any(m_T == UNKNOWN)
    # Caches built before the option keep their key.
    key = json.loads((tmp_path / "a" / "houseexpo-pairs.manifest.json").read_text())["key"]
    assert "seen_window" not in key["config"]
    assert json.loads((tmp_path / "b" / "houseexpo-pairs.manifest.json").read_text())["key"]["config"]["seen_window"] == [
        2.0, 8.0, 30.0]


def test_wide_plans_add_pairs_framed_around_the_robot(shared_data: Path, tmp_path: Path) -> None:
    archive = shared_data / "houseexpo" / "json.tar.gz"
    wide = ["704f25a5e5bcc6bcaef421a83313d92f", "0ea3802b1cabee830f3989dd9c75d496"]  # 37 m and 52 m across
    narrow = ["0791412577f33047b7fe090535826d51", "c6a4d5d2e1d5028207324e98f790d5d8", "6f56ce29120bec8d52057f07682141ef"]
    (tmp_path / "train.txt").write_text("\n".join(wide + narrow) + "\n")
    (tmp_path / "test.txt").write_text("4c3b685d96afa5e3748b03e24fa2186f\n")
    lidar = PseudoSlamConfig(range_m=8.0, fov_deg=360.0)
    cfg = PairConfig(13, 0, 1, pseudoslam=lidar, max_scans=12, seen_window=(2.0, 8.0, 30.0), wide_pairs=(4, 48))
    splits, _ = load_or_build_houseexpo_pairs(archive, tmp_path / "c", cfg, tmp_path / "train.txt",
                                              tmp_path / "test.txt", progress=False)
    ids = list(splits.train.ids)
    # Each wide plan gives 1 + 4 pairs, each narrow plan one; the extra pairs are draws of their own.
    assert sorted(ids.count(i) for i in wide + narrow) == [1, 1, 1, 5, 5]
    first = ids.index(wide[0])
    draws = splits.train.partial[first : first + 5]
    assert all(not np.array_equal(draws[0], d) for d in draws[1:])
    # Up to 48 scans see past a 30 m window: some of the wide plans' maps reach its edge with seen cells.
    wide_maps = splits.train.partial[[k for k, i in enumerate(ids) if i in wide]]
    edge = np.concatenate([wide_maps[:, 0], wide_maps[:, -1], wide_maps[:, :, 0], wide_maps[:, :, -1]], axis=1)
    assert np.any(np.any(edge != UNKNOWN, axis=1))
    # The plain seen-window pairs of the same plans are the first of each plan's draws, and their cache key is unchanged.
    plain = PairConfig(5, 0, 1, pseudoslam=lidar, max_scans=12, seen_window=(2.0, 8.0, 30.0))
    base, _ = load_or_build_houseexpo_pairs(archive, tmp_path / "d", plain, tmp_path / "train.txt",
                                            tmp_path / "test.txt", progress=False)
    for k, pid in enumerate(base.train.ids):
        assert np.array_equal(base.train.partial[k], splits.train.partial[ids.index(pid)])
    assert "wide_pairs" not in json.loads((tmp_path / "d" / "houseexpo-pairs.manifest.json").read_text())["key"]["config"]
