"""The rows of the experiments' tables, one frozen dataclass per table (CSV columns: :mod:`.tables`).

A method is named by its row label (``"(B) U-net"``, ``"(C) SLAM alone"``, …; the networks' labels come from
:func:`~mcnkit.experiments.common.model_label`), a network's variant by ``"mean of K"``, ``"per sample"`` or
``"dropout off"`` (``"-"`` for the other methods), an iteration of Experiment 2 by ``"1"`` or ``"T-5"``.
"""

from __future__ import annotations

from dataclasses import dataclass

from mcnkit.completion.scores import Scores

__all__ = [
    "EXP1_COLUMNS",
    "EXP2_COLUMNS",
    "FILLS",
    "ITERATIONS",
    "NO_VARIANT",
    "SLAM_ALONE",
    "CurveRow",
    "Exp1Row",
    "Exp2Row",
    "Exp3Row",
    "Exp3Summary",
    "LogInfo",
    "PerMapRow",
    "mean_variant",
]

NO_VARIANT = "-"
SLAM_ALONE = "(C) SLAM alone"
FILLS = ("unknown → all free", "unknown → all occupied")
"""The trivial-fill sanity rows of Experiments 2 and 3."""
ITERATIONS = ("1", "T-5")
"""Experiment 2's iterations: the first filter update, and T − ``late`` (the paper's T−5)."""


def mean_variant(k: int) -> str:
    """The variant label of a network's ternary map of the mean of ``k`` samples."""
    return f"mean of {k}"


@dataclass(frozen=True)
class Exp1Row:
    """Experiment 1: one method, trained on one domain, scored on one test domain with one positive class."""

    method: str
    train_domain: str
    test_domain: str
    scores: Scores


EXP1_COLUMNS = (
    "method", "train_domain", "test_domain", "n_maps", "positive_class", "accuracy", "precision", "recall",
    "f_measure", "f_ci95", "miou_unknown", "miou_ci95", "pooled_accuracy", "pooled_precision", "pooled_recall",
    "pooled_f_measure", "pooled_miou_unknown",
)  # fmt: skip
"""``exp1.csv``'s column order."""


@dataclass(frozen=True)
class Exp1SampleRow:
    """Experiment 1, sampled: one network's K samples per test map, scored on the cells unknown in m_t
    (:func:`mcnkit.completion.calibration.score_samples`)."""

    method: str
    train_domain: str
    test_domain: str
    n_maps: int
    k: int
    error: float
    spread: float
    spread_over_error: float
    ece: float
    best_of_k_ratio: float
    f_single: float
    f_majority: float
    f_best_of_k: float


@dataclass(frozen=True)
class Exp1SamplerRow:
    """Experiment 1, the sampler table: whether one network's samples are whole, plausible houses; ECE and the
    majority over ``k_frequencies`` samples per test map, the other figures over the first ``k``
    (:func:`mcnkit.completion.calibration.score_samples` with ``first``)."""

    method: str
    train_domain: str
    test_domain: str
    n_maps: int
    k: int
    k_frequencies: int
    spread_over_error: float
    ece: float
    best_of_k_ratio: float
    f_best_of_k: float
    f_majority: float
    known_kept: float
    one_region: float
    roughness_ratio: float


@dataclass(frozen=True)
class Exp2Row:
    """Experiment 2: one method and variant at one iteration, one positive class, over all houses."""

    iteration: str
    method: str
    variant: str
    scores: Scores
    miou_unknown_inside: float
    """mIoU on the cells unknown in m_t that m_T observed (free space positive)."""
    miou_inside_ci95: float
    exterior_predicted_free: float
    """Share of the unknown cells outside the house (m_T never saw them) predicted free."""
    unknown_share: float
    """Share of the window cells unknown in m_t."""


EXP2_COLUMNS = (
    "iteration", "method", "variant", "n_maps", "positive_class", "accuracy", "precision", "recall", "f_measure",
    "f_ci95", "miou_unknown", "miou_ci95", "pooled_accuracy", "pooled_precision", "pooled_recall",
    "pooled_f_measure", "pooled_miou_unknown", "miou_unknown_inside", "miou_inside_ci95", "exterior_predicted_free",
    "unknown_share",
)  # fmt: skip
"""``exp2.csv``'s column order."""


@dataclass(frozen=True)
class PerMapRow:
    """Experiment 2: one house, one method and variant at one iteration (free space positive)."""

    map: str
    iteration: str
    update: int
    """1-based filter update of the iteration."""
    n_updates: int
    method: str
    variant: str
    accuracy: float
    precision: float
    recall: float
    f_measure: float
    miou_unknown: float
    miou_unknown_inside: float
    exterior_predicted_free: float
    unknown_share: float


@dataclass(frozen=True)
class CurveRow:
    """Experiment 2 along the run: one method (mean of K for the networks) at one fraction of the updates."""

    fraction: float
    method: str
    n_maps: int
    f_measure: float
    f_ci95: float
    miou_unknown: float
    miou_ci95: float
    unknown_share: float


@dataclass(frozen=True)
class Exp3Row:
    """Experiment 3: one log, one point along the run, one method and variant (free space positive)."""

    log: str
    point: float
    update: int
    """1-based filter update of the point."""
    n_updates: int
    method: str
    variant: str
    accuracy: float
    precision: float
    recall: float
    f_measure: float
    """F over the whole window (m_T's unknown cells are negatives)."""
    f_known: float
    """F on the cells m_T knows."""
    miou_unknown: float
    """mIoU on the cells unknown in m_t and known in m_T."""
    unknown_share: float
    truth_unknown_share: float


@dataclass(frozen=True)
class Exp3Summary:
    """Experiment 3: the mean (± 95 % CI) over the points of one method and variant, per log or ``"all"``."""

    log: str
    method: str
    variant: str
    n: int
    f_measure: float
    f_measure_ci95: float
    f_known: float
    f_known_ci95: float
    miou_unknown: float
    miou_unknown_ci95: float


@dataclass(frozen=True)
class LogInfo:
    """Experiment 3: one log's run."""

    log: str
    path: str
    scans: int
    updates: int
    slam_cpu_s: float
    read_and_slam_s: float
    total_s: float
