"""Experiment 1 (the paper's Table): map completion from one Pseudo-SLAM scan on HouseExpo, plus cross-domain.

Rows, each scored with free space and with occupied space as the positive class (:mod:`mcnkit.completion.scores`):
(A) pix2pix and (B) U-net trained on HouseExpo, U-net trained on the procedural domain (our stand-in for
HOME'S), (C) the partial map m_t itself, (D) retrieval from the test domain's training maps, and the sanity
rows "unknown filled all-free" / "all-occupied".  Test domains: HouseExpo (the first ``n_test`` official test
pairs; the first 100 are the paper's protocol) and the procedural test set.  Networks give their
deterministic completion (dropout off); the figure shows K samples with dropout on and their uncertainty.

Outputs in ``out_dir``: ``exp1.csv`` (one row per method × train domain × test domain × positive class),
``exp1_samples.csv`` (K = 8 samples per test map, scored), ``exp1_sampler.csv`` (the sampler table: are the samples
whole houses), ``exp1.md`` (tables, the paper's numbers for comparison, sample diversity) and ``exp1_examples.png``.
"""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path
from typing import TypeVar

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.completion.calibration import score_samples
from mcnkit.completion.checkpoint import load_generator
from mcnkit.completion.data import load_domain_pairs
from mcnkit.completion.nets import CompletionNet
from mcnkit.completion.registry import default_weights_dir
from mcnkit.completion.retrieval import retrieve
from mcnkit.completion.sample import SampleSet, complete, sample_completions
from mcnkit.completion.scores import score_maps
from mcnkit.datasets import PairSet, procedural_pairs
from mcnkit.experiments.common import fill_unknown
from mcnkit.experiments.config import Exp1Config
from mcnkit.experiments.exp1_report import example_figure, markdown
from mcnkit.experiments.rows import EXP1_COLUMNS, Exp1Row, Exp1SampleRow, Exp1SamplerRow
from mcnkit.experiments.tables import write_rows
from mcnkit.threads import torch_threads
from mcnkit.types import FREE, OCCUPIED

__all__ = ["SHIPPED", "Exp1Config", "run_exp1"]

SHIPPED = (
    ("(A) pix2pix", "pix2pix-houseexpo", "houseexpo"),
    ("(B) U-net", "unet-houseexpo", "houseexpo"),
    ("(B) U-net", "unet-procedural", "procedural"),
    ("(S) sampler", "sampler-houseexpo", "houseexpo"),
)
"""(row label, checkpoint name, train domain) of the shipped networks."""
FIGURE_NETS = {("(A) pix2pix", "houseexpo"): "pix2pix", ("(B) U-net", "houseexpo"): "U-net",
               ("(S) sampler", "houseexpo"): "sampler"}
"""The networks of the example figure (row label, train domain) and their column titles."""


def _rows(method: str, train_domain: str, test_domain: str, pred: NDArray[np.floating], test: PairSet
          ) -> list[Exp1Row]:
    return [Exp1Row(method, train_domain, test_domain, score_maps(pred, test.target, test.partial, positive))
            for positive in ("free", "occupied")]


def _example_samples(test: PairSet, nets: dict[str, CompletionNet], k: int, n: int, seed: int
                     ) -> tuple[NDArray[np.int64], dict[str, SampleSet]]:
    """The example maps (``n`` spread over the test set) and each network's ``k`` samples of them."""
    idx = np.linspace(0, len(test) - 1, min(n, len(test))).astype(int)
    return idx, {name: sample_completions(net, test.partial[idx], k, torch.Generator().manual_seed(seed))
                 for name, net in nets.items()}


SAMPLE_K = 8
"""Samples per test map for the sampled table."""
SAMPLER_K = 32
"""Samples per test map behind the sampler table's frequencies (ECE, majority); its other figures take the first
:data:`SAMPLE_K`."""


R = TypeVar("R", Exp1SampleRow, Exp1SamplerRow)


def _sample_row(
    row: type[R], label: str, train_domain: str, test_domain: str, net: CompletionNet, test: PairSet, k: int,
    seed: int, first: int | None = None,
) -> R:
    """``net``'s ``k`` samples of every test map (seeded, in batches of 100), scored (``first``: see
    :func:`~mcnkit.completion.calibration.score_samples`) into a row of ``row``."""
    generator = torch.Generator().manual_seed(seed)
    samples = np.concatenate([sample_completions(net, test.partial[i : i + 100], k, generator).samples
                              for i in range(0, len(test), 100)])
    scores = score_samples(samples, test.partial, test.target, first=first)
    figures = {f.name: getattr(scores, f.name) for f in dataclasses.fields(row) if hasattr(scores, f.name)}
    return row(label, train_domain, test_domain, **figures)


def run_exp1(cfg: Exp1Config) -> str:
    """Runs Experiment 1 and writes its outputs; returns the Markdown report."""
    with torch_threads(cfg.threads):
        return _run_exp1(cfg)


def _run_exp1(cfg: Exp1Config) -> str:
    t0 = time.perf_counter()
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    wdir = Path(cfg.weights_dir) if cfg.weights_dir else default_weights_dir()
    he = load_domain_pairs("houseexpo", cfg.n_train, 200, 1000, cfg.seed, cfg.houseexpo, cfg.cache_dir, progress=False)
    if not 1 <= cfg.n_test <= len(he.test):
        raise ValueError(f"n_test must be in 1..{len(he.test)}, got {cfg.n_test}")
    he_test = PairSet(he.test.partial[: cfg.n_test], he.test.target[: cfg.n_test], he.test.ids[: cfg.n_test])
    proc = procedural_pairs(cfg.n_procedural_train, 0, cfg.n_procedural_test, seed=cfg.seed)
    tests = {"houseexpo": (he_test, he.train.target), "procedural": (proc.test, proc.train.target)}
    nets: dict[tuple[str, str], CompletionNet] = {}
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
    rows: list[Exp1Row] = []
    for test_domain, (test, bank) in tests.items():
        for (label, train_domain), net in nets.items():
            rows += _rows(label, train_domain, test_domain, complete(net, test.partial), test)
        rows += _rows("(C) partial map", "-", test_domain, test.partial, test)
        rows += _rows("(D) retrieval", test_domain, test_domain, retrieve(test.partial, bank).prediction, test)
        rows += _rows("unknown filled all-free", "-", test_domain, fill_unknown(test.partial, FREE), test)
        rows += _rows("unknown filled all-occupied", "-", test_domain, fill_unknown(test.partial, OCCUPIED), test)
    write_rows(out / "exp1.csv", rows, Exp1Row, EXP1_COLUMNS)
    sampled = [_sample_row(Exp1SampleRow, label, train_domain, "houseexpo", net, he_test, SAMPLE_K, cfg.seed)
               for (label, train_domain), net in nets.items()]
    write_rows(out / "exp1_samples.csv", sampled, Exp1SampleRow)
    houses = [_sample_row(Exp1SamplerRow, label, train_domain, "houseexpo", net, he_test, SAMPLER_K, cfg.seed,
                          first=SAMPLE_K) for (label, train_domain), net in nets.items()]
    write_rows(out / "exp1_sampler.csv", houses, Exp1SamplerRow)
    fig_nets = {title: nets[key] for key, title in FIGURE_NETS.items() if key in nets}
    diversity: dict[str, float] = {}
    if fig_nets:
        idx, samples = _example_samples(he_test, fig_nets, cfg.n_samples, cfg.n_examples, cfg.seed)
        example_figure(out / "exp1_examples.png", he_test, idx, samples)
        diversity = {name: float(s.diversity.mean()) for name, s in samples.items()}
    notes.append(f"wall time {time.perf_counter() - t0:.0f} s; figure: exp1_examples.png ({os.fspath(out)})")
    md = markdown(rows, diversity, cfg.n_samples, notes, sampled, houses)
    (out / "exp1.md").write_text(md)
    return md
