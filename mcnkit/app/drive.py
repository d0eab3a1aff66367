"""One loop over frames for every command that runs SLAM: a stepper fed frame by frame, each step handed to sinks.

    stepper = FastSlam(config, rng)            # or McnSlam(...): anything with ``step(frame)``
    sinks = [ProgressSink(total), RecordingSink(logger, stepper), SlamOutputs(out, stepper, ...)]
    outcome = drive(log.frames(), stepper, sinks, stop=SIGNALS.requested)

A :class:`Sink` sees every step (:meth:`Sink.on_step`) and is closed once (:meth:`Sink.close`) however the loop
ends: all frames read, a stop request (a signal), or an exception (a damaged log, Ctrl-C in a notebook).  So the
recording is finalised and the output files hold the results so far in every case; the :class:`Outcome` says which.

Signals: :data:`SIGNALS` is installed by ``mcnkit``'s ``main()``.  Outside :meth:`Signals.deferred` a SIGINT or
SIGTERM raises :class:`Interrupted` at once (nothing is being written then); inside it, the signal is only noted,
the driver stops before the next frame (never inside compiled numba code) and the sinks write what there is.  A
second signal while deferred ends the process at once.  Library callers (notebooks, scripts) do not install it:
there Ctrl-C raises ``KeyboardInterrupt`` as usual and the sinks are still closed.
"""

from __future__ import annotations

import math
import os
import signal
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from types import FrameType
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:  # nothing heavy at import: ``mcnkit``'s main() imports this module before anything else
    from mcnkit.mcn import StepResult
    from mcnkit.slam.fastslam import SlamStep
    from mcnkit.types import Frame

__all__ = ["SIGNALS", "CallbackSink", "DriveStep", "Interrupted", "Outcome", "ProgressSink", "Signals", "Sink",
           "Stepper", "close_sinks", "drive"]


class Stepper(Protocol):
    """What the driver feeds: :class:`~mcnkit.slam.FastSlam` (a ``SlamStep`` per frame) or
    :class:`~mcnkit.mcn.McnSlam` (a ``StepResult``)."""

    def step(self, frame: Frame) -> Any:
        """Processes one frame."""
        ...


@dataclass(frozen=True)
class DriveStep:
    """One frame and what the stepper made of it."""

    frame: Frame
    slam: SlamStep
    """The filter's step (for MCN-SLAM, ``mcn.slam``)."""
    mcn: StepResult | None = None
    """MCN-SLAM's whole result (completions, scores), None for plain FastSLAM."""


@dataclass(frozen=True)
class Outcome:
    """How a drive ended: the frames stepped, why it stopped early (None: every frame was read) and its time."""

    scans: int
    stopped_by: str | None
    """``"SIGINT"``, ``"SIGTERM"``, or ``"<ExceptionType>: message"``; None when the frames ran out."""
    cpu_s: float
    wall_s: float

    @property
    def interrupted(self) -> bool:
        """True when the run ended before the frames did."""
        return self.stopped_by is not None

    @property
    def signalled(self) -> bool:
        """True when SIGINT or SIGTERM stopped the run (a user waiting for the results, not a damaged log)."""
        return self.stopped_by in ("SIGINT", "SIGTERM")


class Sink(Protocol):
    """A consumer of steps: a recording, output files, a progress bar, a notebook callback."""

    def on_step(self, step: DriveStep) -> None:
        """Called after every step."""
        ...

    def close(self, outcome: Outcome) -> None:
        """Called once when the loop ends, however it ends (sinks are closed in the order given)."""
        ...


def _as_step(frame: Frame, result: Any) -> DriveStep:
    """A ``SlamStep`` as it is; an MCN ``StepResult`` (it has ``completion``) with its ``slam`` step."""
    if hasattr(result, "completion"):
        return DriveStep(frame, result.slam, result)
    return DriveStep(frame, result)


def close_sinks(sinks: Sequence[Sink], outcome: Outcome) -> BaseException | None:
    """Closes every sink, even when one fails; returns the first failure (for a drive run with
    ``close=False``, closed by its caller when the last part has run)."""
    first: BaseException | None = None
    for sink in sinks:
        try:
            sink.close(outcome)
        except BaseException as err:  # noqa: BLE001 - closed all, then re-raised by the caller
            first = first or err
    return first


def drive(frames: Iterable[Frame], stepper: Stepper, sinks: Sequence[Sink] = (), *,
          stop: Callable[[], str | None] | None = None, close: bool = True) -> Outcome:
    """Feeds ``frames`` to ``stepper`` one at a time and hands every step to ``sinks``; returns the outcome.

    ``stop()`` is asked before every frame (and once after the last): a non-None answer (the reason) ends the loop
    there.  An exception from the frames, the stepper or a sink closes every sink (with an outcome naming it) and
    propagates.  ``close=False`` leaves the sinks open when the frames run out, for a run driven in parts (a
    notebook's step button): the caller ends it with :func:`close_sinks`.
    """
    cpu0, wall0 = time.process_time(), time.perf_counter()
    scans = 0

    def outcome(stopped_by: str | None) -> Outcome:
        return Outcome(scans, stopped_by, time.process_time() - cpu0, time.perf_counter() - wall0)

    stopped_by: str | None = None
    try:
        for frame in frames:
            if stop is not None and (stopped_by := stop()) is not None:
                break
            step = _as_step(frame, stepper.step(frame))
            scans += 1
            for sink in sinks:
                sink.on_step(step)
        if stopped_by is None and stop is not None:
            stopped_by = stop()
    except BaseException as err:
        failure = close_sinks(sinks, outcome(f"{type(err).__name__}: {err}".splitlines()[0]))
        if failure is not None and failure is not err:
            raise err from failure
        raise
    done = outcome(stopped_by)
    if not close and stopped_by is None:
        return done
    failure = close_sinks(sinks, done)
    if failure is not None:
        raise failure
    return done


class ProgressSink:
    """A tqdm progress bar over scans, with the filter's updates and N_eff."""

    def __init__(self, total: int | None, *, enabled: bool = True) -> None:
        from tqdm import tqdm

        self.bar = tqdm(total=total, unit="scan", disable=not enabled)
        self._updates = 0

    def on_step(self, step: DriveStep) -> None:
        """Advances the bar."""
        if step.slam.updated:
            self._updates += 1
            self.bar.set_postfix(updates=self._updates, neff=f"{step.slam.neff:.1f}", refresh=False)
        self.bar.update(1)

    def close(self, outcome: Outcome) -> None:
        """Closes the bar."""
        self.bar.close()


class CallbackSink:
    """Calls ``on_step(frame, result)`` after every step (``result``: the stepper's own return value), e.g. to
    draw in a notebook."""

    def __init__(self, on_step: Callable[[Frame, Any], None]) -> None:
        self._on_step = on_step

    def on_step(self, step: DriveStep) -> None:
        """Calls the callback."""
        self._on_step(step.frame, step.mcn if step.mcn is not None else step.slam)

    def close(self, outcome: Outcome) -> None:
        """Nothing to close."""


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived while nothing was being written; ``exit_code`` is 128 + the signal number."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        self.name = signal.Signals(signum).name
        self.exit_code = 128 + signum
        super().__init__(self.name)


class Signals:
    """SIGINT / SIGTERM handling for the ``mcnkit`` command (see the module docstring)."""

    HANDLED = (signal.SIGINT, signal.SIGTERM)

    def __init__(self) -> None:
        self.received: int | None = None
        self._deferring = 0

    @contextmanager
    def installed(self, enabled: bool = True) -> Iterator[Signals]:
        """Inside, the handlers are installed (``enabled``: call from the main thread only): a signal raises
        :class:`Interrupted`, or is noted inside :meth:`deferred`; the previous handlers come back on leaving, and
        the signal received is forgotten."""
        self.received = None
        previous = {s: signal.signal(s, self._handle) for s in self.HANDLED} if enabled else {}
        try:
            yield self
        finally:
            for s, handler in previous.items():
                signal.signal(s, handler)
            self.received = None  # a signal ends the command it came in; the next call starts afresh

    def _handle(self, signum: int, _frame: FrameType | None) -> None:
        if not self._deferring:
            self.received = signum
            raise Interrupted(signum)
        if self.received is not None:  # a second signal while the results are written: give up at once
            os.write(2, f"mcnkit: {signal.Signals(signum).name} again, stopped at once\n".encode())
            os._exit(128 + signum)
        self.received = signum

    @contextmanager
    def deferred(self) -> Iterator[Signals]:
        """Inside: signals are noted, not raised (the driver asks :meth:`requested` between frames)."""
        self._deferring += 1
        try:
            yield self
        finally:
            self._deferring -= 1

    def wait(self, seconds: float) -> str | None:
        """Sleeps ``seconds`` (< 0: until a signal) or until SIGINT / SIGTERM, with signals deferred; returns the
        signal's name (None: the time ran out) and forgets it: it ended the wait, not the command."""
        deadline = math.inf if seconds < 0 else time.monotonic() + seconds
        with self.deferred():
            while self.received is None and (left := deadline - time.monotonic()) > 0:
                time.sleep(min(0.2, left))
            name, self.received = self.requested(), None
        return name

    def requested(self) -> str | None:
        """The name of the signal received (``"SIGINT"``, ``"SIGTERM"``), None if none."""
        return None if self.received is None else signal.Signals(self.received).name

    @property
    def exit_code(self) -> int | None:
        """128 + the signal number once one was received."""
        return None if self.received is None else 128 + self.received


SIGNALS = Signals()
"""The process's signal state; ``mcnkit``'s ``main()`` installs it, library calls leave it alone."""
