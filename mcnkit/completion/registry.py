"""The shipped completion networks and the training domains by name, and the error a bad checkpoint raises (no
torch here: the command line reads these before any network loads)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["DOMAINS", "MODELS", "CheckpointError", "default_weights_dir"]

MODELS = {"unet": "unet-houseexpo", "unet-explore": "unet-houseexpo-explore", "pix2pix": "pix2pix-houseexpo",
          "unet-procedural": "unet-procedural"}
"""Short names of the shipped weights (``mcnkit/weights/<name>.safetensors``)."""

DOMAINS = ("houseexpo", "houseexpo-explore", "procedural")
"""Training domains of :func:`mcnkit.completion.data.load_domain_pairs`."""


class CheckpointError(ValueError):
    """A checkpoint that is missing, unreadable, of another architecture/shape, or holding non-finite weights
    (the message is one line naming the file)."""


def default_weights_dir() -> Path:
    """``mcnkit/weights`` inside the installed package."""
    return Path(__file__).resolve().parents[1] / "weights"
