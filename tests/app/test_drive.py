"""The one driver: steps handed to sinks in order, stop requests, and every sink closed however the loop ends."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from mcnkit.app.drive import SIGNALS, CallbackSink, DriveStep, Interrupted, Outcome, drive
from mcnkit.app.sinks import SlamOutputs
from mcnkit.io.errors import LogError
from mcnkit.slam import FastSlam, SlamConfig
from mcnkit.types import Frame
from mcnkit.viz.record import RecordingSink


class _Log:
    """A sink that remembers what it saw."""

    def __init__(self, fail_on_close: bool = False) -> None:
        self.indices: list[int] = []
        self.outcome: Outcome | None = None
        self.fail_on_close = fail_on_close

    def on_step(self, step: DriveStep) -> None:
        self.indices.append(step.slam.index)

    def close(self, outcome: Outcome) -> None:
        self.outcome = outcome
        if self.fail_on_close:
            raise RuntimeError("close failed")


def test_every_step_reaches_every_sink_and_a_stop_ends_between_frames(frames: list[Frame]) -> None:
    slam = FastSlam(SlamConfig(n_particles=3), np.random.default_rng(0))
    a, b = _Log(), _Log()
    seen: list[int] = []
    outcome = drive(frames, slam, [a, CallbackSink(lambda f, r: seen.append(r.index)), b],
                    stop=lambda: "SIGINT" if slam.n_scans == 7 else None)
    assert a.indices == b.indices == seen == list(range(7))
    assert outcome.scans == 7 and outcome.stopped_by == "SIGINT" and outcome.interrupted
    assert a.outcome == b.outcome == outcome
    full = _Log()
    done = drive(frames, FastSlam(SlamConfig(n_particles=3), np.random.default_rng(0)), [full])
    assert done.scans == len(frames) and not done.interrupted and full.indices == list(range(len(frames)))


def test_an_exception_closes_every_sink_then_propagates(frames: list[Frame]) -> None:
    def damaged() -> Iterator[Frame]:
        yield from frames[:5]
        raise LogError("run.bag", "chunk 3: bad CRC")

    a, broken, c = _Log(), _Log(fail_on_close=True), _Log()
    with pytest.raises(LogError, match="bad CRC") as info:
        drive(damaged(), FastSlam(SlamConfig(n_particles=3), np.random.default_rng(0)), [a, broken, c])
    assert isinstance(info.value.__cause__, RuntimeError)  # the failed close is chained, not lost
    for sink in (a, broken, c):
        assert sink.outcome is not None and sink.outcome.scans == 5
        assert sink.outcome.stopped_by == "LogError: run.bag: chunk 3: bad CRC"


def test_a_damaged_log_still_leaves_readable_outputs_and_recording(frames: list[Frame], tmp_path: Path) -> None:
    from mcnkit.viz import RerunLogger

    def damaged() -> Iterator[Frame]:
        yield from frames[:12]
        raise LogError("run.bag", "truncated")

    slam = FastSlam(SlamConfig(n_particles=3), np.random.default_rng(0))
    rrd, out = tmp_path / "run.rrd", tmp_path / "out"
    sinks = [RecordingSink(RerunLogger(rrd), slam), SlamOutputs(out, slam, {"log": "run.bag"})]
    with pytest.raises(LogError):
        drive(damaged(), slam, sinks)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["scans"] == 12 and summary["interrupted"] and summary["stopped_by"].startswith("LogError")
    assert len((out / "trajectory.tum").read_text().splitlines()) == 12
    verify = subprocess.run([sys.executable, "-m", "rerun", "rrd", "verify", str(rrd)], capture_output=True,
                            text=True, env={**os.environ, "RERUN_ANALYTICS": "0"})
    assert verify.returncode == 0, verify.stderr
    assert not rrd.with_name("run.rrd.partial").exists() and not list(out.glob(".mcnkit-*"))


def test_signals_raise_outside_a_drive_and_are_noted_inside() -> None:
    before = signal.getsignal(signal.SIGTERM)
    with SIGNALS.installed():
        with pytest.raises(Interrupted) as info:
            os.kill(os.getpid(), signal.SIGTERM)
        assert info.value.exit_code == 143
        with SIGNALS.installed(), SIGNALS.deferred():
            os.kill(os.getpid(), signal.SIGINT)  # noted, nothing raised
            assert SIGNALS.requested() == "SIGINT" and SIGNALS.exit_code == 130
    assert signal.getsignal(signal.SIGTERM) is before
