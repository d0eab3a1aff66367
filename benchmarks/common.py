"""What the benchmarks share: where the data and results live, the real buildings with a reference, and the
documented ``mcnkit slam`` command as a child process runs it.

The benchmarks are a package: run them from the repository root as ``python -m benchmarks.NAME`` (the studies as
``python -m benchmarks.studies.NAME``)."""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

__all__ = ["BUILDINGS", "RESULTS", "ROOT", "SLAM_ENV", "data_dir", "save_report", "slam_command"]

ROOT = Path(__file__).resolve().parents[1]
"""The repository."""
RESULTS = ROOT / "benchmarks" / "results"
"""Where every benchmark writes its JSON (and figures)."""

BUILDINGS = {
    "aces": ("reallab/radish/aces-corrected.log.gz", None),
    "fr079": ("reallab/radish/freiburg-079-corrected.log.gz", None),
    "fr101": ("reallab/radish/freiburg-101-corrected.log.gz", None),
    "fhw": ("reallab/radish/fhw-corrected.log.gz", None),
    "acapulco": ("reallab/radish/acapulco-corrected.log.gz", None),
    "intel": ("reallab/intel/intel-corrected.log.gz", None),
    "campus": ("reallab/radish/freiburg-campus-corrected.log.gz", None),
    "mit-csail": ("reallab/mit-csail/mit-csail.clf", "reallab/mit-csail/mit-csail.relations"),
}
"""Building -> (its log relative to the data folder, its relations file or None)."""


def data_dir(arg: str | None = None) -> Path:
    """The shared data folder: ``arg`` (a ``--data`` flag), else ``$MCNKIT_SHARED_DATA``, else ``../shared/data``."""
    if arg:
        return Path(arg)
    env = os.environ.get("MCNKIT_SHARED_DATA")
    return Path(env) if env else ROOT.parent / "shared" / "data"


def slam_command(log: Path, seed: int, out: Path, options: Sequence[str] = ()) -> list[str]:
    """The documented command, ``mcnkit slam LOG --particles 30 --resolution 0.05 --out DIR``, as this
    interpreter runs it (no progress bar; ``options`` appended)."""
    return [sys.executable, "-m", "mcnkit.app.main", "slam", str(log), "--particles", "30", "--resolution", "0.05",
            "--seed", str(seed), "--out", str(out), "--no-progress", *options]


SLAM_ENV = {**os.environ, "RERUN_ANALYTICS": "0"}
"""The environment benchmarks run ``mcnkit slam`` in (Rerun analytics off)."""


def save_report(out: Path, report: dict[str, Any], md: str) -> int:
    """Prints the markdown table, writes the report as JSON to ``out`` and the table beside it (``.md``); the exit
    code: 0 when the report's verdict is ok, else 1."""
    print(md)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=1) + "\n")
    out.with_suffix(".md").write_text(md)
    return 0 if report["verdict"]["ok"] else 1
