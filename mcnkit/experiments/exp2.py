"""Experiment 2 (the paper's Table 2): MCN-SLAM on simulated HouseExpo houses, at the first iteration and at T−5.

Protocol (written to ``exp2.md`` too):

1. **Houses**: the first ``n_maps`` HouseExpo test plans in the seeded shuffle of the official test list that
   Experiment 1 uses (the same pair cache: its first maps are Exp 1's first test maps); a plan the simulated robot
   cannot drive in is skipped and the next one taken.  The paper draws 10 at random; 50 give confidence intervals.
2. **Robot**: :func:`mcnkit.sim.simulate` explores the whole house (360° lidar, ``lidar_range_m``, drifting
   odometry; seed ``seed``).  The run is written as a ROS1 bag and read back with :func:`mcnkit.io.open_log`, so
   the SLAM sees what a real log reader delivers (``log_format=""`` feeds the frames directly).
3. **SLAM**: grid FastSLAM (gmapping's defaults, ``particles`` particles).  At every filter update the ancestry of
   the particle best *at that update* is kept; its map at update k is rebuilt exactly after the run
   (:func:`~mcnkit.experiments.common.map_at`).  Iteration i (1-based, as the paper) is the map after the i-th
   filter update: iteration 1 is the first scan, before the robot moves; T is the last update, and the paper's
   "T−5" is iteration T−5 (five updates before the last).
4. **Ground truth** m_T: the best particle's map after the whole run (the paper: the Gmapping map with sufficient
   observation).  **Window**: the paper frames the whole house, so every map of a house is pooled on the same
   window, m_T's known extent padded square on ``size``² cells (:func:`mcnkit.mcn.map_window`; thin walls survive
   the pooling).  m_T's unknown cells there (outside the outer walls) count as occupied, the convention of the
   training maps and of Exp 1 (the F-measure, free space positive, does not depend on it).
5. **Rows**: (A) pix2pix and (B) U-net (the shipped weights, :func:`mcnkit.mcn.load_model`), and (B') the U-net
   trained on exploration maps (``unet-explore``: m_t after 1–12 scans of this robot's 360°, 8 m lidar, not the
   paper's single 180°, 2 m scan; :mod:`mcnkit.completion.data`): the ternary map of the
   mean output of K samples (dropout on; what :class:`mcnkit.mcn.McnSlam` returns as ``mean``), the mean score of
   the K samples, and the deterministic completion (dropout off); (C) SLAM alone (m_t as is); (D) retrieval of the
   HouseExpo training map that best agrees with m_t's observed cells; and the sanity rows "unknown → all free" and
   "unknown → all occupied".  Completions keep m_t's observed cells.
6. **Scores**: per-cell binary classification against m_T, free space positive (the paper's reading) and occupied
   positive; mIoU over {free, occupied} on the cells unknown in m_t; per-map means with 95 % CIs and pooled.

Outputs in ``out_dir``: ``exp2.csv`` (one row per iteration × method × variant × positive class),
``exp2_per_map.csv``, ``exp2_curve.csv`` (F and mIoU along the run), ``exp2.md``, ``exp2_examples.png``,
``exp2_curve.png``; ``runs/`` (or ``runs_dir``) caches each house's SLAM result, keyed by everything that shapes
it (:mod:`.houses`).

This module computes; the rows are :mod:`.rows`, the targets :mod:`.targets`, the report ``exp2_report`` and the
figures ``exp2_figures``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.completion.nets import CompletionNet
from mcnkit.completion.scores import mean_ci95
from mcnkit.experiments.common import (
    MapCompletions,
    aggregate,
    complete_windows,
    fill_unknown,
    model_label,
    per_map_scores,
)
from mcnkit.experiments.config import Exp2Config
from mcnkit.experiments.exp2_figures import curve_figure, example_figure
from mcnkit.experiments.exp2_report import markdown
from mcnkit.experiments.houses import CURVE_FRACTIONS, HouseRun, run_house
from mcnkit.experiments.rows import (
    EXP2_COLUMNS,
    FILLS,
    ITERATIONS,
    NO_VARIANT,
    SLAM_ALONE,
    CurveRow,
    Exp2Row,
    PerMapRow,
    mean_variant,
)
from mcnkit.experiments.tables import write_rows
from mcnkit.experiments.targets import Check, check_targets
from mcnkit.threads import torch_threads
from mcnkit.types import FREE, OCCUPIED, UNKNOWN

__all__ = ["Exp2Config", "Exp2Results", "run_exp2"]

F32 = NDArray[np.float32]


@dataclass(frozen=True)
class Exp2Results:
    """What Experiment 2 computed: the tables, the houses, the targets checked and the notes of its report."""

    rows: list[Exp2Row]
    per_map: list[PerMapRow]
    curve: list[CurveRow]
    houses: list[HouseRun]
    targets: list[Check]
    exterior_share: dict[str, float]
    """Per iteration, the share of the cells unknown in m_t that lie outside the houses."""
    notes: list[str]


def _houses_and_bank(cfg: Exp2Config) -> tuple[list[str], F32 | None, list[str]]:
    """Candidate plan names (in order), the retrieval bank (training m_T, or None) and notes."""
    from mcnkit.completion.data import load_domain_pairs

    notes: list[str] = []
    try:
        he = load_domain_pairs("houseexpo", cfg.n_train, 200, cfg.n_test_pool, cfg.seed, cfg.houseexpo,
                               cfg.cache_dir, progress=False)
    except FileNotFoundError:
        if not cfg.maps:
            raise
        notes.append("HouseExpo not found: no retrieval bank, row (D) left out.")
        return list(cfg.maps), None, notes
    names = list(cfg.maps) if cfg.maps else [f"houseexpo:{i}" for i in he.test.ids]
    return names, he.train.target, notes


def _exterior_free(pred: F32, partial: F32, exterior: NDArray[np.bool_]) -> NDArray[np.float64]:
    """Per map, the share of the cells unknown in m_t and outside the house (m_T never saw them) predicted free
    (averaged over the samples of a (B, K, S, S) stack)."""
    p = pred if pred.ndim == 4 else pred[:, None]
    cells = (partial == UNKNOWN) & exterior
    n = cells.sum(axis=(-2, -1))
    hit = ((p == FREE) & cells[:, None]).sum(axis=(-2, -1)).mean(axis=1)
    return np.where(n > 0, hit / np.maximum(n, 1), np.nan)


def _method_rows(iteration: str, method: str, variant: str, pred: F32, truth: F32, partial: F32,
                 exterior: NDArray[np.bool_], unknown_share: float) -> list[Exp2Row]:
    inside = aggregate(pred, truth, partial, "free", miou_mask=(partial == UNKNOWN) & ~exterior)
    ext = mean_ci95(_exterior_free(pred, partial, exterior))[0]
    return [Exp2Row(iteration, method, variant, aggregate(pred, truth, partial, positive), inside.miou_unknown,
                    inside.miou_ci95, ext, unknown_share) for positive in ("free", "occupied")]


def _per_map_rows(iteration: str, method: str, variant: str, pred: F32, truth: F32, partial: F32,
                  exterior: NDArray[np.bool_], houses: list[HouseRun], updates: list[int]) -> list[PerMapRow]:
    pm = per_map_scores(pred, truth, partial, "free")
    pm_in = per_map_scores(pred, truth, partial, "free", miou_mask=(partial == UNKNOWN) & ~exterior)
    ext = _exterior_free(pred, partial, exterior)
    return [PerMapRow(h.name, iteration, updates[b] + 1, h.n_updates, method, variant, float(pm["accuracy"][b]),
                      float(pm["precision"][b]), float(pm["recall"][b]), float(pm["f_measure"][b]),
                      float(pm["miou_unknown"][b]), float(pm_in["miou_unknown"][b]), float(ext[b]),
                      float((partial[b] == UNKNOWN).mean()))
            for b, h in enumerate(houses)]


def _predictions(partial: F32, nets: dict[str, CompletionNet], bank: F32 | None, k: int, seed: int, tag: int
                 ) -> tuple[dict[tuple[str, str], F32], dict[str, MapCompletions]]:
    """Every method's prediction for a stack of m_t: {(method, variant): (B, S, S) or (B, K, S, S)}."""
    from mcnkit.completion.retrieval import retrieve

    preds: dict[tuple[str, str], F32] = {}
    comps: dict[str, MapCompletions] = {}
    for j, (label, net) in enumerate(nets.items()):
        c = complete_windows(net, partial, k, torch.Generator().manual_seed(seed * 1000 + tag * 10 + j))
        comps[label] = c
        preds[(label, mean_variant(k))] = c.mean
        preds[(label, "per sample")] = c.samples
        preds[(label, "dropout off")] = c.deterministic
    preds[(SLAM_ALONE, NO_VARIANT)] = partial
    if bank is not None:
        preds[("(D) retrieval", NO_VARIANT)] = retrieve(partial, bank).prediction
    preds[(FILLS[0], NO_VARIANT)] = fill_unknown(partial, FREE)
    preds[(FILLS[1], NO_VARIANT)] = fill_unknown(partial, OCCUPIED)
    return preds, comps


def _curve(houses: list[HouseRun], nets: dict[str, CompletionNet], k: int, seed: int) -> list[CurveRow]:
    """F (free positive) and mIoU along the run at fractions 0, 0.1, …, 1 of the filter updates (the all-occupied
    fill has the F of SLAM alone)."""
    rows: list[CurveRow] = []
    truth = np.stack([h.truth for h in houses])
    for fi, f in enumerate(CURVE_FRACTIONS):
        partial = np.stack([h.partial_at(int(round(f * (h.n_updates - 1)))) for h in houses])
        preds: dict[str, F32] = {SLAM_ALONE: partial, FILLS[0]: fill_unknown(partial, FREE),
                                 FILLS[1]: fill_unknown(partial, OCCUPIED)}
        for j, (label, net) in enumerate(nets.items()):
            g = torch.Generator().manual_seed(seed * 1000 + 500 + fi * 10 + j)
            preds[label] = complete_windows(net, partial, k, g).mean
        share = float((partial == UNKNOWN).mean())
        for method, pred in preds.items():
            s = aggregate(pred, truth, partial, "free")
            rows.append(CurveRow(f, method, len(houses), s.f_measure, s.f_ci95, s.miou_unknown, s.miou_ci95, share))
    return rows


def _notes(cfg: Exp2Config, houses: list[HouseRun], skipped: list[str], labels: list[str], bank: F32 | None,
           notes: list[str], t0: float) -> list[str]:
    """The report's protocol notes."""
    return [
        "Houses: " + (f"the given plans ({len(cfg.maps)})" if cfg.maps else
                      f"the first {len(houses)} usable HouseExpo test plans of the seeded shuffle (seed {cfg.seed}) "
                      "of the official test list, the order of Experiment 1's test maps")
        + (f"; skipped: {'; '.join(skipped)}" if skipped else "") + ".",
        f"Robot: mcnkit.sim, {cfg.lidar_beams} beams over {cfg.lidar_fov_deg:g}°, range {cfg.lidar_range_m:g} m, "
        f"drifting odometry, whole-house exploration (≤ {cfg.max_duration_s:g} s), sim seed {cfg.seed}; "
        + (f"written as a {cfg.log_format} and read back with open_log." if cfg.log_format else
           "frames fed directly (no log written)."),
        f"SLAM: FastSlam with gmapping's defaults, {cfg.particles} particles; m_t at iteration i = the map of the "
        "particle best at the i-th filter update (exact, rebuilt from its ancestry); m_T = the best map after the "
        "last update.",
        f"Window: m_T's known extent padded square on {cfg.size}² cells (map_window); m_T's unknown cells counted "
        "occupied (exterior, as in the training maps); every map pooled with occupied > free > unknown. The "
        "simulated odometry starts at the true pose, so the SLAM maps lie in the plan's frame and the windows have "
        "the training maps' orientation (rows = y, columns = x).",
        f"Networks: {', '.join(f'{lab} = {m}' for lab, m in zip(labels, cfg.models, strict=True))} "
        f"(load_model); K = {cfg.samples} samples with dropout on, seeded; 'mean of {cfg.samples}' is the ternary "
        "map of the mean output, 'per sample' the mean score of the samples, 'dropout off' the deterministic "
        "output; observed cells of m_t are kept in every completion.",
        "(D) retrieval: the HouseExpo training m_T with the highest agreement on m_t's observed cells, m_t pasted "
        f"over it (bank: {0 if bank is None else len(bank)} maps of the Exp 1 pair split).",
        "Scores: free space positive (the paper's reading) and occupied positive; a cell predicted unknown is a "
        "negative; mIoU over {free, occupied} on the cells unknown in m_t; per-map mean ± 95 % CI "
        "(1.96 sd/√n) and pooled over maps.",
        *notes, *cfg.extra_notes,
        f"Wall time {time.perf_counter() - t0:.0f} s ({sum(h.sim_s for h in houses):.0f} s simulation, "
        f"{sum(h.slam_cpu_s for h in houses):.0f} s SLAM CPU; cached runs count their first time); "
        f"torch threads {cfg.threads}.",
    ]


def run_exp2(cfg: Exp2Config) -> str:
    """Runs Experiment 2 and writes its outputs; returns the Markdown report."""
    with torch_threads(cfg.threads):
        return _run_exp2(cfg)


def _run_exp2(cfg: Exp2Config) -> str:
    from tqdm import tqdm

    from mcnkit.mcn import load_model

    t0 = time.perf_counter()
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    names, bank, notes = _houses_and_bank(cfg)
    nets = {model_label(m): load_model(m) for m in cfg.models}
    houses: list[HouseRun] = []
    skipped: list[str] = []
    bar = tqdm(total=cfg.n_maps, desc="exp2 houses", unit="house", disable=not cfg.progress)
    for i, name in enumerate(names):
        if len(houses) == cfg.n_maps:
            break
        try:
            houses.append(run_house(cfg, name, i, Path(cfg.runs_dir) if cfg.runs_dir else out / "runs"))
            bar.update(1)
        except ValueError as err:  # a plan without room for the robot, an unreadable plan
            skipped.append(f"{name} ({err})")
    bar.close()
    if not houses:
        raise ValueError("no house could be simulated" + (f": {'; '.join(skipped[:3])}" if skipped else ""))
    truth = np.stack([h.truth for h in houses])
    exterior = np.stack([h.exterior for h in houses])
    updates = {"1": [0 for _ in houses], "T-5": [h.late_update(cfg.late) for h in houses]}
    rows: list[Exp2Row] = []
    per_map: list[PerMapRow] = []
    comps: dict[str, dict[str, MapCompletions]] = {}
    exterior_share: dict[str, float] = {}
    for tag, it in enumerate(ITERATIONS):
        partial = np.stack([h.partial_at(u) for h, u in zip(houses, updates[it], strict=True)])
        unknown = partial == UNKNOWN
        exterior_share[it] = float((unknown & exterior).sum() / max(int(unknown.sum()), 1))
        preds, comps[it] = _predictions(partial, nets, bank, cfg.samples, cfg.seed, tag)
        share = float(unknown.mean())
        for (method, variant), pred in preds.items():
            rows += _method_rows(it, method, variant, pred, truth, partial, exterior, share)
            per_map += _per_map_rows(it, method, variant, pred, truth, partial, exterior, houses, updates[it])
    write_rows(out / "exp2.csv", rows, Exp2Row, EXP2_COLUMNS)
    write_rows(out / "exp2_per_map.csv", per_map, PerMapRow)
    curve = _curve(houses, nets, cfg.samples, cfg.seed) if cfg.curve else []
    if curve:
        write_rows(out / "exp2_curve.csv", curve, CurveRow)
        curve_figure(out / "exp2_curve.png", curve)
    if cfg.n_examples > 0 and nets:
        example_figure(out / "exp2_examples.png", houses, updates["T-5"], comps, cfg.n_examples)
    results = Exp2Results(rows, per_map, curve, houses, check_targets(rows, cfg.models, cfg.samples),
                          exterior_share, _notes(cfg, houses, skipped, list(nets), bank, notes, t0))
    md = markdown(cfg, results)
    (out / "exp2.md").write_text(md)
    return md
