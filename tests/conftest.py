"""Shared test fixtures: where the real data lives, and small generated logs."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from mcnkit.types import Frame, LidarSpec, Pose2D, Scan

os.environ.setdefault("RERUN_ANALYTICS", "0")  # no telemetry from tests

SHARED_DATA = Path(os.environ.get("MCNKIT_SHARED_DATA", Path(__file__).resolve().parents[1].parent / "shared" / "data"))


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """``../shared/data`` beside the project root (CI clones the project next to it)."""
    if not SHARED_DATA.is_dir():
        pytest.fail(f"real data not found at {SHARED_DATA}; clone the project next to shared/ or set MCNKIT_SHARED_DATA")
    return SHARED_DATA


def make_frames(n: int = 20, beams: int = 8, seed: int = 0, start_ns: int = 1_000_000_000) -> list[Frame]:
    """A robot moving along +x at 0.1 m per scan, 10 Hz, with random ranges and one no-return per scan."""
    rng = np.random.default_rng(seed)
    spec = LidarSpec(-np.pi / 2, np.pi / (beams - 1), beams, 0.1, 10.0, Pose2D(0.2, 0.0, 0.0))
    frames = []
    for i in range(n):
        ranges = rng.uniform(0.5, 9.0, beams).astype(np.float32)
        ranges[i % beams] = np.nan
        frames.append(Frame(start_ns + i * 100_000_000, Scan(ranges, spec), Pose2D(0.1 * i, 0.0, 0.01 * i)))
    return frames


@pytest.fixture
def frames() -> list[Frame]:
    """Twenty generated frames (see :func:`make_frames`)."""
    return make_frames()
