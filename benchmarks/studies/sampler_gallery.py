"""What the sampled completions look like: test maps, their truth and K samples side by side.

For the first ``--maps`` test pairs of ``--domain`` (default ``houseexpo``: Experiment 1's, one 180°, 2 m scan;
``houseexpo-explore``: the maps part-way through an exploration that the ``*-explore`` nets complete;
``houseexpo-seen``: the same maps on the window ``mcnkit explore`` completes) one row
each: m_t, the true map m_T, ``--show`` of the K samples a shipped net draws
(``mcnkit.completion.sample.sample_completions``, seeded) and the per-cell frequency of "free" over all K
(white: every sample free, black: none; grey where they disagree).
The figures of :mod:`benchmarks.bench_sampling` say whether samples are calibrated and whole; this picture is
for looking at them: are rooms closed, are there doors, are walls straight?

Writes ``benchmarks/results/sampler_gallery_<model>.png`` (``_<model>_<domain>.png`` for another domain).

    .venv/bin/python -m benchmarks.studies.sampler_gallery [--model sampler] [--domain houseexpo] [--maps 10] [--k 16]
        [--show 5]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import torch

from benchmarks.common import RESULTS
from mcnkit.completion.data import load_domain_pairs
from mcnkit.completion.registry import DOMAINS, MODELS
from mcnkit.completion.sample import sample_completions
from mcnkit.mcn import load_model


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--model", default="sampler", choices=list(MODELS), help="the shipped net that draws the samples")
    ap.add_argument("--domain", default="houseexpo", choices=DOMAINS,
                    help="whose test pairs: houseexpo (Experiment 1's, default), houseexpo-explore, houseexpo-seen (on the "
                         "explorer's window) or procedural")
    ap.add_argument("--maps", type=int, default=10, help="test pairs shown, the first of the domain's (default 10)")
    ap.add_argument("--k", type=int, default=16, help="samples drawn per map, for the frequency column (default 16)")
    ap.add_argument("--show", type=int, default=5, help="samples shown per map (default 5)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the samples' generator (default 0)")
    ap.add_argument("--out", type=Path, default=None,
                    help="PNG to write (default results/sampler_gallery_MODEL[_DOMAIN].png)")
    a = ap.parse_args(argv)
    if not 1 <= a.show <= a.k:
        ap.error(f"--show {a.show} must be between 1 and --k {a.k}")
    test = load_domain_pairs(a.domain, 200, 200, 1000, 0, progress=False).test
    partial, target = test.partial[: a.maps], test.target[: a.maps]
    net = load_model(a.model)
    samples = sample_completions(net, partial, a.k, torch.Generator().manual_seed(a.seed)).samples
    free_freq = (samples == 0.0).mean(axis=1)
    cols = 3 + a.show
    fig, axes = plt.subplots(a.maps, cols, figsize=(1.6 * cols, 1.6 * a.maps), squeeze=False)
    for i in range(a.maps):
        panels = [partial[i], target[i], *samples[i, : a.show]]
        for j, img in enumerate(panels):
            axes[i, j].imshow(img, cmap="gray_r", vmin=0, vmax=1, interpolation="nearest")
        axes[i, -1].imshow(free_freq[i], cmap="gray", vmin=0, vmax=1, interpolation="nearest")
    titles = ["m_t", "m_T (truth)", *[f"sample {j + 1}" for j in range(a.show)], f"free freq. (K={a.k})"]
    for j, t in enumerate(titles):
        axes[0, j].set_title(t, fontsize=8)
    for ax in axes.ravel():
        ax.set_xticks([])
        ax.set_yticks([])
    which = "Exp 1" if a.domain == "houseexpo" else a.domain
    fig.suptitle(f"{a.model}: the first {a.maps} {which} test maps (black occupied, grey unknown, white free)",
                 fontsize=9)
    fig.tight_layout()
    suffix = "" if a.domain == "houseexpo" else f"_{a.domain}"
    out = a.out or RESULTS / f"sampler_gallery_{a.model}{suffix}.png"
    fig.savefig(out, dpi=80)
    print(out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
