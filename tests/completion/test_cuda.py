"""On a GPU, the completion networks train, complete and sample as on the CPU, and MCN-SLAM runs with its net there.

Skipped where torch sees no CUDA device (CI has none); on a machine with one: ``pytest tests/completion/test_cuda.py``.
A torch generator on the CPU serves a net on the GPU (the random numbers are drawn on the generator's device and
moved), so the same seed gives the same samples on either device, up to the floating-point differences of the
convolutions, which flip the odd cell whose probability sits at a threshold.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from mcnkit.app.commands.train import main as train_main
from mcnkit.completion.nets import MaskedSampler, SamplerConfig, UNet, UNetConfig
from mcnkit.completion.sample import complete, sample_completions
from mcnkit.datasets import PairSplits
from mcnkit.mcn import McnConfig, McnSlam, load_model
from mcnkit.sim import SimConfig, plan_raster, simulate
from mcnkit.slam import SlamConfig

pytestmark = pytest.mark.skipif(not torch.cuda.is_available(), reason="needs a CUDA GPU (torch.cuda.is_available())")

NETS = {
    "unet": lambda: UNet(UNetConfig(base_channels=8, max_channels=32, depth=4, dropout=0.5, noise_channels=1)),
    "sampler": lambda: MaskedSampler(SamplerConfig(UNetConfig(out_channels=1, base_channels=8, max_channels=32,
                                                              depth=4, dropout=0.0), (0.1, 0.4, 1.0))),
}


def _agreement(a: np.ndarray, b: np.ndarray) -> float:
    return float((a == b).mean())


@pytest.mark.parametrize("kind", list(NETS))
def test_a_net_samples_on_the_gpu_from_a_cpu_generator_as_on_the_cpu(kind: str, tiny_splits: PairSplits) -> None:
    torch.manual_seed(0)
    net = NETS[kind]().eval()
    partial = tiny_splits.test.partial[:4]
    cpu = sample_completions(net, partial, 4, torch.Generator().manual_seed(3), "cpu")
    gpu = sample_completions(net.to("cuda"), partial, 4, torch.Generator().manual_seed(3), "cuda")
    assert gpu.samples.shape == cpu.samples.shape == (4, 4, 64, 64)
    assert _agreement(gpu.samples, cpu.samples) > 0.99
    assert np.allclose(gpu.mean_output, cpu.mean_output, atol=1e-3)


@pytest.mark.parametrize("model", ["unet", "pix2pix", "sampler"])
def test_training_on_the_gpu_writes_a_checkpoint_the_cpu_completes_with(model: str, tmp_path: Path,
                                                                        tiny_splits: PairSplits) -> None:
    out = tmp_path / model
    args = ["train", "--model", model, "--domain", "procedural", "--n-train", "32", "--n-val", "8", "--n-test", "8",
            "--epochs", "2", "--batch-size", "8", "--base-channels", "8", "--max-channels", "32", "--depth", "4",
            "--device", "cuda", "--out", str(out), "--no-progress"]
    assert train_main(args) == 0
    assert train_main([*args, "--epochs", "3", "--resume"]) == 0  # resumed on the GPU from its own checkpoint
    on_cpu = load_model(out / "best.safetensors")
    on_gpu = load_model(out / "best.safetensors", "cuda")
    assert next(on_gpu.parameters()).is_cuda and not next(on_cpu.parameters()).is_cuda
    partial = tiny_splits.test.partial
    assert _agreement(complete(on_gpu, partial, "cuda"), complete(on_cpu, partial, "cpu")) > 0.99


def test_mcn_slam_completes_with_its_net_on_the_gpu() -> None:
    run = simulate(plan_raster("procedural:1", 0.05, None), SimConfig(max_duration_s=10.0), seed=0)
    results = {}
    for device in ("cpu", "cuda"):
        mcn = McnSlam(SlamConfig(n_particles=8), load_model("sampler-explore", device), McnConfig(samples=4, ranks=2),
                      np.random.default_rng(0), generator=torch.Generator().manual_seed(0), device=device)
        results[device] = [r.completion for r in (mcn.step(f) for f in run.frames) if r.completion is not None]
    assert len(results["cuda"]) == len(results["cpu"]) > 0
    last_cpu, last_gpu = results["cpu"][-1], results["cuda"][-1]
    assert np.array_equal(last_cpu.partial, last_gpu.partial)  # the SLAM is the same: the net does not steer it
    assert _agreement(last_gpu.samples, last_cpu.samples) > 0.98
