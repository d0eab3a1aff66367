"""The paper's published tables, as data: Experiment 1's table, Experiment 2's Table 2 and the real-lab table of
Experiment 3 (free space positive; accuracy, precision, recall, F).  The reports print them under ours and the
notebooks draw them as ticks."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["EXP1", "EXP2", "EXP3", "PaperRow", "markdown_rows"]


@dataclass(frozen=True)
class PaperRow:
    """One row of a table of the paper; ``iteration`` only in Table 2 (``"1"`` or ``"T-5"``)."""

    method: str
    accuracy: float
    precision: float
    recall: float
    f_measure: float
    iteration: str = ""


EXP1 = (
    PaperRow("(A) pix2pix", 0.5831, 0.8613, 0.3762, 0.4939),
    PaperRow("(B) U-net", 0.5852, 0.8612, 0.3807, 0.4963),
    PaperRow("(C) Pseudo SLAM", 0.4340, 0.8517, 0.0616, 0.1110),
    PaperRow("(D) training map with highest precision", 0.4893, 0.8026, 0.1753, 0.2734),
    PaperRow("(A) pix2pix trained on HOME'S", 0.5065, 0.8537, 0.2222, 0.3481),
    PaperRow("(B) U-net trained on HOME'S", 0.5257, 0.7915, 0.2976, 0.4286),
)
"""Experiment 1 (HouseExpo, completion from one scan; the last two rows trained on HOME'S)."""

EXP2 = (
    PaperRow("(A) pix2pix", 0.7864, 0.4486, 0.7072, 0.4858, "1"),
    PaperRow("(B) U-net", 0.8028, 0.4686, 0.7561, 0.5275, "1"),
    PaperRow("(C) Gmapping", 0.8314, 0.6836, 0.0994, 0.1671, "1"),
    PaperRow("(D) baseline", 0.8429, 0.7765, 0.3371, 0.4062, "1"),
    PaperRow("(A) pix2pix", 0.8715, 0.6608, 0.6962, 0.6546, "T-5"),
    PaperRow("(B) U-net", 0.8718, 0.6306, 0.7063, 0.6429, "T-5"),
)
"""Table 2 (Experiment 2, simulated houses): iteration 1 and T−5; no Gmapping or baseline row at T−5."""

EXP3 = (
    PaperRow("(A) pix2pix", 0.7021, 0.7582, 0.2507, 0.3769),
    PaperRow("(B) U-net", 0.7002, 0.5985, 0.3119, 0.4101),
    PaperRow("(C) Gmapping", 0.6711, 0.9817, 0.1056, 0.1907),
    PaperRow("(D) baseline", 0.6802, 0.7351, 0.1945, 0.3076),
)
"""The real-lab table (Experiment 3, one lab room)."""


def markdown_rows(rows: tuple[PaperRow, ...]) -> list[str]:
    """Markdown table rows ``| method | [iteration |] Acc | Prec | Rec | F |`` (T−5 with the minus sign)."""
    out = []
    for r in rows:
        it = f" {r.iteration.replace('-', '−')} |" if r.iteration else ""
        out.append(f"| {r.method} |{it} {r.accuracy:.4f} | {r.precision:.4f} | {r.recall:.4f} | {r.f_measure:.4f} |")
    return out
