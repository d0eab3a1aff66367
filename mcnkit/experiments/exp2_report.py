"""Experiment 2's Markdown report (``exp2.md``): the targets, where the unknown cells are, the tables per iteration
and positive class, the paper's Table 2, the scores along the run, the houses and the notes."""

from __future__ import annotations

from typing import TYPE_CHECKING

from mcnkit.experiments import paper
from mcnkit.experiments.houses import CURVE_FRACTIONS
from mcnkit.experiments.rows import FILLS, ITERATIONS, NO_VARIANT, Exp2Row, mean_variant
from mcnkit.experiments.targets import find_row, target_models

if TYPE_CHECKING:
    from mcnkit.experiments.config import Exp2Config
    from mcnkit.experiments.exp2 import Exp2Results

__all__ = ["markdown"]


def _row(r: Exp2Row) -> str:
    s = r.scores
    return (f"| {r.method} | {r.variant} | {s.n_maps} | {s.accuracy:.4f} | {s.precision:.4f} | "
            f"{s.recall:.4f} | {s.f_measure:.4f} ± {s.f_ci95:.4f} | {s.miou_unknown:.4f} ± "
            f"{s.miou_ci95:.4f} | {s.pooled_f_measure:.4f} | {s.pooled_miou_unknown:.4f} | "
            f"{r.miou_unknown_inside:.4f} ± {r.miou_inside_ci95:.4f} | {r.exterior_predicted_free:.3f} |")


def _diagnosis(cfg: Exp2Config, res: Exp2Results) -> list[str]:
    """Where the cells to complete are (inside the house or outside its outer walls) and what the nets put there."""
    shown = ("-", mean_variant(cfg.samples))
    lines = ["## Where the unknown cells are", "",
             "'Inside' = cells m_T observed (rooms and walls); 'exterior' = window cells m_T never observed (outside "
             "the outer walls and the square padding), counted occupied. 'mIoU inside' is the mIoU on the cells "
             "unknown in m_t that m_T observed; 'exterior → free' the share of the unknown exterior cells a method "
             "fills with free space.", "",
             "| iteration | unknown cells of m_t that are exterior | method | mIoU unknown | mIoU inside | "
             "exterior → free |", "|---|---|---|---|---|---|"]
    summary: list[str] = []
    for it in ITERATIONS:
        share = res.exterior_share[it]
        sel = [r for r in res.rows if r.iteration == it and r.scores.positive_class == "free" and r.variant in shown]
        lines += [f"| {it} | {share:.3f} | {r.method} | {r.scores.miou_unknown:.4f} | "
                  f"{r.miou_unknown_inside:.4f} | {r.exterior_predicted_free:.3f} |" for r in sel]
        for method in target_models(cfg.models):
            u = find_row(res.rows, it, method, mean_variant(cfg.samples))
            best_in = max(find_row(res.rows, it, f, NO_VARIANT).miou_unknown_inside for f in FILLS)
            summary.append(f"- At iteration {it}, {share:.0%} of the cells to complete lie outside the house; "
                           f"{method} fills {u.exterior_predicted_free:.0%} of them with free space. Inside the "
                           f"house its mIoU is {u.miou_unknown_inside:.3f} against {best_in:.3f} for the better "
                           "trivial fill there.")
    return [*lines, "", *summary, ""] if summary else [*lines, ""]


def _tables(cfg: Exp2Config, rows: list[Exp2Row]) -> list[str]:
    lines: list[str] = []
    for it in ITERATIONS:
        share = next((r.unknown_share for r in rows if r.iteration == it), float("nan"))
        title = "iteration 1 (the first scan, before the robot moves)" if it == "1" else f"iteration T−{cfg.late}"
        for positive in ("free", "occupied"):
            lines += [f"## {title}, positive class: {positive}"
                      + (" (the paper's reading)" if positive == "free" else ""), "",
                      f"Share of window cells unknown in m_t: {share:.3f}.", "",
                      "| method | variant | n | Acc | Prec | Rec | F (±95 %) | mIoU unknown (±95 %) | pooled F | "
                      "pooled mIoU | mIoU unknown inside (±95 %) | exterior → free |",
                      "|---|---|---|---|---|---|---|---|---|---|---|---|"]
            lines += [_row(r) for r in rows if r.iteration == it and r.scores.positive_class == positive]
            lines.append("")
    return lines


def _curve(res: Exp2Results) -> list[str]:
    if not res.curve:
        return []
    methods = list(dict.fromkeys(r.method for r in res.curve))
    lines = ["## Along the run (free space positive, mean of K for the networks)", "",
             "| fraction of updates | " + " | ".join(methods) + " |", "|---|" + "---|" * len(methods)]
    for f in CURVE_FRACTIONS:
        lines.append(f"| {f:.1f} | " + " | ".join(f"F {r.f_measure:.3f} / mIoU {r.miou_unknown:.3f}"
                                                 for r in res.curve if r.fraction == f) + " |")
    return [*lines, ""]


def markdown(cfg: Exp2Config, res: Exp2Results) -> str:
    """``exp2.md`` of the results ``res`` of a run with ``cfg``."""
    lines = [f"# Experiment 2: MCN-SLAM in simulation ({len(res.houses)} HouseExpo test houses)", ""]
    if res.targets:
        lines += ["## Targets (free space positive; U-net = ternary map of the mean of "
                  f"{cfg.samples} samples)", "", "| check | met | value |", "|---|---|---|"]
        lines += [f"| {t.text} | {'yes' if t.met else '**no**'} | {t.value} |" for t in res.targets] + [""]
    lines += _diagnosis(cfg, res)
    lines += _tables(cfg, res.rows)
    lines += ["## The paper's Table 2 (free space positive; Acc / Prec / Rec / F)", "",
              "| method | iteration | Acc | Prec | Rec | F |", "|---|---|---|---|---|---|",
              *paper.markdown_rows(paper.EXP2), ""]
    lines += _curve(res)
    lines += ["## Houses", "", "| house | scans | filter updates T | T−5 update | m_T unknown share | sim s | SLAM CPU s |",
              "|---|---|---|---|---|---|---|"]
    lines += [f"| {h.name} | {h.n_scans} | {h.n_updates} | {max(1, h.n_updates - cfg.late)} | "
              f"{h.truth_unknown_share:.3f} | {h.sim_s:.1f} | {h.slam_cpu_s:.1f} |" for h in res.houses]
    lines += ["", "## Protocol and notes", ""] + [f"- {n}" for n in res.notes] + [""]
    return "\n".join(lines)
