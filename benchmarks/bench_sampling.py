"""Do the K sampled completions mean something?  Issue 15's table for every shipped net.

For each shipped net (``mcnkit.completion.registry.MODELS``) and each set of test pairs — the Exp 1 HouseExpo
test pairs (the first 100, 300 and 1,000 of the seeded shuffle of the official test list) and the net's own
domain's test pairs (from its model card) — draws K samples per m_t with
``mcnkit.completion.sample.sample_completions`` (seeded) and scores them with
:func:`mcnkit.completion.calibration.score_samples` on the cells unknown in m_t: error, spread, spread/error,
ECE of the free probability the K samples estimate, best-of-K error ratio, free-space F of one sample, of the
per-cell majority and of the best sample.  Targets (issue 15, ``unet`` on 300 pairs, K = 8): spread/error in
0.7–1.3, ECE ≤ 0.05, best-of-K ratio ≤ 0.85, F single ≥ 0.70, F majority ≥ 0.77.

Writes ``benchmarks/results/sampling.json``, ``sampling.md`` and ``sampling_reliability.png`` (one reliability
diagram per pair set, a curve per net).

    .venv/bin/python benchmarks/bench_sampling.py [--k 8] [--models unet pix2pix] [--sizes 100 300 1000]
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
TARGETS = {"spread_over_error": (0.7, 1.3), "ece": (0.0, 0.05), "best_of_k_ratio": (0.0, 0.85),
           "f_single": (0.70, 1.0), "f_majority": (0.77, 1.0)}


def _samples(net: torch.nn.Module, partial: np.ndarray, k: int, seed: int, batch: int = 100) -> np.ndarray:
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=list(MODELS), choices=list(MODELS), help="shipped nets to score")
    ap.add_argument("--k", type=int, default=8, help="samples per m_t (default 8)")
    ap.add_argument("--sizes", nargs="+", type=int, default=[100, 300, 1000],
                    help="how many Exp 1 test pairs (first N of the 1,000) per row (default 100 300 1000)")
    ap.add_argument("--own-test", type=int, default=100, help="test pairs of each net's own domain (default 100)")
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
        for name, (partial, target) in {**sets, **own}.items():
            t0 = time.perf_counter()
            scores = score_samples(_samples(net, partial, args.k, args.seed), partial, target)
            row = {"model": model, "pairs": name, "seconds": time.perf_counter() - t0, **scores.as_dict(),
                   "verdict": _verdict(scores)}
            rows.append(row)
            curves.setdefault(name, []).append((model, scores.reliability))
            print(f"{model:16s} {name:22s} {scores.summary()}  {row['verdict']}", flush=True)

    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "sampling.json").write_text(json.dumps({"k": args.k, "seed": args.seed, "targets": TARGETS,
                                                        "rows": rows}, indent=1))
    lines = [f"# Sampled completions (`benchmarks/bench_sampling.py`, K = {args.k}, seed {args.seed})", "",
             "On the cells unknown in m_t. Targets (issue 15, `unet`, 300 pairs): spread/error 0.7–1.3, ECE ≤ 0.05, "
             "best-of-K / single error ≤ 0.85, F one sample ≥ 0.70, F majority ≥ 0.77.", "",
             "| net | pairs | error | spread | spread/error | ECE | best-of-K / single | F one | F majority | F best | verdict |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['model']} | {r['pairs']} | {r['error']:.3f} | {r['spread']:.3f} | {r['spread_over_error']:.2f} | "
                     f"{r['ece']:.3f} | {r['best_of_k_ratio']:.2f} | {r['f_single']:.3f} | {r['f_majority']:.3f} | "
                     f"{r['f_best_of_k']:.3f} | {r['verdict']} |")
    (args.out / "sampling.md").write_text("\n".join(lines) + "\n")
    _plot(curves, args.out / "sampling_reliability.png")
    print(f"wrote {args.out / 'sampling.json'}, sampling.md, sampling_reliability.png")


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
