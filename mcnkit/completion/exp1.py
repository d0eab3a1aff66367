"""Experiment 1 (the paper's Table): map completion from one Pseudo-SLAM scan on HouseExpo, plus cross-domain.

Rows, each scored with free space and with occupied space as the positive class (:mod:`scores`):
(A) pix2pix and (B) U-net trained on HouseExpo, U-net trained on the procedural domain (our stand-in for
HOME'S), (C) the partial map m_t itself, (D) retrieval from the test domain's training maps, and the sanity
rows "unknown filled all-free" / "all-occupied".  Test domains: HouseExpo (the first ``n_test`` official test
pairs; the first 100 are the paper's protocol) and the procedural test set.  Networks give their
deterministic completion (dropout off); the figure shows K samples with dropout on and their uncertainty.

Outputs in ``out_dir``: ``exp1.csv`` (one row per method × train domain × test domain × positive class),
``exp1.md`` (tables, the paper's numbers for comparison, sample diversity) and ``exp1_examples.png``.
"""

from __future__ import annotations

import csv
import os
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.completion.checkpoint import load_generator
from mcnkit.completion.data import load_domain_pairs
from mcnkit.completion.nets import UNet
from mcnkit.completion.registry import default_weights_dir
from mcnkit.completion.retrieval import retrieve
from mcnkit.completion.sample import complete, sample_completions
from mcnkit.completion.scores import score_maps
from mcnkit.datasets import PairSet, procedural_pairs
from mcnkit.types import FREE, OCCUPIED, UNKNOWN

__all__ = ["CSV_COLUMNS", "SHIPPED", "Exp1Config", "default_weights_dir", "run_exp1"]

CSV_COLUMNS = [
    "method", "train_domain", "test_domain", "n_maps", "positive_class", "accuracy", "precision", "recall",
    "f_measure", "f_ci95", "miou_unknown", "miou_ci95", "pooled_accuracy", "pooled_precision", "pooled_recall",
    "pooled_f_measure", "pooled_miou_unknown",
]  # fmt: skip
# (row label, checkpoint name, train domain)
SHIPPED = (
    ("(A) pix2pix", "pix2pix-houseexpo", "houseexpo"),
    ("(B) U-net", "unet-houseexpo", "houseexpo"),
    ("(B) U-net", "unet-procedural", "procedural"),
)
PAPER = """| (A) pix2pix | 0.5831 | 0.8613 | 0.3762 | 0.4939 |
| (B) U-net | 0.5852 | 0.8612 | 0.3807 | 0.4963 |
| (C) Pseudo SLAM | 0.4340 | 0.8517 | 0.0616 | 0.1110 |
| (D) training map with highest precision | 0.4893 | 0.8026 | 0.1753 | 0.2734 |
| (A) pix2pix trained on HOME'S | 0.5065 | 0.8537 | 0.2222 | 0.3481 |
| (B) U-net trained on HOME'S | 0.5257 | 0.7915 | 0.2976 | 0.4286 |"""


@dataclass(frozen=True)
class Exp1Config:
    """Where to write, which weights, how many test maps, the pair splits to read."""

    out_dir: str = "results/exp1"
    weights_dir: str | None = None
    n_test: int = 100
    n_train: int = 16000
    n_procedural_train: int = 4000
    n_procedural_test: int = 100
    n_samples: int = 4
    n_examples: int = 4
    seed: int = 0
    houseexpo: str | None = None
    cache_dir: str | None = None
    threads: int = 2


def _fill(partial: NDArray[np.floating], value: float) -> NDArray[np.float32]:
    out = np.asarray(partial, np.float32).copy()
    out[out == UNKNOWN] = value
    return out


def _rows(
    method: str, train_domain: str, test_domain: str, pred: NDArray[np.floating], test: PairSet
) -> list[dict[str, object]]:
    rows: list[dict[str, object]] = []
    for positive in ("free", "occupied"):
        s = score_maps(pred, test.target, test.partial, positive)
        d = s.as_dict()
        rows.append({"method": method, "train_domain": train_domain, "test_domain": test_domain, **d})
    return rows


def _figure(path: Path, test: PairSet, nets: dict[str, UNet], k: int, n: int, seed: int) -> dict[str, float]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    idx = np.linspace(0, len(test) - 1, min(n, len(test))).astype(int)
    cols = 1 + sum(k + 1 for _ in nets) + 1
    fig, axes = plt.subplots(len(idx), cols, figsize=(1.6 * cols, 1.7 * len(idx)), squeeze=False)
    diversity: dict[str, float] = {}
    sets = {}
    for name, net in nets.items():
        s = sample_completions(net, test.partial[idx], k, torch.Generator().manual_seed(seed))
        sets[name] = s
        diversity[name] = float(s.diversity.mean())
    for r, i in enumerate(idx):
        panels: list[tuple[str, NDArray[np.floating], str]] = [("m_t", test.partial[i], "gray_r")]
        for name, s in sets.items():
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
    plt.close(fig)
    return diversity


def _md(rows: list[dict[str, object]], diversity: dict[str, float], cfg: Exp1Config, notes: list[str]) -> str:
    lines = ["# Experiment 1: map completion (HouseExpo, one Pseudo-SLAM scan) and cross-domain", ""]
    for positive in ("free", "occupied"):
        lines += [
            f"## Positive class: {positive}" + (" (the paper's reading, primary)" if positive == "free" else ""),
            "",
            "| method | train | test | n | Acc | Prec | Rec | F (±95 %) | mIoU unknown (±95 %) | pooled F | pooled mIoU |",
            "|---|---|---|---|---|---|---|---|---|---|---|",
        ]
        for r in rows:
            if r["positive_class"] != positive:
                continue
            lines.append(
                f"| {r['method']} | {r['train_domain']} | {r['test_domain']} | {r['n_maps']} | {r['accuracy']:.4f} | "
                f"{r['precision']:.4f} | {r['recall']:.4f} | {r['f_measure']:.4f} ± {r['f_ci95']:.4f} | "
                f"{r['miou_unknown']:.4f} ± {r['miou_ci95']:.4f} | {r['pooled_f_measure']:.4f} | {r['pooled_miou_unknown']:.4f} |"
            )
        lines.append("")
    lines += ["## The paper's Table (free space positive; Acc / Prec / Rec / F)", "", "| method | Acc | Prec | Rec | F |",
              "|---|---|---|---|---|", PAPER, ""]  # fmt: skip
    if diversity:
        lines += [
            f"## Sample diversity ({cfg.n_samples} samples, dropout on; share of cells two samples differ on)",
            "",
        ]
        lines += [f"- {k}: {v:.4f}" for k, v in diversity.items()] + [""]
    lines += ["## Notes", ""] + [f"- {n}" for n in notes] + [""]
    return "\n".join(lines)


def run_exp1(cfg: Exp1Config) -> str:
    """Runs Experiment 1 and writes its outputs; returns the Markdown report."""
    t0 = time.perf_counter()
    torch.set_num_threads(max(1, cfg.threads))
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    wdir = Path(cfg.weights_dir) if cfg.weights_dir else default_weights_dir()
    he = load_domain_pairs("houseexpo", cfg.n_train, 200, 1000, cfg.seed, cfg.houseexpo, cfg.cache_dir, progress=False)
    if not 1 <= cfg.n_test <= len(he.test):
        raise ValueError(f"n_test must be in 1..{len(he.test)}, got {cfg.n_test}")
    he_test = PairSet(he.test.partial[: cfg.n_test], he.test.target[: cfg.n_test], he.test.ids[: cfg.n_test])
    proc = procedural_pairs(cfg.n_procedural_train, 0, cfg.n_procedural_test, seed=cfg.seed)
    tests = {"houseexpo": (he_test, he.train.target), "procedural": (proc.test, proc.train.target)}
    nets: dict[tuple[str, str], UNet] = {}
    notes = [
        f"HouseExpo test: the first {cfg.n_test} of the seeded shuffle of the official test list "
        f"(the first 100 are the paper protocol); procedural test: {cfg.n_procedural_test} apartments with HOME'S masking.",
        "Networks: deterministic completion (dropout off), output converted by the paper's rule.",
        "(D) retrieval: training m_T with the highest agreement on m_t's observed cells, observed cells pasted over it "
        f"(bank: {len(he.train)} HouseExpo / {len(proc.train)} procedural training maps).",
        "mIoU unknown: mean IoU over {free, occupied} on the cells unknown in m_t (per-map mean ± 95 % CI).",
    ]
    for label, name, domain in SHIPPED:
        path = wdir / name
        if not (wdir / f"{name}.safetensors").is_file():
            notes.append(f"{label} trained on {domain}: no checkpoint {path}.safetensors — row left out.")
            continue
        net, _ = load_generator(path)
        nets[(label, domain)] = net
    rows: list[dict[str, object]] = []
    for test_domain, (test, bank) in tests.items():
        for (label, train_domain), net in nets.items():
            rows += _rows(label, train_domain, test_domain, complete(net, test.partial), test)
        rows += _rows("(C) partial map", "-", test_domain, test.partial, test)
        rows += _rows("(D) retrieval", test_domain, test_domain, retrieve(test.partial, bank).prediction, test)
        rows += _rows("unknown filled all-free", "-", test_domain, _fill(test.partial, FREE), test)
        rows += _rows("unknown filled all-occupied", "-", test_domain, _fill(test.partial, OCCUPIED), test)
    with open(out / "exp1.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=CSV_COLUMNS, extrasaction="ignore")
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.6f}" if isinstance(v, float) else v) for k, v in r.items()})
    fig_nets = {
        lab.split()[1]: n
        for (lab, dom), n in nets.items()
        if dom == "houseexpo" and lab in ("(A) pix2pix", "(B) U-net")
    }
    diversity = (
        _figure(out / "exp1_examples.png", he_test, fig_nets, cfg.n_samples, cfg.n_examples, cfg.seed)
        if fig_nets
        else {}
    )
    notes.append(f"wall time {time.perf_counter() - t0:.0f} s; figure: exp1_examples.png ({os.fspath(out)})")
    md = _md(rows, diversity, cfg, notes)
    (out / "exp1.md").write_text(md)
    return md
