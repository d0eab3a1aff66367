"""HouseExpo reading, validation, rasterization and installation."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pytest
from matplotlib.path import Path as MplPath

from mcnkit.datasets.houseexpo import (
    FloorPlan,
    PlanError,
    SkipLog,
    install_houseexpo,
    is_self_intersecting,
    iter_plans,
    load_plan,
    parse_plan,
    rasterize_plan,
    rasterize_polygon,
    read_split,
)
from mcnkit.types import GridSpec


def test_square_cells_exact() -> None:
    plan = FloorPlan("sq", np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]))
    free, grid = rasterize_plan(plan, resolution_m=0.25, border_cells=1)
    expected = np.zeros((6, 6), bool)
    expected[1:5, 1:5] = True
    np.testing.assert_array_equal(free, expected)
    assert (grid.origin_x_m, grid.origin_y_m) == (-0.25, -0.25)


def test_l_shape_cells_exact_and_row0_is_lowest_y() -> None:
    verts = np.array([[0, 0], [2, 0], [2, 1], [1, 1], [1, 2], [0, 2]], float)
    free = rasterize_polygon(verts, GridSpec(0.5, 0.0, 0.0, 4, 4))
    expected = np.array(
        [[1, 1, 1, 1], [1, 1, 1, 1], [1, 1, 0, 0], [1, 1, 0, 0]],  # row 0 = y in [0, 0.5)
        bool,
    )
    np.testing.assert_array_equal(free, expected)


@pytest.mark.parametrize("seed", range(5))
def test_matches_point_in_polygon_on_random_star_polygons(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 12
    ang = np.sort(rng.uniform(0, 2 * np.pi, n))
    rad = rng.uniform(1.0, 3.0, n)
    verts = np.stack([rad * np.cos(ang) + 0.013, rad * np.sin(ang) - 0.007], 1)
    grid = GridSpec(0.1, -3.5, -3.5, 70, 70)
    free = rasterize_polygon(verts, grid)
    rc = np.stack(np.meshgrid(np.arange(70), np.arange(70), indexing="ij"), -1)
    centres = grid.cell_to_world(rc).reshape(-1, 2)
    expected = MplPath(verts).contains_points(centres).reshape(70, 70)
    np.testing.assert_array_equal(free, expected)


def test_real_plans_free_area_within_2_percent(shared_data: Path) -> None:
    archive = shared_data / "houseexpo" / "json.tar.gz"
    ids = read_split(shared_data / "houseexpo" / "map_id_test.txt")[:40]
    plans = list(iter_plans(archive, ids))
    assert len(plans) >= 30
    for plan in plans:
        for res in (0.05, 1.0 / 16.0):
            free, _ = rasterize_plan(plan, res, 5)
            area = free.sum() * res * res
            assert abs(area - plan.area_m2) / plan.area_m2 < 0.02, (plan.id, res, area, plan.area_m2)


def test_self_intersection() -> None:
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    bowtie = np.array([[0, 0], [1, 1], [1, 0], [0, 1]], float)
    assert not is_self_intersecting(square)
    assert is_self_intersecting(bowtie)
    assert is_self_intersecting(bowtie, chunk=1)


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        (b"{not json", "malformed json"),
        (b'{"id": "x"}', "malformed json: no 'verts'"),
        (b'{"id": "x", "verts": [[0, 0], [1, 0]]}', "empty outline"),
        (b'{"id": "x", "verts": [[0, 0], [1, 0], [2, 0]]}', "empty outline: zero area"),
        (b'{"id": "x", "verts": [[0, 0], [2, 2], [2, 0], [0, 1]]}', "self-intersecting"),
        (b'{"id": "y", "verts": [[0, 0], [1, 0], [1, 1]]}', "id mismatch"),
        (b'{"id": "x", "verts": "oops"}', "bad outline|malformed"),
    ],
)
def test_parse_rejects_with_reason(text: bytes, reason: str) -> None:
    with pytest.raises(PlanError, match=reason):
        parse_plan(text, "x")


def test_iter_plans_skips_with_reasons(tiny_houseexpo: Path) -> None:
    skips = SkipLog()
    plans = list(iter_plans(tiny_houseexpo, skips=skips))
    assert sorted(p.id for p in plans) == [f"good{i}" for i in range(8)]
    assert skips.reasons["broken"].startswith("malformed json")
    assert skips.reasons["bowtie"] == "self-intersecting outline"
    skips = SkipLog()
    plans = list(iter_plans(tiny_houseexpo, ["good1", "nope"], skips))
    assert [p.id for p in plans] == ["good1"]
    assert skips.reasons == {"nope": "unknown id: not in the source"}
    assert load_plan(tiny_houseexpo, "good2").room_labels == ("Bedroom",)
    with pytest.raises(PlanError, match="unknown id"):
        load_plan(tiny_houseexpo, "nope")


def test_extracted_folder_reads_the_same(tiny_houseexpo: Path, tmp_path: Path) -> None:
    import tarfile

    out = tmp_path / "extracted"
    with tarfile.open(tiny_houseexpo) as tf:
        tf.extractall(out, filter="data")
    a = {p.id for p in iter_plans(tiny_houseexpo)}
    b = {p.id for p in iter_plans(out)}
    assert a == b and len(a) == 8


def test_corrupted_archive_does_not_crash(tiny_houseexpo: Path, tmp_path: Path) -> None:
    data = tiny_houseexpo.read_bytes()
    bad = tmp_path / "bad.tar.gz"
    bad.write_bytes(data[: len(data) // 2])
    skips = SkipLog()
    plans = list(iter_plans(bad, skips=skips))
    assert len(plans) < 8
    assert any(r.startswith("corrupted archive") for r in skips.reasons.values())


def test_install_checks_sha256(tiny_houseexpo: Path, tmp_path: Path) -> None:
    digest = hashlib.sha256(tiny_houseexpo.read_bytes()).hexdigest()
    dest = tmp_path / "data"
    target = install_houseexpo(tiny_houseexpo.as_uri(), dest, digest)
    assert target == dest / "houseexpo" / "json.tar.gz"
    assert target.read_bytes() == tiny_houseexpo.read_bytes()
    assert (dest / "houseexpo" / "map_id_train.txt").is_file()
    target.unlink()
    with pytest.raises(ValueError, match="sha256 mismatch"):
        install_houseexpo(str(tiny_houseexpo), dest, "0" * 64)
    assert not target.exists() and not list((dest / "houseexpo").glob("*.part"))
