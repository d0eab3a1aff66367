"""Experiment 1 on a small split with the shipped weights: the tables, the sampled and sampler tables, the figure."""

from __future__ import annotations

from pathlib import Path

import pytest

from mcnkit.experiments.config import Exp1Config
from mcnkit.experiments.exp1 import SAMPLE_K, SAMPLER_K, run_exp1
from mcnkit.experiments.rows import Exp1Row, Exp1SampleRow, Exp1SamplerRow
from mcnkit.experiments.tables import read_rows


@pytest.mark.slow
def test_exp1_writes_its_tables_and_scores_the_samples(tmp_path: Path, shared_data: Path) -> None:
    cfg = Exp1Config(out_dir=str(tmp_path / "exp1"), n_test=20, n_train=200, n_procedural_train=100,
                     n_procedural_test=10, n_examples=2, houseexpo=str(shared_data / "houseexpo" / "json.tar.gz"),
                     cache_dir=str(tmp_path / "cache"), threads=1)
    md = run_exp1(cfg)
    out = Path(cfg.out_dir)
    rows = read_rows(out / "exp1.csv", Exp1Row)
    assert {r.method for r in rows} >= {"(A) pix2pix", "(B) U-net", "(C) partial map", "(D) retrieval"}
    sampled = read_rows(out / "exp1_samples.csv", Exp1SampleRow)
    assert [(r.method, r.train_domain) for r in sampled] == [
        ("(A) pix2pix", "houseexpo"), ("(B) U-net", "houseexpo"), ("(B) U-net", "procedural"),
        ("(S) sampler", "houseexpo")]
    for r in sampled:
        assert r.n_maps == 20 and r.k == SAMPLE_K
        assert 0.0 < r.error < 1.0 and 0.0 <= r.spread <= 1.0 and 0.0 <= r.ece <= 1.0
        assert r.f_best_of_k >= r.f_single  # the best of K is at least the average sample
        assert r.best_of_k_ratio <= 1.0
    assert "## Sampled completions (8 per test map" in md and (out / "exp1_examples.png").stat().st_size > 0
    houses = {r.method: r for r in read_rows(out / "exp1_sampler.csv", Exp1SamplerRow)}
    sampler, unet = houses["(S) sampler"], houses["(B) U-net"]
    assert sampler.k == SAMPLE_K and sampler.k_frequencies == SAMPLER_K
    assert sampler.known_kept == 1.0                             # a sample keeps every cell m_t observed
    assert sampler.spread_over_error > 5 * unet.spread_over_error  # samples, not copies of one completion
    assert "## Sampler: are the samples whole houses?" in md
