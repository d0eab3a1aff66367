"""Experiment 2's targets, as data, and the lookup of its rows.

A target is a check on the row of one network (the ternary map of the mean of K samples, free space positive):
its F at least a value, its F a multiple of SLAM alone's, its mIoU above both trivial fills'.  Each network
named in :data:`TARGETS` that a run includes is checked against every target; a row a target needs that the
table lacks (a network or method renamed, a row left out) raises :class:`MissingRowError` rather than dropping
the check.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from mcnkit.experiments import paper
from mcnkit.experiments.common import model_label
from mcnkit.experiments.rows import FILLS, NO_VARIANT, SLAM_ALONE, Exp2Row, mean_variant
from mcnkit.experiments.tables import columns, flatten

__all__ = ["TARGETS", "AboveFills", "AtLeast", "Check", "MissingRowError", "RatioToSlam", "Target",
           "check_targets", "find_row", "target_models"]

_METRICS = frozenset(columns(Exp2Row))


class MissingRowError(LookupError):
    """A row the report needs is not in the table."""


def find_row(rows: Sequence[Exp2Row], iteration: str, method: str, variant: str, positive: str = "free") -> Exp2Row:
    """The row of ``method``/``variant`` at ``iteration`` with ``positive`` as positive class."""
    for r in rows:
        if (r.iteration, r.method, r.variant, r.scores.positive_class) == (iteration, method, variant, positive):
            return r
    have = sorted({(r.method, r.variant) for r in rows})
    raise MissingRowError(f"no row ({iteration!r}, {method!r}, {variant!r}, {positive} positive) in Experiment 2's "
                          f"table; it holds {have}")


def _metric(row: Exp2Row, metric: str) -> float:
    return float(flatten(row)[metric])


@dataclass(frozen=True)
class Check:
    """A target checked: its text, whether it is met, and the figures it compared."""

    text: str
    met: bool
    value: str


def _check_metric(metric: str) -> None:
    if metric not in _METRICS:
        raise ValueError(f"a target on {metric!r}, not a column of Experiment 2's table")


@dataclass(frozen=True)
class AtLeast:
    """The network's ``metric`` at ``iteration`` is at least ``value``; ``paper``: the paper's figure for it."""

    text: str
    iteration: str
    metric: str
    value: float
    paper: float

    def __post_init__(self) -> None:
        _check_metric(self.metric)

    def check(self, rows: Sequence[Exp2Row], method: str, variant: str, name: str) -> Check:
        """Checks the row of ``method``/``variant``; ``name`` fills the text."""
        v = _metric(find_row(rows, self.iteration, method, variant), self.metric)
        return Check(self.text.format(name=name, value=self.value, paper=self.paper), v >= self.value, f"{v:.4f}")


@dataclass(frozen=True)
class RatioToSlam:
    """The network's ``metric`` at ``iteration`` is at least ``factor`` times SLAM alone's."""

    text: str
    iteration: str
    metric: str
    factor: float

    def __post_init__(self) -> None:
        _check_metric(self.metric)

    def check(self, rows: Sequence[Exp2Row], method: str, variant: str, name: str) -> Check:
        """Checks the row of ``method``/``variant`` against SLAM alone's; ``name`` fills the text."""
        v = _metric(find_row(rows, self.iteration, method, variant), self.metric)
        base = _metric(find_row(rows, self.iteration, SLAM_ALONE, NO_VARIANT), self.metric)
        ratio = v / base if base > 0 else float("inf")
        return Check(self.text.format(name=name, factor=self.factor), ratio >= self.factor,
                     f"{v:.4f} / {base:.4f} = {ratio:.2f}×")


@dataclass(frozen=True)
class AboveFills:
    """The network's ``metric`` at ``iteration`` is above that of both trivial fills (:data:`~.rows.FILLS`)."""

    text: str
    iteration: str
    metric: str

    def __post_init__(self) -> None:
        _check_metric(self.metric)

    def check(self, rows: Sequence[Exp2Row], method: str, variant: str, name: str) -> Check:
        """Checks the row of ``method``/``variant`` against the fills'; ``name`` fills the text."""
        v = _metric(find_row(rows, self.iteration, method, variant), self.metric)
        best = max(_metric(find_row(rows, self.iteration, f, NO_VARIANT), self.metric) for f in FILLS)
        return Check(self.text.format(name=name, iteration=self.iteration), bool(v > best), f"{v:.4f} vs {best:.4f}")


Target = AtLeast | RatioToSlam | AboveFills


def _paper_f(method: str, iteration: str) -> float:
    return next(r.f_measure for r in paper.EXP2 if (r.method, r.iteration) == (method, iteration))


_INSIDE = "{name} mIoU on the unknown cells m_T knows (as in Exp 3) above both trivial fills, iteration {iteration}"
_ALL_UNKNOWN = "same, with the cells m_T never saw counted occupied, iteration {iteration}"
UNET_TARGETS: tuple[Target, ...] = (
    AtLeast("{name} F at iteration 1 ≥ {value} (paper {paper})", "1", "f_measure", 0.53, _paper_f("(B) U-net", "1")),
    RatioToSlam("{name} F at iteration 1 ≥ {factor} × SLAM alone", "1", "f_measure", 1.3),
    AtLeast("{name} F at T−5 ≥ {value} (paper {paper})", "T-5", "f_measure", 0.64, _paper_f("(B) U-net", "T-5")),
    AboveFills(_INSIDE, "1", "miou_unknown_inside"),
    AboveFills(_ALL_UNKNOWN, "1", "miou_unknown"),
    AboveFills(_INSIDE, "T-5", "miou_unknown_inside"),
    AboveFills(_ALL_UNKNOWN, "T-5", "miou_unknown"),
)
"""The checks a U-net row must pass."""
TARGETS: dict[str, tuple[Target, ...]] = {"unet": UNET_TARGETS, "unet-explore": UNET_TARGETS}
"""Model name → the targets on its row: the paper's U-net (trained on first-iteration maps) and the one trained on
the maps of a robot part-way through exploring."""


def target_models(models: Sequence[str]) -> list[str]:
    """The row labels of the networks of ``models`` that have targets, in :data:`TARGETS`' order."""
    return [model_label(m) for m in TARGETS if m in models]


def check_targets(rows: Sequence[Exp2Row], models: Sequence[str], k: int) -> list[Check]:
    """Every target of the networks of ``models`` (K = ``k`` samples) on ``rows``."""
    out: list[Check] = []
    for m in TARGETS:
        if m in models:
            label = model_label(m)
            out += [t.check(rows, label, mean_variant(k), label.split(") ", 1)[-1]) for t in TARGETS[m]]
    return out
