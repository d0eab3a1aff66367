"""Torch's thread count for one piece of work, restored afterwards: library functions never leave a
process-wide setting changed (the command line sets what the user asked for; scripts and notebooks keep theirs)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["torch_threads"]


@contextmanager
def torch_threads(n: int | None) -> Iterator[None]:
    """Runs the block with ``n`` torch threads (at least 1; ``None``: unchanged) and restores the previous count."""
    import torch

    before = torch.get_num_threads()
    if n is not None:
        torch.set_num_threads(max(1, int(n)))
    try:
        yield
    finally:
        torch.set_num_threads(before)
