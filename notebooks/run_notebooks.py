"""Executes every notebook top to bottom, in full mode (or small with --ci), on copies: the committed notebooks
keep no outputs.  Executed copies go to ``notebooks/executed/`` (not committed).

    .venv/bin/python notebooks/run_notebooks.py [--ci] [names...]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import nbformat
from nbclient import NotebookClient
from nbclient.exceptions import CellExecutionError

HERE = Path(__file__).resolve().parent


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("names", nargs="*", help="notebook file names (default: all)")
    ap.add_argument("--ci", action="store_true", help="small parameters, no viewer (what make test runs)")
    ap.add_argument("--timeout", type=int, default=1800, help="seconds per cell")
    args = ap.parse_args()
    if args.ci:
        os.environ["MCNKIT_CI"] = "1"
    else:
        os.environ.pop("MCNKIT_CI", None)
    os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")
    out_dir = HERE / "executed"
    out_dir.mkdir(exist_ok=True)
    paths = [HERE / n for n in args.names] if args.names else sorted(HERE.glob("*.ipynb"))
    failed = 0
    for path in paths:
        nb = nbformat.read(path, as_version=4)
        t0 = time.perf_counter()
        try:
            NotebookClient(nb, timeout=args.timeout, kernel_name="python3",
                           resources={"metadata": {"path": str(HERE)}}).execute()
            status = "ok"
        except CellExecutionError as err:
            failed += 1
            status = f"FAILED: {str(err).strip().splitlines()[-1]}"
        nbformat.write(nb, out_dir / path.name)
        print(f"{path.name:40s} {time.perf_counter() - t0:6.1f} s  {status}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
