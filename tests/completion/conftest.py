"""Small generated pairs for the completion tests."""

from __future__ import annotations

import pytest

from mcnkit.datasets import PairSplits, procedural_pairs


@pytest.fixture(scope="session")
def tiny_splits() -> PairSplits:
    """32 training, 8 validation and 8 test pairs from the procedural domain (64×64)."""
    return procedural_pairs(32, 8, 8, seed=0)
