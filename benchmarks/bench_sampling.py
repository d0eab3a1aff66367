"""Are the K sampled completions different plausible houses?  The sampler table for every shipped net.

For each shipped net (``mcnkit.completion.registry.MODELS``) and each set of test pairs (the Exp 1 HouseExpo test
pairs: the first 300 and 1,000 of the seeded shuffle of the official test list; and the net's own domain's test
pairs when it was trained on another domain) it draws K = 32 samples per m_t with
``mcnkit.completion.sample.sample_completions`` (seeded) and scores them with
:func:`mcnkit.completion.calibration.score_samples`: ECE and the per-cell majority on all 32, the per-sample
figures (error, spread, best-of-8, F of one sample and of the best, known cells kept, one free region,
roughness against the true maps') on the first 8.  It also times 30 partial maps × 8 samples at 2 threads, the
size of one MCN-SLAM step with 30 particles.

Targets (for ``sampler`` on the first 300 Exp 1 pairs): spread/error 0.8–1.2, ECE ≤ 0.05, best-of-8 / single
error ≤ 0.80, F of the best of 8 ≥ 0.77, F of the majority of 32 ≥ 0.75, known cells kept ≥ 99.5 %, one free
region ≥ 0.80, roughness / truth's 0.75–1.25; 30 × 8 samples ≤ 600 ms.

Writes ``benchmarks/results/sampling.json``, ``sampling.md`` and ``sampling_reliability.png`` (one reliability
diagram per pair set, a curve per net).

    .venv/bin/python benchmarks/bench_sampling.py [--models sampler unet] [--sizes 300 1000] [--k 32] [--k-per-sample 8]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
import torch

from mcnkit.completion.calibration import SampleScores, score_samples
from mcnkit.completion.data import load_domain_pairs
from mcnkit.completion.registry import MODELS, default_weights_dir
from mcnkit.completion.sample import sample_completions
from mcnkit.mcn import load_model

RESULTS = Path(__file__).resolve().parent / "results"
TARGETS = {"spread_over_error": (0.8, 1.2), "ece": (0.0, 0.05), "best_of_k_ratio": (0.0, 0.80),
           "f_best_of_k": (0.77, 1.0), "f_majority": (0.75, 1.0), "known_kept": (0.995, 1.0),
           "one_region": (0.80, 1.0), "roughness_ratio": (0.75, 1.25)}
TIMING_TARGET_MS = 600.0
TARGET_MODEL, TARGET_PAIRS = "sampler", "exp1-300"


def _samples(net: torch.nn.Module, partial: np.ndarray, k: int, seed: int, batch: int = 50) -> np.ndarray:
    generator = torch.Generator().manual_seed(seed)
    return np.concatenate([sample_completions(net, partial[i : i + batch], k, generator).samples  # type: ignore[arg-type]
                           for i in range(0, len(partial), batch)])


def _domain(model: str) -> str:
    """The training domain the net's checkpoint records (``info.train_config.domain`` of its JSON)."""
    card = json.loads((default_weights_dir() / f"{MODELS[model]}.json").read_text())
    return str(card["info"]["train_config"]["domain"])


def _verdict(s: SampleScores) -> str:
    missed = [name for name, (lo, hi) in TARGETS.items() if not lo <= getattr(s, name) <= hi]
    return "meets" if not missed else "misses " + ", ".join(missed)


def _step_ms(net: torch.nn.Module, partial: np.ndarray, repeats: int = 5) -> float:
    """Median wall time of 30 partial maps × 8 samples (one MCN-SLAM step of 30 particles)."""
    batch = partial[:30]
    _samples(net, batch, 8, 0, batch=30)  # warm-up: the frozen inference copy is built once
    times = []
    for r in range(repeats):
        t0 = time.perf_counter()
        _samples(net, batch, 8, r, batch=30)
        times.append(time.perf_counter() - t0)
    return 1000 * float(np.median(times))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS), help="shipped nets to score")
    ap.add_argument("--k", type=int, default=32, help="samples per m_t for ECE and the majority (default 32)")
    ap.add_argument("--k-per-sample", type=int, default=8,
                    help="the first samples used for spread, best-of-K, F and structure (default 8)")
    ap.add_argument("--sizes", nargs="+", type=int, default=[300, 1000],
                    help="how many Exp 1 test pairs (first N of the 1,000) per row (default 300 1000)")
    ap.add_argument("--own-test", type=int, default=300, help="test pairs of each net's own domain (default 300)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the samples' generator")
    ap.add_argument("--out", type=Path, default=RESULTS, help="folder for sampling.json/.md/_reliability.png")
    args = ap.parse_args()
    torch.set_num_threads(2)

    exp1 = load_domain_pairs("houseexpo", 200, 200, max(args.sizes), 0, progress=False).test
    sets: dict[str, tuple[np.ndarray, np.ndarray]] = {
        f"exp1-{n}": (exp1.partial[:n], exp1.target[:n]) for n in sorted(args.sizes)}
    rows: list[dict[str, object]] = []
    curves: dict[str, list[tuple[str, np.ndarray]]] = {}
    for model in args.models:
        net = load_model(model)
        domain = _domain(model)
        own: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        if domain != "houseexpo":
            pairs = load_domain_pairs(domain, 200, 200, args.own_test, 0, progress=False).test
            own[f"{domain}-{args.own_test}"] = (pairs.partial, pairs.target)
        step_ms = _step_ms(net, exp1.partial)
        print(f"{model:16s} 30 maps x 8 samples: {step_ms:.0f} ms (2 threads)", flush=True)
        for name, (partial, target) in {**sets, **own}.items():
            t0 = time.perf_counter()
            scores = score_samples(_samples(net, partial, args.k, args.seed), partial, target, first=args.k_per_sample)
            row = {"model": model, "pairs": name, "seconds": time.perf_counter() - t0, "step_30x8_ms": step_ms,
                   **scores.as_dict(), "verdict": _verdict(scores)}
            rows.append(row)
            curves.setdefault(name, []).append((model, scores.reliability))
            print(f"{model:16s} {name:22s} {scores.summary()}  {row['verdict']}", flush=True)

    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "sampling.json").write_text(json.dumps({
        "k": args.k, "k_per_sample": args.k_per_sample, "seed": args.seed, "targets": TARGETS,
        "timing_target_ms": TIMING_TARGET_MS, "target_row": [TARGET_MODEL, TARGET_PAIRS], "rows": rows}, indent=1))
    (args.out / "sampling.md").write_text(_markdown(rows, args.k, args.k_per_sample, args.seed))
    _plot(curves, args.out / "sampling_reliability.png")
    print(f"wrote {args.out / 'sampling.json'}, sampling.md, sampling_reliability.png")


def _markdown(rows: list[dict[str, object]], k: int, k_each: int, seed: int) -> str:
    lines = [f"# Sampled completions (`benchmarks/bench_sampling.py`, K = {k}, seed {seed})", "",
             f"On the cells unknown in m_t; ECE and the majority over {k} samples, the other figures over the first "
             f"{k_each}. Targets (`{TARGET_MODEL}`, `{TARGET_PAIRS}`): spread/error 0.8–1.2, ECE ≤ 0.05, best-of-8 / "
             "single ≤ 0.80, F best of 8 ≥ 0.77, F majority ≥ 0.75, known kept ≥ 99.5 %, one region ≥ 0.80, "
             f"roughness / truth 0.75–1.25; 30 × 8 samples ≤ {TIMING_TARGET_MS:.0f} ms.", "",
             "| net | pairs | error | spread/error | ECE | best-of-8 / single | F one | F majority | F best of 8 | "
             "known kept | one region | roughness / truth | 30×8 ms | verdict |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['model']} | {r['pairs']} | {r['error']:.3f} | {r['spread_over_error']:.2f} | "
                     f"{r['ece']:.3f} | {r['best_of_k_ratio']:.2f} | {r['f_single']:.3f} | {r['f_majority']:.3f} | "
                     f"{r['f_best_of_k']:.3f} | {r['known_kept']:.4f} | {r['one_region']:.2f} | "
                     f"{r['roughness_ratio']:.2f} | {r['step_30x8_ms']:.0f} | {r['verdict']} |")
    return "\n".join(lines) + "\n"


def _plot(curves: dict[str, list[tuple[str, np.ndarray]]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(curves), figsize=(3.6 * len(curves), 3.6), squeeze=False)
    for ax, (name, per_model) in zip(axes[0], curves.items(), strict=True):
        ax.plot([0, 1], [0, 1], color="0.6", lw=1, ls="--", label="calibrated")
        for model, table in per_model:
            filled = table[:, 2] > 0
            ax.plot(table[filled, 0], table[filled, 1], marker="o", ms=3, label=model)
        ax.set(title=name, xlabel="free probability (share of K samples)", xlim=(0, 1), ylim=(0, 1))
        ax.set_ylabel("observed free frequency")
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
