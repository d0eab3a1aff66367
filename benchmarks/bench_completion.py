"""Benchmark of the completion networks: latency of one 64×64 completion, and of 30 particles × 8 samples.

Measured on the shipped U-net ``unet-houseexpo`` (Exp 1's (B)) and the masked samplers ``sampler-houseexpo`` and
``sampler-houseexpo-explore`` (MCN-SLAM's default), through the public functions, i.e. the inference fast path (:func:`mcnkit.completion.sample.inference_net`: spectral norm evaluated
once, batch norm folded) and the conversion to ternary included:

* one completion: :func:`mcnkit.completion.sample.complete` (eval mode, dropout off) on one 64×64 partial map;
  median over ``--repeats`` timed calls after warm-up (target ≤ 5 ms); the plain module call
  ``net(x)`` (spectral norm recomputed, batch norm unfused) is reported alongside for reference;
* sampling for a particle filter: 30 particles × 8 samples = 240 completions
  (:func:`mcnkit.completion.sample.sample_completions`, conversion to ternary and label entropy included);
  median.  A U-net draws them in one pass with dropout on (target ≤ 100 ms); a sampler round by round, each
  round a pass over the 240 maps (target ≤ 600 ms).

Uses ``--threads`` torch threads (default 2, this machine's cores).  Prints the figures and writes
``benchmarks/results/completion.json``.

    .venv/bin/python -m benchmarks.bench_completion [--weights W [W ...]] [--threads 2]
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

import numpy as np
import torch

from benchmarks.common import ROOT
from mcnkit.completion.checkpoint import load_generator
from mcnkit.completion.nets import CompletionNet, MaskedSampler, UNet, UNetConfig
from mcnkit.completion.sample import complete, sample_completions
from mcnkit.datasets import procedural_pairs

DEFAULT_WEIGHTS = ("unet-houseexpo", "sampler-houseexpo", "sampler-houseexpo-explore")
BATCH_TARGET_MS, SAMPLER_BATCH_TARGET_MS = 100.0, 600.0


def _median_ms(fn: object, repeats: int) -> float:
    assert callable(fn)
    fn()
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1e3)
    return statistics.median(times)


def main() -> int:
    """Runs the benchmark; returns 0."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    wdir = ROOT / "mcnkit" / "weights"
    ap.add_argument("--weights", nargs="+", default=[str(wdir / name) for name in DEFAULT_WEIGHTS],
                    help="checkpoints to time (default: the shipped U-net and samplers)")
    ap.add_argument("--threads", type=int, default=2, help="torch CPU threads (default 2, this machine's cores)")
    ap.add_argument("--repeats", type=int, default=30, help="timed calls of one completion (the batch: a third)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "completion.json"), help="JSON output")
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    partial = procedural_pairs(0, 0, 30, seed=0).test.partial  # (30, 64, 64)
    results = []
    for weights in args.weights:
        if Path(weights + ".safetensors").is_file():
            net, _ = load_generator(weights)
            source = str(Path(weights).relative_to(ROOT)) if Path(weights).is_relative_to(ROOT) else weights
        else:
            net, source = UNet(UNetConfig()).eval(), f"untrained default UNetConfig ({weights} not found)"
        one = torch.from_numpy(np.stack([partial[0], (partial[0] == 0.5).astype(np.float32)])[None])
        gen = torch.Generator().manual_seed(0)

        def single(net: CompletionNet = net) -> None:
            complete(net, partial[:1])

        def raw(net: CompletionNet = net, one: torch.Tensor = one) -> None:
            with torch.no_grad():
                net(one)

        def batch(net: CompletionNet = net, gen: torch.Generator = gen) -> None:
            sample_completions(net, partial, k=8, generator=gen)

        single_ms = _median_ms(single, args.repeats)
        raw_ms = _median_ms(raw, args.repeats)
        batch_ms = _median_ms(batch, max(5, args.repeats // 3))
        target = SAMPLER_BATCH_TARGET_MS if isinstance(net, MaskedSampler) else BATCH_TARGET_MS
        results.append(
            {
                "weights": source,
                "generator_config": net.config.as_dict(),
                "parameters": sum(p.numel() for p in net.parameters()),
                "single_64x64_ms": round(single_ms, 3),
                "single_64x64_plain_module_call_ms": round(raw_ms, 3),
                "particles30_x_samples8_ms": round(batch_ms, 2),
                "particles30_x_samples8_target_ms": target,
            }
        )
        print(
            f"{source}: one 64x64 completion {single_ms:.2f} ms (target <= 5 ms; plain net(x) {raw_ms:.2f} ms); "
            f"30 particles x 8 samples {batch_ms:.1f} ms (target <= {target:.0f} ms)"
        )
    result = {
        "threads": args.threads,
        "torch": torch.__version__,
        "machine": platform.processor() or platform.machine(),
        "single_target_ms": 5.0,
        "batch_target_ms": BATCH_TARGET_MS,
        "sampler_batch_target_ms": SAMPLER_BATCH_TARGET_MS,
        "models": results,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
