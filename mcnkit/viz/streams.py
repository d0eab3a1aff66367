"""One recording fanned out to several Rerun streams: the ``.rrd`` file and the live viewers (gRPC, a notebook)."""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Any

import rerun as rr
import rerun.blueprint as rrb

if TYPE_CHECKING:
    from mcnkit.app.recording import LiveViewer

__all__ = ["Tee"]


class Tee:
    """One recording, sent to the ``.rrd`` file and, optionally, to live viewers (gRPC, a notebook).

    Every destination has its own stream with the same application and recording ids, and every call is made on
    each: a notebook viewer takes over the sinks of its stream, the file is finalised when the run ends while a
    served stream may go on serving, and a viewer that goes away cannot hold up the file.
    """

    def __init__(self, application_id: str, recording_id: str) -> None:
        self.streams: list[rr.RecordingStream] = []
        self.file: rr.RecordingStream | None = None
        self.served: rr.RecordingStream | None = None
        self._ids = (application_id, recording_id)

    def _stream(self) -> rr.RecordingStream:
        stream = rr.RecordingStream(self._ids[0], recording_id=self._ids[1])
        stream.set_log_time_enabled(False)  # deterministic files: no wall-clock timeline
        self.streams.append(stream)
        return stream

    def attach_file(self, path: Path, blueprint: rrb.Blueprint) -> None:
        self.file = self._stream()
        self.file.save(str(path), default_blueprint=blueprint)

    def attach_grpc(self, live: LiveViewer, blueprint: rrb.Blueprint) -> None:
        """A stream to a running viewer (``live.connect``) and one to a server hosted on 127.0.0.1."""
        if live.connect is not None:
            self._stream().set_sinks(rr.GrpcSink(live.connect), default_blueprint=blueprint)
        if live.serve_port is not None:
            self.served = self._stream()
            server = rr.GrpcServerSink(bind_ip="127.0.0.1", port=live.serve_port,
                                       server_memory_limit=live.server_memory_limit)
            self.served.set_sinks(server, default_blueprint=blueprint)

    def attach_notebook_viewer(self, blueprint: rrb.Blueprint, size: tuple[int, int]) -> Any:
        import os

        os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")  # offline: the kernel serves the viewer
        import rerun.notebook

        live = self._stream()
        viewer = rerun.notebook.Viewer(recording=live, width=size[0], height=size[1], blueprint=blueprint)
        viewer.update_panels(blueprint="hidden", selection="hidden")  # room for the views; the time panel stays
        return viewer

    def log(self, *args: Any, **kwargs: Any) -> None:
        for s in self.streams:
            s.log(*args, **kwargs)

    def set_time(self, *args: Any, **kwargs: Any) -> None:
        for s in self.streams:
            s.set_time(*args, **kwargs)

    def send_columns(self, *args: Any, live: bool | None = None, **kwargs: Any) -> None:
        """To every stream (``live=None``), the live ones only (True) or the file only (False)."""
        for s in self.streams:
            if live is None or live == (s is not self.file):
                s.send_columns(*args, **kwargs)

    def flush(self) -> None:
        for s in self.streams:
            s.flush()

    def close(self, keep_serving: bool) -> None:
        """Flushes and disconnects every stream (the file last but one: finalised with its footer) except, with
        ``keep_serving``, the served one.  The file goes first; a live viewer that went away is reported, not
        raised."""
        for s in sorted(self.streams, key=lambda s: s is not self.file):  # the file first: it never waits on a viewer
            if s is self.served and keep_serving:
                continue
            if s is not self.file:
                try:
                    s.flush(timeout_sec=2.0)
                except RuntimeError as err:  # gRPC could not deliver: the viewer is gone
                    warnings.warn(f"live viewer: {str(err).splitlines()[0]}", stacklevel=2)
            s.disconnect()
        self.streams = [self.served] if keep_serving and self.served is not None else []
