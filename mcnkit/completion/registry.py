"""The shipped completion networks and the training domains by name, and the error a bad checkpoint raises (no
torch here: the command line reads these before any network loads)."""

from __future__ import annotations

from pathlib import Path

__all__ = ["DEFAULT_MODEL", "DOMAINS", "MODELS", "CheckpointError", "default_weights_dir"]

MODELS = {"sampler": "sampler-houseexpo", "sampler-explore": "sampler-houseexpo-explore",
          "sampler-explore-large": "sampler-houseexpo-explore-large", "sampler-seen": "sampler-houseexpo-seen",
          "sampler-seen-large": "sampler-houseexpo-seen-large", "sampler-seen-wide": "sampler-houseexpo-seen-wide",
          "unet": "unet-houseexpo",
          "unet-explore": "unet-houseexpo-explore", "pix2pix": "pix2pix-houseexpo",
          "unet-procedural": "unet-procedural"}
"""Short names of the shipped weights (``mcnkit/weights/<name>.safetensors``): the masked samplers, which draw
whole houses (HouseExpo's one-scan maps; maps part-way through an exploration, and the same with a U-net of four
times the channels in its upper levels: better completions at three to five times the CPU; the same two on the
window an explorer completes, the seen part plus 2 m, where the house's extent is unknown; the smaller of those
trained with more maps of buildings wider than that window, framed around the robot), and the deterministic nets
of the paper's experiments."""

DEFAULT_MODEL = "sampler-explore"
"""The completion network MCN-SLAM uses unless told otherwise (``mcnkit run``, ``mcnkit demo``): the masked sampler
trained on maps part-way through an exploration, the maps a robot's SLAM holds during a run."""

DOMAINS = ("houseexpo", "houseexpo-explore", "houseexpo-seen", "houseexpo-seen-wide", "procedural")
"""Training domains of :func:`mcnkit.completion.data.load_domain_pairs`."""


class CheckpointError(ValueError):
    """A checkpoint that is missing, unreadable, of another architecture/shape, or holding non-finite weights
    (the message is one line naming the file)."""


def default_weights_dir() -> Path:
    """``mcnkit/weights`` inside the installed package."""
    return Path(__file__).resolve().parents[1] / "weights"
