"""Experiment 1's report: the Markdown tables (ours, then the paper's) and the example figure."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from mcnkit.completion.sample import SampleSet
from mcnkit.datasets import PairSet
from mcnkit.experiments import paper
from mcnkit.experiments.rows import Exp1Row, Exp1SampleRow, Exp1SamplerRow

__all__ = ["example_figure", "markdown"]


def _row(r: Exp1Row) -> str:
    s = r.scores
    return (f"| {r.method} | {r.train_domain} | {r.test_domain} | {s.n_maps} | {s.accuracy:.4f} | "
            f"{s.precision:.4f} | {s.recall:.4f} | {s.f_measure:.4f} ± {s.f_ci95:.4f} | "
            f"{s.miou_unknown:.4f} ± {s.miou_ci95:.4f} | {s.pooled_f_measure:.4f} | {s.pooled_miou_unknown:.4f} |")


def markdown(rows: list[Exp1Row], diversity: dict[str, float], n_samples: int, notes: list[str],
             sampled: list[Exp1SampleRow] | None = None, houses: list[Exp1SamplerRow] | None = None) -> str:
    """``exp1.md``: per positive class the table of ``rows``, the paper's table, the sampled table (best-of-K,
    calibration), the sampler table (are the samples whole houses), the sample diversity (``n_samples`` samples
    per example) and the notes."""
    lines = ["# Experiment 1: map completion (HouseExpo, one Pseudo-SLAM scan) and cross-domain", ""]
    for positive in ("free", "occupied"):
        lines += [
            f"## Positive class: {positive}" + (" (the paper's reading, primary)" if positive == "free" else ""),
            "",
            "| method | train | test | n | Acc | Prec | Rec | F (±95 %) | mIoU unknown (±95 %) | pooled F | pooled mIoU |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        lines += [_row(r) for r in rows if r.scores.positive_class == positive]
        lines.append("")
    lines += ["## The paper's Table (free space positive; Acc / Prec / Rec / F)", "", "| method | Acc | Prec | Rec | F |",
              "|---|---|---|---|---|", *paper.markdown_rows(paper.EXP1), ""]  # fmt: skip
    if sampled:
        k = sampled[0].k
        lines += [f"## Sampled completions ({k} per test map; cells unknown in m_t; free space positive for F)", "",
                  "| method | train | test | n | error | spread / error | ECE | best-of-K / single error | F one "
                  "sample | F majority | F best of K |", "|---|---|---|---|---|---|---|---|---|---|---|"]
        lines += [f"| {r.method} | {r.train_domain} | {r.test_domain} | {r.n_maps} | {r.error:.3f} | "
                  f"{r.spread_over_error:.2f} | {r.ece:.3f} | {r.best_of_k_ratio:.2f} | {r.f_single:.3f} | "
                  f"{r.f_majority:.3f} | {r.f_best_of_k:.3f} |" for r in sampled]
        lines.append("")
    if houses:
        h = houses[0]
        lines += [f"## Sampler: are the samples whole houses? (ECE and majority over {h.k_frequencies} samples per "
                  f"test map, the rest over the first {h.k}; cells unknown in m_t)", "",
                  "| method | train | test | n | spread / error | ECE | best-of-8 / single error | F best of 8 | "
                  "F majority | known cells kept | one free region | roughness / truth's |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        lines += [f"| {r.method} | {r.train_domain} | {r.test_domain} | {r.n_maps} | {r.spread_over_error:.2f} | "
                  f"{r.ece:.3f} | {r.best_of_k_ratio:.2f} | {r.f_best_of_k:.3f} | {r.f_majority:.3f} | "
                  f"{r.known_kept:.4f} | {r.one_region:.2f} | {r.roughness_ratio:.2f} |" for r in houses]
        lines += ["", "One free region: the share of samples whose free space is one 4-connected region (specks "
                  "under 4 cells ignored); roughness: free/non-free cell edges per √(free cells), over the true "
                  "maps' (1: as rough as real houses; below: blobs without interior walls; above: noise).", ""]
    if diversity:
        lines += [f"## Sample diversity ({n_samples} samples, dropout on; share of cells two samples differ on)", ""]
        lines += [f"- {k}: {v:.4f}" for k, v in diversity.items()] + [""]
    lines += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(lines)


def example_figure(path: Path, test: PairSet, idx: NDArray[np.int64], samples: dict[str, SampleSet]) -> None:
    """One row per example map ``test[idx]``: m_t, each network's samples and their uncertainty, m_T."""
    from matplotlib.figure import Figure

    k = next(iter(samples.values())).samples.shape[1]
    cols = 1 + sum(k + 1 for _ in samples) + 1
    fig = Figure(figsize=(1.6 * cols, 1.7 * len(idx)))
    axes = fig.subplots(len(idx), cols, squeeze=False)
    for r, i in enumerate(idx):
        panels: list[tuple[str, NDArray[np.floating], str]] = [("m_t", test.partial[i], "gray_r")]
        for name, s in samples.items():
            panels += [(f"{name} s{j + 1}", s.samples[r, j], "gray_r") for j in range(k)]
            panels.append((f"{name} uncert.", s.uncertainty[r], "magma"))
        panels.append(("m_T", test.target[i], "gray_r"))
        for c, (title, img, cmap) in enumerate(panels):
            ax = axes[r, c]
            ax.imshow(img, cmap=cmap, vmin=0.0, vmax=1.0, interpolation="nearest")
            ax.set_xticks([])
            ax.set_yticks([])
            if r == 0:
                ax.set_title(title, fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
