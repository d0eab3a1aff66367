"""What would a *calibrated* sampler built on today's nets score?  (Are the sampling targets reachable together?)

For each net, the per-cell label probabilities P(free | outputs), P(occupied | ...), P(unknown | ...) are
estimated on the Exp 1 **validation** pairs (a 20 × 20 histogram over the net's two output channels, cells
unknown in m_t only, add-2 smoothing toward the overall label shares), then K labels per cell are drawn on the
test pairs by inverse-CDF with spatially correlated uniforms (a Gaussian field blurred with σ = L cells and
mapped through Φ; L = 0 is independent per cell).  Such a sampler is calibrated by construction (up to the
histogram's resolution and the validation/test shift), so its figures say what calibration costs in F with the
information the nets have: spread/error ≈ 1 and ECE small, but every sample is as wrong as the per-cell
uncertainty says, so the F of one sample (and of the majority of K) falls below the deterministic completion's.

This is a measurement, not the shipped sampler.  Writes ``benchmarks/results/sampling_calibrated_bound.json``/``.md``.

    .venv/bin/python -m benchmarks.studies.sampling_calibrated_bound [--models unet pix2pix] [--lengths 0 2 4 8]
"""

from __future__ import annotations

import argparse
import json

import numpy as np
import torch
from scipy.ndimage import gaussian_filter
from scipy.special import ndtr

from benchmarks.common import RESULTS
from mcnkit.completion.calibration import score_samples
from mcnkit.completion.data import load_domain_pairs
from mcnkit.completion.registry import MODELS
from mcnkit.completion.sample import network_outputs
from mcnkit.mcn import load_model
from mcnkit.types import FREE, OCCUPIED, UNKNOWN

LABELS = np.array([FREE, OCCUPIED, UNKNOWN], np.float32)
BINS = 20


def _bin(outputs: np.ndarray) -> np.ndarray:
    """Histogram cell of each map cell's (image', mask') output pair → (N, H, W) in [0, BINS²)."""
    i = np.clip((outputs[:, 0] * BINS).astype(np.int64), 0, BINS - 1)
    j = np.clip((outputs[:, 1] * BINS).astype(np.int64), 0, BINS - 1)
    return i * BINS + j


def label_table(outputs: np.ndarray, partial: np.ndarray, target: np.ndarray) -> np.ndarray:
    """(BINS², 3) probabilities of free / occupied / unknown in m_T per output bin, on cells unknown in m_t."""
    unknown = partial == UNKNOWN
    index = _bin(outputs)[unknown]
    counts = np.stack([np.bincount(index, weights=target[unknown] == v, minlength=BINS * BINS) for v in LABELS], 1)
    prior = counts.sum(0) / counts.sum()
    return (counts + 2 * prior) / (counts.sum(1, keepdims=True) + 2)


def draw(probs: np.ndarray, partial: np.ndarray, k: int, length: float, rng: np.random.Generator) -> np.ndarray:
    """K samples (N, K, H, W) from per-cell label probabilities (N, H, W, 3) with correlated uniforms."""
    z = rng.standard_normal((len(probs), k, *probs.shape[1:3]))
    if length > 0:
        z = gaussian_filter(z, sigma=(0, 0, length, length), mode="wrap")
        z /= z.std(axis=(-2, -1), keepdims=True)
    u = ndtr(z)
    index = (u[..., None] > np.cumsum(probs, axis=-1)[:, None]).sum(-1).clip(0, 2)
    return np.where(partial[:, None] != UNKNOWN, partial[:, None], LABELS[index]).astype(np.float32)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", default=["unet", "pix2pix"], choices=list(MODELS), help="nets")
    ap.add_argument("--lengths", nargs="+", type=float, default=[0, 2, 4, 8], help="field correlation lengths, cells")
    ap.add_argument("--n-test", type=int, default=300, help="Exp 1 test pairs (default 300)")
    ap.add_argument("--k", type=int, default=8, help="samples per m_t (default 8)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the fields")
    ap.add_argument("--fit-on", choices=["val", "test"], default="val",
                    help="pairs the label probabilities are fitted on: val (a real sampler) or test (the ideal "
                         "calibration, an upper bound for this information; not a sampler one could ship)")
    args = ap.parse_args()
    torch.set_num_threads(2)
    pairs = load_domain_pairs("houseexpo", 200, 200, args.n_test, 0, progress=False)
    rows = []
    for model in args.models:
        net = load_model(model)
        fit = pairs.val if args.fit_on == "val" else pairs.test
        table = label_table(network_outputs(net, fit.partial), fit.partial, fit.target)
        probs = table[_bin(network_outputs(net, pairs.test.partial))]
        for length in args.lengths:
            s = score_samples(draw(probs, pairs.test.partial, args.k, length, np.random.default_rng(args.seed)),
                              pairs.test.partial, pairs.test.target)
            rows.append({"model": model, "length_cells": length, "fit_on": args.fit_on, **s.as_dict()})
            print(f"{model:8s} L={length:4.1f}  {s.summary()}", flush=True)
    RESULTS.mkdir(exist_ok=True)
    stem = "sampling_calibrated_bound" + ("" if args.fit_on == "val" else "_ideal")
    (RESULTS / f"{stem}.json").write_text(json.dumps({"k": args.k, "n_test": args.n_test,
                                                                        "rows": rows}, indent=1))
    lines = ["# A calibrated sampler on today's nets (`benchmarks/studies/sampling_calibrated_bound.py`)", "",
             f"Exp 1 test pairs: {args.n_test}, K = {args.k}; label probabilities calibrated on the {args.fit_on} pairs"
             + (" (the ideal calibration: an upper bound, not a sampler)." if args.fit_on == "test" else "."), "",
             "| net | L (cells) | error | spread/error | ECE | best-of-K / single | F one | F majority | F best |",
             "|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| {r['model']} | {r['length_cells']:g} | {r['error']:.3f} | {r['spread_over_error']:.2f} | {r['ece']:.3f} | "
              f"{r['best_of_k_ratio']:.2f} | {r['f_single']:.3f} | {r['f_majority']:.3f} | {r['f_best_of_k']:.3f} |"
              for r in rows]
    (RESULTS / f"{stem}.md").write_text("\n".join(lines) + "\n")
    print(f"wrote {RESULTS / stem}.json and .md")


if __name__ == "__main__":
    main()
