"""Map completion networks (MCN): U-net and pix2pix generators with spectral normalization, sampling, training,
checkpoints, scores, the retrieval baseline and Experiment 1.

The names below are imported on first use (torch loads only when a network is needed)."""

from typing import TYPE_CHECKING

from mcnkit._lazy import lazy_exports

if TYPE_CHECKING:
    from mcnkit.completion.checkpoint import CheckpointError, load_checkpoint, load_generator, save_checkpoint
    from mcnkit.completion.nets import DiscriminatorConfig, PatchDiscriminator, UNet, UNetConfig
    from mcnkit.completion.sample import SampleSet, complete, diversity, sample_completions
    from mcnkit.completion.scores import Scores, score_maps

__all__ = [
    "CheckpointError",
    "DiscriminatorConfig",
    "PatchDiscriminator",
    "SampleSet",
    "Scores",
    "UNet",
    "UNetConfig",
    "complete",
    "diversity",
    "load_checkpoint",
    "load_generator",
    "sample_completions",
    "save_checkpoint",
    "score_maps",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "mcnkit.completion.checkpoint": ("CheckpointError", "load_checkpoint", "load_generator", "save_checkpoint"),
    "mcnkit.completion.nets": ("DiscriminatorConfig", "PatchDiscriminator", "UNet", "UNetConfig"),
    "mcnkit.completion.sample": ("SampleSet", "complete", "diversity", "sample_completions"),
    "mcnkit.completion.scores": ("Scores", "score_maps"),
})
