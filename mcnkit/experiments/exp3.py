"""Experiment 3 (the paper's real-lab experiment) on the MIT CSAIL and Intel Research Lab logs.

The paper completed the map of one laboratory room; its data are not public.  Here the two classic real-robot
logs stand in, with the HouseExpo-trained networks (a domain shift the paper also met: its real-lab F was lower).

Protocol (also in ``exp3.md``):

1. Each CARMEN log is converted to a ROS1 bag in a temporary directory with mcnkit's writer and read back with
   :func:`mcnkit.io.open_log` (the path a user's bag takes; ``convert=False`` reads the log directly).
2. Grid FastSLAM (gmapping's defaults, ``particles`` particles) runs over it once; at every filter update the
   ancestry of the particle best at that update is kept, so its map at any update is rebuilt exactly afterwards
   (:func:`~mcnkit.experiments.common.map_at`) and the networks complete only at the chosen points: MCN-SLAM's
   completion at those updates, without completing at every update.
3. At each point (a fraction of the filter updates, default 10/25/50/75/90 %) the window is a ``window_m`` square
   centred on the robot (:func:`mcnkit.mcn.robot_window`; these buildings are far larger than one house; 16 m on
   64 cells is 0.25 m a cell, the scale of the HouseExpo training maps); m_t = the best particle's map there,
   m_T = the final best map pooled on the same window.
4. Rows: SLAM alone (m_t), (B) U-net and (A) pix2pix (ternary map of the mean of K samples, the mean score of the
   samples, the deterministic output), and the trivial fills.  Scores against m_T, free space positive: F over the
   whole window (m_T's unknown cells are negatives, the paper's protocol) and F on the cells m_T knows; mIoU over
   {free, occupied} on the cells unknown in m_t **and known in m_T** (in a building, what m_T never saw is not
   known to be wall).

Outputs in ``out_dir``: ``exp3.csv`` (one row per log × point × method × variant), ``exp3.md``,
``exp3_<log>.png`` (the windows at each point) and ``exp3_<log>_overview.png`` (the final map and the windows);
the rows are :mod:`.rows`, the report and figures ``exp3_report``.
"""

from __future__ import annotations

import os
import tempfile
import time
from collections.abc import Iterator
from itertools import islice
from pathlib import Path

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.completion.nets import CompletionNet
from mcnkit.completion.scores import mean_ci95
from mcnkit.experiments.common import (
    complete_windows,
    fill_unknown,
    map_at,
    model_label,
    new_lineage,
    per_map_scores,
    run_slam,
)
from mcnkit.experiments.config import Exp3Config
from mcnkit.experiments.exp3_report import PointWindows, markdown, overview_figure, windows_figure
from mcnkit.experiments.rows import FILLS, NO_VARIANT, SLAM_ALONE, Exp3Row, Exp3Summary, LogInfo, mean_variant
from mcnkit.experiments.tables import write_rows
from mcnkit.grid import pool_to_window
from mcnkit.locations import shared_data_dir
from mcnkit.threads import torch_threads
from mcnkit.types import FREE, OCCUPIED, UNKNOWN, Frame

__all__ = ["Exp3Config", "default_logs", "run_exp3"]

F32 = NDArray[np.float32]


def _reallab_dir() -> Path:
    return shared_data_dir() / "reallab"


def default_logs(reallab: str | os.PathLike[str] | None = None) -> tuple[str, ...]:
    """The MIT CSAIL and Intel Research Lab logs (``$MCNKIT_SHARED_DATA/reallab`` or ``../shared/data/reallab``)."""
    root = Path(reallab) if reallab else _reallab_dir()
    return (str(root / "mit-csail" / "mit-csail.clf"), str(root / "intel" / "intel-corrected.log.gz"))


def _log_name(path: str) -> str:
    name = Path(path).name
    for suffix in (".gz", ".clf", ".log", ".bag", ".mcap"):
        name = name.removesuffix(suffix)
    return name


def _frames(cfg: Exp3Config, path: str, tmp: Path) -> Iterator[Frame]:
    """The log's frames, through a ROS1 bag written in ``tmp`` when ``cfg.convert``."""
    from mcnkit.io import LogContent, open_log, write_log

    with open_log(path) as log:
        frames = list(islice(log.frames(), cfg.max_scans))
        gt = log.ground_truth()
    if not cfg.convert:
        yield from frames
        return
    if gt is not None and cfg.max_scans is not None:
        gt = None  # a truncated log: leave the ground truth out rather than cut it
    bag = write_log(tmp / f"{_log_name(path)}.bag", LogContent(frames, ground_truth=gt), "ros1")
    with open_log(bag) as log:
        yield from log.frames()


def _row(log: str, pw: PointWindows, n_updates: int, method: str, variant: str, pred: F32) -> Exp3Row:
    """The row of one prediction at one point: F (whole window), F on the cells m_T knows, mIoU on cells unknown
    in m_t and known in m_T; ``pred`` one window (S, S) or a stack of samples (K, S, S)."""
    p = pred if pred.ndim == 3 else pred[None]
    t, m = pw.truth[None], pw.partial[None]
    known = pw.truth != UNKNOWN
    whole = {k: float(v[0]) for k, v in per_map_scores(p[None], t, m, "free", miou_mask=(m == UNKNOWN) & known[None]).items()}
    f_known = float(per_map_scores(np.where(known, p, UNKNOWN)[None], t, m, "free")["f_measure"][0])
    return Exp3Row(log, pw.point, pw.update + 1, n_updates, method, variant, whole["accuracy"], whole["precision"],
                   whole["recall"], whole["f_measure"], f_known, whole["miou_unknown"],
                   float((pw.partial == UNKNOWN).mean()), float((pw.truth == UNKNOWN).mean()))


def _run_log(cfg: Exp3Config, path: str, nets: dict[str, CompletionNet], out: Path, index: int
             ) -> tuple[list[Exp3Row], LogInfo]:
    from mcnkit.mcn import robot_window
    from mcnkit.slam import SlamConfig

    name = _log_name(path)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="mcnkit-exp3-") as tmp:
        run = run_slam(_frames(cfg, path, Path(tmp)), SlamConfig(n_particles=cfg.particles),
                       np.random.default_rng([cfg.seed, index]))
    t_slam = time.perf_counter() - t0
    final = map_at(run, -1)
    lm = new_lineage(run.slam)
    pts: list[PointWindows] = []
    for p in cfg.points:
        k = int(round(p * (run.n_updates - 1)))
        window = robot_window(run.best_poses[k][-1, :2], cfg.size, cfg.window_m)
        partial = pool_to_window(map_at(run, k, lm), window, outside=UNKNOWN).astype(np.float32)
        truth = pool_to_window(final, window, outside=UNKNOWN).astype(np.float32)
        pts.append(PointWindows(p, k, window, partial, truth))
    partial = np.stack([pw.partial for pw in pts])
    comps = {lab: complete_windows(net, partial, cfg.samples, torch.Generator().manual_seed(cfg.seed * 1000 + j))
             for j, (lab, net) in enumerate(nets.items())}
    rows: list[Exp3Row] = []
    for i, pw in enumerate(pts):
        preds: dict[tuple[str, str], F32] = {(SLAM_ALONE, NO_VARIANT): pw.partial}
        for lab, c in comps.items():
            preds[(lab, mean_variant(cfg.samples))] = c.mean[i]
            preds[(lab, "per sample")] = c.samples[i]
            preds[(lab, "dropout off")] = c.deterministic[i]
        preds[(FILLS[0], NO_VARIANT)] = fill_unknown(pw.partial, FREE)
        preds[(FILLS[1], NO_VARIANT)] = fill_unknown(pw.partial, OCCUPIED)
        rows += [_row(name, pw, run.n_updates, method, variant, pred) for (method, variant), pred in preds.items()]
    if nets:
        windows_figure(out / f"exp3_{name}.png", name, pts, comps, run.n_updates)
    overview_figure(out / f"exp3_{name}_overview.png", name, final, pts, run.best_poses[-1])
    info = LogInfo(name, path, run.n_scans, run.n_updates, run.cpu_s, t_slam, time.perf_counter() - t0)
    return rows, info


def _summary(rows: list[Exp3Row]) -> list[Exp3Summary]:
    """Per log (and over all logs) and method/variant: the mean of each metric over the points, with 95 % CIs."""
    out = []
    logs = list(dict.fromkeys(r.log for r in rows))
    for log in [*logs, "all"]:
        rs = [r for r in rows if log in ("all", r.log)]
        for method, variant in dict.fromkeys((r.method, r.variant) for r in rs):
            sel = [r for r in rs if (r.method, r.variant) == (method, variant)]
            f, f_ci = mean_ci95(np.array([r.f_measure for r in sel], float))
            fk, fk_ci = mean_ci95(np.array([r.f_known for r in sel], float))
            mi, mi_ci = mean_ci95(np.array([r.miou_unknown for r in sel], float))
            out.append(Exp3Summary(log, method, variant, len(sel), f, f_ci, fk, fk_ci, mi, mi_ci))
    return out


def run_exp3(cfg: Exp3Config) -> str:
    """Runs Experiment 3 and writes its outputs; returns the Markdown report."""
    with torch_threads(cfg.threads):
        return _run_exp3(cfg)


def _run_exp3(cfg: Exp3Config) -> str:
    from tqdm import tqdm

    from mcnkit.mcn import load_model

    t0 = time.perf_counter()
    out = Path(cfg.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    logs = cfg.logs or default_logs()
    for p in logs:
        if not Path(p).exists():
            raise FileNotFoundError(2, "robot log not found", p)
    nets = {model_label(m): load_model(m) for m in cfg.models}
    rows: list[Exp3Row] = []
    infos: list[LogInfo] = []
    for i, path in enumerate(tqdm(logs, desc="exp3 logs", unit="log", disable=not cfg.progress)):
        r, info = _run_log(cfg, path, nets, out, i)
        rows += r
        infos.append(info)
    write_rows(out / "exp3.csv", rows, Exp3Row)
    md = markdown(cfg, rows, _summary(rows), infos, time.perf_counter() - t0)
    (out / "exp3.md").write_text(md)
    return md
