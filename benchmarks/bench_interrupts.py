"""SIGINT and SIGTERM at ten seeded random moments each of ``mcnkit slam`` and ``mcnkit run`` on the MIT CSAIL log.

    python -m benchmarks.bench_interrupts [--tries 10] [--seed 0] [--data ../shared/data]

Each try starts the command as a subprocess with ``--rrd`` and ``--out``, waits for the recording to be opened
(its ``.partial`` file appears), sleeps a random 0–4 s and sends the signal.  Counted per command and signal: exit
code 128 + signal, stderr one line without a traceback, ``rerun rrd verify`` passing, ``--out`` holding
``trajectory.tum`` and a ``summary.json`` marked interrupted, and no temporary file left behind.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.common import data_dir

RERUN = Path(sys.executable).parent / "rerun"
ENV = {**os.environ, "RERUN_ANALYTICS": "0"}
COMMANDS = {
    "slam": ["slam", "{log}", "--particles", "30"],
    "run": ["run", "{log}", "--particles", "10", "--samples", "4", "--ranks", "2"],
}


def _try(argv: list[str], signum: int, delay_s: float, folder: Path) -> dict[str, object]:
    rrd, out = folder / "run.rrd", folder / "out"
    proc = subprocess.Popen([sys.executable, "-m", "mcnkit.app.main", *argv, "--rrd", str(rrd), "--out", str(out),
                             "--no-progress"], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=ENV)
    partial = rrd.with_name(rrd.name + ".partial")
    while not partial.exists() and proc.poll() is None:
        time.sleep(0.02)
    time.sleep(delay_s)
    finished_first = proc.poll() is not None
    if not finished_first:
        proc.send_signal(signum)
    _, err = proc.communicate(timeout=600)
    lines = err.strip().splitlines()
    verify = subprocess.run([str(RERUN), "rrd", "verify", str(rrd)], capture_output=True, text=True, env=ENV)
    summary = json.loads((out / "summary.json").read_text()) if (out / "summary.json").is_file() else {}
    return {
        "finished_first": finished_first,
        "exit_ok": proc.returncode == 128 + signum,
        "one_line": len(lines) == 1 and "Traceback" not in err,
        "verify_ok": verify.returncode == 0,
        "partial_out": bool(summary.get("interrupted")) and (out / "trajectory.tum").is_file(),
        "no_temp_left": not partial.exists() and not list(out.glob(".mcnkit-*")),
        "scans": summary.get("scans", 0),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--tries", type=int, default=10, help="interrupts per command and signal (default 10)")
    ap.add_argument("--seed", type=int, default=0, help="random seed of the moments the signals are sent (default 0)")
    ap.add_argument("--data", help="the shared data folder (default: $MCNKIT_SHARED_DATA, else ../shared/data)")
    ap.add_argument("--json", type=Path, default=None, help="also write the results here")
    args = ap.parse_args()
    log = data_dir(args.data) / "reallab/mit-csail/mit-csail.clf"
    rng = np.random.default_rng(args.seed)
    rows = []
    print("| command | signal | tries | exit 128+n | one line, no traceback | rrd verify | partial --out | "
          "no temp left | scans at stop (min–max) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, template in COMMANDS.items():
        argv = [a.format(log=log) for a in template]
        for signum in (signal.SIGINT, signal.SIGTERM):
            results = []
            for _ in range(args.tries):
                with tempfile.TemporaryDirectory(prefix="mcnkit-bench-int-") as tmp:
                    results.append(_try(argv, signum, float(rng.uniform(0.0, 4.0)), Path(tmp)))
            sent = [r for r in results if not r["finished_first"]]
            count = {k: sum(bool(r[k]) for r in sent) for k in
                     ("exit_ok", "one_line", "verify_ok", "partial_out", "no_temp_left")}
            scans = [int(r["scans"]) for r in sent] or [0]  # type: ignore[call-overload]
            sig = signal.Signals(signum).name
            rows.append({"command": name, "signal": sig, "tries": len(sent), **count, "scans": scans})
            print(f"| {name} | {sig} | {len(sent)} | {count['exit_ok']} | {count['one_line']} | {count['verify_ok']} | "
                  f"{count['partial_out']} | {count['no_temp_left']} | {min(scans)}–{max(scans)} |", flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")
    return 0 if all(r[k] == r["tries"] for r in rows for k in
                    ("exit_ok", "one_line", "verify_ok", "partial_out", "no_temp_left")) else 1


if __name__ == "__main__":
    sys.exit(main())
