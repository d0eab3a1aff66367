"""SIGINT and SIGTERM at seeded random moments of ``mcnkit slam`` and ``mcnkit run`` (subprocesses): exit 130 / 143,
one line on stderr and no traceback, a recording that ``rerun rrd verify`` accepts, and ``--out`` holding the
results so far with ``"interrupted": true``.  ``benchmarks/bench_interrupts.py`` runs ten of each."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

RERUN = Path(sys.executable).parent / "rerun"
ENV = {**os.environ, "RERUN_ANALYTICS": "0"}


def _interrupt(argv: list[str], rrd: Path, signum: int, delay_s: float, *, after_start: bool) -> subprocess.Popen[str]:
    """Starts ``mcnkit ARGV``; sends ``signum`` ``delay_s`` after the recording was opened (``after_start``: after
    the process started); returns the finished process."""
    proc = subprocess.Popen([sys.executable, "-m", "mcnkit.app.main", *argv], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=ENV)
    partial = rrd.with_name(rrd.name + ".partial")
    deadline = time.monotonic() + 120
    while not after_start and not partial.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    time.sleep(delay_s)
    assert proc.poll() is None, f"finished before the signal: {proc.communicate()}"
    proc.send_signal(signum)
    proc.wait(timeout=300)
    return proc


def _check(proc: subprocess.Popen[str], signum: int, rrd: Path, out: Path, command: str) -> bool:
    """The checks every interrupted run passes; returns whether it had started stepping (partial results)."""
    assert proc.stderr is not None
    err = proc.stderr.read()
    name = signal.Signals(signum).name
    assert proc.returncode == 128 + signum, (proc.returncode, err)
    assert "Traceback" not in err and "Error" not in err, err
    assert err.strip().splitlines()[-1] == f"mcnkit {command}: interrupted by {name}", err
    assert len(err.strip().splitlines()) == 1, err
    assert not rrd.with_name(rrd.name + ".partial").exists()
    assert not list(out.glob(".mcnkit-*")), "a staging folder was left behind"
    if rrd.exists():
        verify = subprocess.run([str(RERUN), "rrd", "verify", str(rrd)], capture_output=True, text=True, env=ENV)
        assert verify.returncode == 0, verify.stderr
    summary = out / "summary.json"
    if not summary.exists():
        return False
    s = json.loads(summary.read_text())
    assert s["interrupted"] is True and s["stopped_by"] == name and s["scans"] > 0
    assert (out / "trajectory.tum").stat().st_size > 0 and (out / "map.pgm").is_file()
    assert len((out / "trajectory.tum").read_text().splitlines()) == s["scans"]
    if command == "slam":  # no offline refinement after a signal: the results come at once
        assert s["trajectory"] == "tracked"
        assert (out / "trajectory.tum").read_bytes() == (out / "trajectory_tracked.tum").read_bytes()
    assert rrd.exists()
    return True


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_slam_interrupted_at_random_moments(tmp_path: Path, shared_data: Path, signum: int) -> None:
    log = shared_data / "reallab/mit-csail/mit-csail.clf"
    rng = np.random.default_rng(17 + signum)
    stepped = 0
    for i, (delay, after_start) in enumerate([(rng.uniform(0.0, 3.0), False), (rng.uniform(0.0, 3.0), False),
                                              (rng.uniform(0.3, 1.2), True)]):
        rrd, out = tmp_path / f"run{i}.rrd", tmp_path / f"out{i}"
        proc = _interrupt(["slam", str(log), "--particles", "10", "--rrd", str(rrd), "--out", str(out),
                           "--no-progress"], rrd, signum, delay, after_start=after_start)
        stepped += _check(proc, signum, rrd, out, "slam")
    assert stepped >= 2  # the two signals sent after the recording opened found a run stepping


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_mcn_run_interrupted_at_random_moments(tmp_path: Path, shared_data: Path, signum: int) -> None:
    log = shared_data / "reallab/mit-csail/mit-csail.clf"
    rng = np.random.default_rng(29 + signum)
    stepped = 0
    for i in range(2):
        rrd, out = tmp_path / f"run{i}.rrd", tmp_path / f"out{i}"
        proc = _interrupt(["run", str(log), "--particles", "6", "--samples", "2", "--ranks", "1", "--rrd", str(rrd),
                           "--out", str(out), "--no-progress"], rrd, signum, rng.uniform(0.0, 3.0), after_start=False)
        stepped += _check(proc, signum, rrd, out, "run")
    assert stepped == 2
