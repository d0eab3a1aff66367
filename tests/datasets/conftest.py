"""Tiny hand-made HouseExpo-style archives for the dataset tests."""

from __future__ import annotations

import io
import json
import tarfile
from collections.abc import Callable
from pathlib import Path

import pytest


def square_json(plan_id: str, side_m: float = 4.0) -> bytes:
    """A HouseExpo-style plan: a square room of ``side_m`` metres starting at (0.1, 0.1)."""
    s = 0.1 + side_m
    doc = {
        "id": plan_id,
        "room_num": 1,
        "bbox": {"min": [0.1, 0.1], "max": [s, s]},
        "verts": [[0.1, 0.1], [s, 0.1], [s, s], [0.1, s]],
        "room_category": {"Bedroom": [[0.1, 0.1, s, s]]},
    }
    return json.dumps(doc).encode()


def write_archive(path: Path, members: dict[str, bytes]) -> Path:
    """Writes ``json/<name>`` members into a gzipped tar at ``path``."""
    with tarfile.open(path, "w:gz") as tf:
        for name, data in members.items():
            info = tarfile.TarInfo(f"json/{name}")
            info.size = len(data)
            tf.addfile(info, io.BytesIO(data))
    return path


@pytest.fixture
def archive_tools() -> tuple[Callable[[str, float], bytes], Callable[[Path, dict[str, bytes]], Path]]:
    """``(square_json, write_archive)`` for tests that build their own archives."""
    return square_json, write_archive


@pytest.fixture
def tiny_houseexpo(tmp_path: Path) -> Path:
    """An archive with 8 good plans, one malformed, one self-intersecting, and split lists (with unknown ids)."""
    members = {f"good{i}.json": square_json(f"good{i}", 3.0 + 0.5 * i) for i in range(8)}
    members["broken.json"] = b'{"verts": [[0, 0], [1, 0]'
    bowtie = {"id": "bowtie", "verts": [[0.1, 0.1], [4.1, 4.1], [4.1, 0.1], [0.1, 2.1]]}
    members["bowtie.json"] = json.dumps(bowtie).encode()
    archive = write_archive(tmp_path / "json.tar.gz", members)
    train = [f"good{i}" for i in range(6)] + ["broken", "bowtie", "missing1"]
    (tmp_path / "map_id_train.txt").write_text("\n".join(train) + "\n")
    (tmp_path / "map_id_test.txt").write_text("good6\ngood7\nmissing2\n")
    return archive
