"""The paper's experiments: Experiment 1 (map completion from one scan, :mod:`.exp1`), Experiment 2 (MCN-SLAM on
simulated HouseExpo houses, :mod:`.exp2`) and Experiment 3 (the real-lab logs MIT CSAIL and Intel, :mod:`.exp3`).

Each experiment is a frozen config dataclass (:mod:`.config`, so that ``mcnkit experiment --help`` loads neither
torch nor the SLAM; every field is a flag of its command), a ``run_*`` function that computes the rows of its
tables and writes them (CSV, a Markdown report, PNG figures) and returns the Markdown.  Apart from the computing:
the rows are dataclasses (:mod:`.rows`) written and read back by :mod:`.tables`; the paper's tables are data
(:mod:`.paper`) and so are Experiment 2's targets (:mod:`.targets`); the reports and figures are
``exp1_report``, ``exp2_report``, ``exp2_figures`` and ``exp3_report``; Experiment 2's per-house SLAM runs and
their cache are :mod:`.houses`.
"""

from typing import TYPE_CHECKING

from mcnkit._lazy import lazy_exports

if TYPE_CHECKING:
    from mcnkit.experiments.config import Exp1Config, Exp2Config, Exp3Config
    from mcnkit.experiments.exp1 import run_exp1
    from mcnkit.experiments.exp2 import run_exp2
    from mcnkit.experiments.exp3 import run_exp3

__all__ = [
    "Exp1Config",
    "Exp2Config",
    "Exp3Config",
    "run_exp1",
    "run_exp2",
    "run_exp3",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "mcnkit.experiments.exp1": ("run_exp1",),
    "mcnkit.experiments.exp2": ("run_exp2",),
    "mcnkit.experiments.exp3": ("run_exp3",),
    "mcnkit.experiments.config": ("Exp1Config", "Exp2Config", "Exp3Config"),
})
