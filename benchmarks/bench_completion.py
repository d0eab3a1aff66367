"""Benchmark of the completion network: latency of one 64×64 completion, and of 30 particles × 8 samples.

Measured on the default shipped U-net ``unet-houseexpo`` (Exp 1's (B), MCN-SLAM's default), through the public
functions, i.e. the inference fast path (:func:`mcnkit.completion.sample.inference_net`: spectral norm evaluated
once, batch norm folded) and the conversion to ternary included:

* one completion: :func:`mcnkit.completion.sample.complete` (eval mode, dropout off) on one 64×64 partial map;
  median over ``--repeats`` timed calls after warm-up (target ≤ 5 ms); the plain module call
  ``net(x)`` (spectral norm recomputed, batch norm unfused) is reported alongside for reference;
* sampling for a particle filter: 30 particles × 8 samples = 240 completions in one batch with dropout on
  (:func:`mcnkit.completion.sample.sample_completions`, conversion to ternary and label entropy included);
  median (target ≤ 100 ms).

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
from mcnkit.completion.nets import UNet, UNetConfig
from mcnkit.completion.sample import complete, sample_completions
from mcnkit.datasets import procedural_pairs


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
    ap.add_argument("--weights", nargs="+", default=[str(wdir / "unet-houseexpo")])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "results" / "completion.json"))
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

        def single(net: UNet = net) -> None:
            complete(net, partial[:1])

        def raw(net: UNet = net, one: torch.Tensor = one) -> None:
            with torch.no_grad():
                net(one)

        def batch(net: UNet = net, gen: torch.Generator = gen) -> None:
            sample_completions(net, partial, k=8, generator=gen)

        single_ms = _median_ms(single, args.repeats)
        raw_ms = _median_ms(raw, args.repeats)
        batch_ms = _median_ms(batch, max(5, args.repeats // 3))
        results.append(
            {
                "weights": source,
                "generator_config": net.config.as_dict(),
                "parameters": sum(p.numel() for p in net.parameters()),
                "single_64x64_ms": round(single_ms, 3),
                "single_64x64_plain_module_call_ms": round(raw_ms, 3),
                "particles30_x_samples8_ms": round(batch_ms, 2),
            }
        )
        print(
            f"{source}: one 64x64 completion {single_ms:.2f} ms (target <= 5 ms; plain net(x) {raw_ms:.2f} ms); "
            f"30 particles x 8 samples in one batch {batch_ms:.1f} ms (target <= 100 ms)"
        )
    result = {
        "threads": args.threads,
        "torch": torch.__version__,
        "machine": platform.processor() or platform.machine(),
        "single_target_ms": 5.0,
        "batch_target_ms": 100.0,
        "models": results,
    }
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
