"""Watching a run live: ``--connect`` to a running viewer and ``--serve`` from the run's own gRPC server, both beside
``--rrd``; the whole configuration in the recording; ``--mcn.FIELD`` / ``--recording.FIELD`` flags.

The viewer is Rerun's own binary, headless: ``rerun --save FILE --bind 127.0.0.1 --port P`` is a gRPC server that
writes everything it receives to FILE, and ``rerun URL --save FILE`` a client that saves what a server sends.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from mcnkit.app.main import main
from mcnkit.app.recording import DEFAULT_VIEWER_URL, RecordingConfig, ViewerError, check_viewer, free_port, viewer_url

ENV = {**os.environ, "RERUN_ANALYTICS": "0"}


def _rerun_binary() -> Path:
    import rerun_cli

    return Path(rerun_cli.__file__).parent / "rerun"  # the binary itself: ending it ends the server


def _write_clf(path: Path, n: int = 30, *, back_and_forth: bool = False) -> None:
    """A robot driving +x at 0.1 m per scan in a 4 m wide corridor, 181 beams (as tests/app/commands/test_slam.py); or, for
    long logs, back and forth between x = 1 and x = 5."""
    angles = np.radians(np.linspace(-90, 90, 181))
    lines = []
    for k in range(n):
        x = 3.0 - 2.0 * np.cos(0.05 * k) if back_and_forth else 0.1 * k
        with np.errstate(divide="ignore"):
            r = np.abs(np.where(np.sin(angles) > 0, 2.0, -2.0) / np.sin(angles))
        r = np.minimum(np.minimum(r, (8.0 - x) / np.maximum(np.cos(angles), 1e-3)), 81.91)
        t = 1000.0 + 0.2 * k
        lines.append(f"FLASER 181 {' '.join(f'{v:.3f}' for v in r)} {x:.3f} 0.0 0.0 {x:.3f} 0.0 0.0 {t:.6f} h {t:.6f}")
    path.write_text("\n".join(lines) + "\n")


def _wait_port(port: int, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.2):
                return
        except OSError:
            time.sleep(0.05)
    raise AssertionError(f"nothing listens on 127.0.0.1:{port}")


def _listening(port: int) -> bool:
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=0.2):
            return True
    except OSError:
        return False


def _entities(path: Path) -> tuple[set[str], int]:
    """The entity paths of a (possibly unfinished) .rrd and its /world/particles rows."""
    from rerun.chunk import RrdReader

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a file still being received has no footer yet
        store = RrdReader(path).stream().collect()
    rows = sum(chunk.num_rows for chunk in store.stream() if chunk.entity_path == "/world/particles")
    return {chunk.entity_path for chunk in store.stream()}, rows


def _wait_rows(path: Path, rows: int, timeout_s: float = 15.0) -> set[str]:
    deadline = time.monotonic() + timeout_s
    seen: tuple[set[str], int] = (set(), 0)
    while time.monotonic() < deadline:
        if path.is_file() and path.stat().st_size > 0:
            try:
                seen = _entities(path)
            except Exception:  # noqa: BLE001 - a message half written: read again
                seen = (set(), 0)
            if seen[1] >= rows:
                return seen[0]
        time.sleep(0.2)
    raise AssertionError(f"{path}: {seen[1]} of {rows} particle rows arrived")


def _config_document(path: Path) -> dict[str, object]:
    from rerun.chunk import RrdReader

    table = RrdReader(path).stream().collect().reader(index=None, contents="/config").to_arrow_table()
    return json.loads(table.column("/config:TextDocument:text")[0].as_py()[0])  # type: ignore[no-any-return]


def _verify(path: Path) -> None:
    run = subprocess.run([sys.executable, "-m", "rerun", "rrd", "verify", str(path)], capture_output=True, text=True,
                         env=ENV, check=False)
    assert run.returncode == 0, run.stderr


@pytest.fixture
def viewer(tmp_path: Path) -> Iterator[tuple[int, Path]]:
    """A headless viewer on 127.0.0.1 that saves what it receives: (its port, its file)."""
    port, received = free_port(), tmp_path / "received.rrd"
    proc = subprocess.Popen([str(_rerun_binary()), "--save", str(received), "--bind", "127.0.0.1", "--port", str(port)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=ENV)
    try:
        _wait_port(port)
        yield port, received
    finally:
        proc.terminate()
        proc.wait(timeout=10)


def test_slam_streams_to_a_running_viewer_and_to_its_file(tmp_path: Path, viewer: tuple[int, Path]) -> None:
    port, received = viewer
    log, rrd, out = tmp_path / "corridor.clf", tmp_path / "run.rrd", tmp_path / "out"
    _write_clf(log)
    assert main(["slam", str(log), "--particles", "4", "--out", str(out), "--rrd", str(rrd), "--no-progress",
                 "--connect", str(port)]) == 0
    entities = _wait_rows(received, 30)  # every scan reached the viewer ...
    assert {"/world/particles", "/world/map/estimate", "/world/scan/hits", "/config"} <= entities
    assert _entities(rrd) == (entities, 30)  # ... and the file, which is finalised
    _verify(rrd)
    summary = json.loads((out / "summary.json").read_text())
    document = _config_document(rrd)  # the recording says how it was made, as summary.json does
    assert document["config"] == summary["config"] and document["recording"] == summary["recording"]
    assert (document["command"], document["seed"], document["log"]) == ("slam", 0, str(log))


def test_an_interrupted_live_run_leaves_a_readable_file(tmp_path: Path, viewer: tuple[int, Path]) -> None:
    port, received = viewer
    log, rrd = tmp_path / "long.clf", tmp_path / "run.rrd"
    _write_clf(log, 5000, back_and_forth=True)  # far longer than the test waits
    proc = subprocess.Popen([sys.executable, "-m", "mcnkit.app.main", "slam", str(log), "--particles", "4", "--out",
                             str(tmp_path / "out"), "--rrd", str(rrd), "--no-progress", "--connect",
                             f"rerun+http://127.0.0.1:{port}/proxy"], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=ENV)
    _wait_rows(received, 5, timeout_s=60)  # it is running and the viewer gets it
    assert proc.poll() is None, proc.communicate()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130 and "Traceback" not in err, err
    _verify(rrd)
    _, rows = _entities(rrd)
    assert 5 <= rows < 5000
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["interrupted"] is True


def test_serve_hosts_the_recording_for_viewers_that_connect_late(tmp_path: Path) -> None:
    log, rrd, got = tmp_path / "corridor.clf", tmp_path / "run.rrd", tmp_path / "got.rrd"
    _write_clf(log)
    proc = subprocess.Popen([sys.executable, "-m", "mcnkit.app.main", "slam", str(log), "--particles", "4", "--out",
                             str(tmp_path / "out"), "--rrd", str(rrd), "--no-progress", "--serve",
                             "--recording.grpc-port", "0", "--recording.linger-s", "60"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV)
    assert proc.stdout is not None
    lines = []
    for line in proc.stdout:  # the address comes first, then the run, then "still serving"
        lines.append(line)
        if line.startswith("the run is over"):
            break
    url = next(w for w in lines[0].split() if w.startswith("rerun+http://127.0.0.1:"))
    port = int(url.rsplit(":", 1)[1].split("/")[0])
    assert rrd.is_file()  # the file is finalised while the server goes on
    _verify(rrd)
    client = subprocess.Popen([str(_rerun_binary()), url, "--save", str(got), "--bind", "127.0.0.1", "--port",
                               str(free_port())], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=ENV)
    try:
        entities = _wait_rows(got, 30)  # a viewer that connects after the run gets all of it
    finally:
        client.terminate()
        client.wait(timeout=10)
    assert {"/world/particles", "/config"} <= entities
    proc.send_signal(signal.SIGINT)  # Ctrl-C ends the serving, not the (finished) run
    _, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    assert not _listening(port)


def test_viewer_addresses_and_one_line_errors(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert viewer_url(None) == viewer_url("") == DEFAULT_VIEWER_URL == "rerun+http://127.0.0.1:9876/proxy"
    assert viewer_url("9877") == "rerun+http://127.0.0.1:9877/proxy"
    assert viewer_url("localhost:9000") == "rerun+http://localhost:9000/proxy"
    assert viewer_url("rerun+https://example.org:443/proxy") == "rerun+https://example.org:443/proxy"
    with pytest.raises(ViewerError, match="not a viewer address"):
        viewer_url("http://127.0.0.1:9876/")
    port = free_port()
    with pytest.raises(ViewerError, match="no Rerun viewer is listening there"):
        check_viewer(f"rerun+http://127.0.0.1:{port}/proxy")
    log = tmp_path / "corridor.clf"
    _write_clf(log, 3)
    assert main(["slam", str(log), "--out", str(tmp_path / "o"), "--connect", str(port), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith(f"mcnkit slam: rerun+http://127.0.0.1:{port}/proxy: no Rerun viewer") and "\n" not in err
    assert not (tmp_path / "o").exists()  # refused before anything was written
    with socket.socket() as busy:  # a port to serve on that is taken
        busy.bind(("127.0.0.1", 0))
        busy.listen()
        taken = busy.getsockname()[1]
        assert main(["slam", str(log), "--out", str(tmp_path / "o"), "--serve", "--recording.grpc-port", str(taken),
                     "--no-progress"]) == 2
    assert f"127.0.0.1:{taken}: cannot serve the gRPC server there" in capsys.readouterr().err
    with pytest.raises(ValueError, match="port number"):
        RecordingConfig(grpc_port=70000)
