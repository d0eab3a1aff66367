"""The paper's SLAM experiments: Experiment 2 (MCN-SLAM on simulated HouseExpo houses, :mod:`.exp2`) and
Experiment 3 (the real-lab logs MIT CSAIL and Intel, :mod:`.exp3`).  Experiment 1 (completion from one scan) is
:mod:`mcnkit.completion.exp1`.

Each experiment is a frozen config dataclass, a ``run_*`` function that writes a CSV, a Markdown report and PNG
figures and returns the Markdown, and an ``add_*_arguments(parser)`` that adds its command-line options (for
``mcnkit experiment exp2|exp3``, in :mod:`.options`; ``exp2_config_from_args`` / ``exp3_config_from_args`` build the config back from
the parsed options).
"""

from typing import TYPE_CHECKING

from mcnkit._lazy import lazy_exports

if TYPE_CHECKING:
    from mcnkit.experiments.exp2 import run_exp2
    from mcnkit.experiments.exp3 import run_exp3
    from mcnkit.experiments.options import (
        Exp2Config,
        Exp3Config,
        add_exp2_arguments,
        add_exp3_arguments,
        exp2_config_from_args,
        exp3_config_from_args,
    )

__all__ = [
    "Exp2Config",
    "Exp3Config",
    "add_exp2_arguments",
    "add_exp3_arguments",
    "exp2_config_from_args",
    "exp3_config_from_args",
    "run_exp2",
    "run_exp3",
]

__getattr__, __dir__ = lazy_exports(__name__, {
    "mcnkit.experiments.exp2": ("run_exp2",),
    "mcnkit.experiments.exp3": ("run_exp3",),
    "mcnkit.experiments.options": ("Exp2Config", "Exp3Config", "add_exp2_arguments", "add_exp3_arguments",
                                   "exp2_config_from_args", "exp3_config_from_args"),
})
