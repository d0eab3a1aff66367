"""Finished ``.rrd`` files: compacted in place, shown in a notebook."""

from __future__ import annotations

import uuid
from pathlib import Path
from typing import Any

import rerun as rr

from mcnkit.viz.blueprints import APPLICATION_ID, recording_blueprint

__all__ = ["optimize_recording", "recording_viewer"]


def recording_viewer(path: str | Path, size: tuple[int, int] = (1000, 560)) -> Any:
    """An embedded notebook viewer showing a finished ``.rrd`` (its chunks are sent from the kernel, offline),
    laid out by :func:`recording_blueprint`.

    Returns the ``rerun.notebook.Viewer``; call ``.display()`` on it, and ``.set_time_ctrl(timeline="step",
    sequence=i, play=False)`` to move its time cursor.
    """
    import os

    from rerun.chunk import RrdReader

    os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")
    import rerun.notebook

    reader = RrdReader(str(path))
    rec_id = reader.recordings()[0].recording_id if reader.recordings() else str(uuid.uuid4())
    store = reader.store()
    blueprint = recording_blueprint({chunk.entity_path for chunk in reader.stream().collect().stream()})
    stream = rr.RecordingStream(APPLICATION_ID, recording_id=rec_id)
    viewer = rerun.notebook.Viewer(recording=stream, width=size[0], height=size[1], blueprint=blueprint)
    viewer.update_panels(blueprint="hidden", selection="hidden")
    stream.send_chunks(store)
    return viewer


def optimize_recording(path: str | Path) -> tuple[int, int]:
    """Compacts a finished ``.rrd`` in place with ``rerun rrd optimize`` (many small chunks merged: about a third
    of the size, the blueprint kept); returns the sizes before and after.  On failure the file is left as it was.
    """
    import subprocess
    import sys

    path = Path(path)
    before = path.stat().st_size
    tmp = path.with_name(path.name + ".optimized.partial")
    done = subprocess.run([sys.executable, "-m", "rerun", "rrd", "optimize", str(path), "-o", str(tmp)],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0 or not tmp.is_file() or tmp.stat().st_size == 0:
        tmp.unlink(missing_ok=True)
        return before, before
    tmp.replace(path)
    return before, path.stat().st_size
