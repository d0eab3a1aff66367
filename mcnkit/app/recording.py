"""Where a run's Rerun recording goes and how (no rerun import here: the command line builds its flags from it).

A run records to any of: a file (``--rrd FILE``), a viewer that is already running (``--connect [URL]``: Rerun's
gRPC address, default ``rerun+http://127.0.0.1:9876/proxy``, which a plain ``rerun`` listens on) and a gRPC server
the run hosts itself on 127.0.0.1 (``--serve``: viewers connect to it, late ones get everything logged so far;
``--recording.web-viewer`` also serves Rerun's web viewer there).  :class:`RecordingConfig` holds the settings
(``--recording.FIELD`` flags, the ``[recording]`` table of a ``--config`` file, written into ``summary.json``);
:class:`LiveViewer` is where the live stream goes (:mod:`mcnkit.viz` opens it).

    p = argparse.ArgumentParser()
    add_options(p, LiveOptions, const=LIVE_CONST)   # --connect [URL], --serve, --recording.grpc-port, ...
    args = p.parse_args(["--serve", "--recording.grpc-port", "0"])
    live = live_viewer(args, RecordingConfig(grpc_port=0))   # LiveViewer(serve_port=<a free port>, ...)
"""

from __future__ import annotations

import argparse
import re
import socket
from dataclasses import dataclass, field
from urllib.parse import quote

__all__ = ["DEFAULT_VIEWER_URL", "LIVE_CONST", "LiveOptions", "LiveViewer", "RecordingConfig", "ViewerError",
           "check_viewer", "free_port", "live_viewer", "viewer_url"]

DEFAULT_VIEWER_URL = "rerun+http://127.0.0.1:9876/proxy"
"""Where a viewer started with a plain ``rerun`` listens (Rerun 0.41's default gRPC address)."""


class ViewerError(ValueError):
    """A live viewer that cannot be reached or served; ``str()`` is one line naming the address."""


@dataclass(frozen=True)
class RecordingConfig:
    """How a run is recorded for Rerun (where to: ``--rrd``, ``--connect``, ``--serve``)."""

    map_every: int = 10
    """mcnkit slam: record the best particle's map every N filter updates (mcnkit run: mcn.full_map_every)."""
    flush_updates: int = 50
    """Send the queued rows to the file every N filter updates (to a live viewer: at every filter update)."""
    grpc_port: int = 9876
    """Port of the gRPC server --serve starts on 127.0.0.1 (0: any free port)."""
    web_viewer: bool = False
    """With --serve, also serve Rerun's web viewer on 127.0.0.1 and print the address to open in a browser."""
    web_port: int = 9090
    """Port of that web viewer (0: any free port)."""
    server_memory_limit: str = "1GiB"
    """How much of the recording the --serve server keeps for viewers that connect late (e.g. 1GiB, 25%)."""
    linger_s: float = -1.0
    """With --serve, keep serving this many seconds after the run ends (-1: until Ctrl-C)."""

    def __post_init__(self) -> None:
        if self.map_every < 0 or self.flush_updates < 1:
            raise ValueError(f"map_every must be >= 0 and flush_updates >= 1, got {self.map_every}, "
                             f"{self.flush_updates}")
        for name in ("grpc_port", "web_port"):
            if not 0 <= getattr(self, name) <= 65535:
                raise ValueError(f"{name} must be a port number (0: any free port), got {getattr(self, name)}")


@dataclass(frozen=True)
class LiveViewer:
    """Where a run streams live: a running viewer's address and/or a server of its own on 127.0.0.1."""

    connect: str | None = None
    """gRPC address of a running viewer (``rerun+http://HOST:PORT/proxy``), or None."""
    serve_port: int | None = None
    """Port of the gRPC server to host on 127.0.0.1, or None."""
    web_port: int | None = None
    """Port of the web viewer to serve on 127.0.0.1 (with ``serve_port``), or None."""
    server_memory_limit: str = "1GiB"
    """Kept by the server for viewers that connect late."""

    @property
    def serve_url(self) -> str | None:
        """The gRPC address of the hosted server (for ``rerun --connect URL``), None when not serving."""
        return None if self.serve_port is None else f"rerun+http://127.0.0.1:{self.serve_port}/proxy"

    @property
    def web_url(self) -> str | None:
        """The address to open in a browser, None without a web viewer."""
        if self.web_port is None or self.serve_url is None:
            return None
        return f"http://127.0.0.1:{self.web_port}/?url={quote(self.serve_url, safe='')}"


_URL = re.compile(r"rerun(\+https?)?://(?P<host>\[[^\]]+\]|[^/:]+):(?P<port>\d+)/proxy")


def viewer_url(text: str | None) -> str:
    """A viewer's gRPC address from ``--connect``'s value: nothing (the default), a port, ``HOST:PORT`` or a full
    ``rerun+http://HOST:PORT/proxy`` address; raises :class:`ViewerError` for anything else."""
    if text is None or not text.strip():
        return DEFAULT_VIEWER_URL
    text = text.strip()
    if text.isdigit():
        return f"rerun+http://127.0.0.1:{int(text)}/proxy"
    if re.fullmatch(r"[^/:]+:\d+", text):
        return f"rerun+http://{text}/proxy"
    if not _URL.fullmatch(text):
        raise ViewerError(f"{text}: not a viewer address (a port, HOST:PORT or rerun+http://HOST:PORT/proxy)")
    return text


def check_viewer(url: str, timeout_s: float = 1.0) -> None:
    """Raises :class:`ViewerError` unless something accepts connections at ``url`` (a viewer that is not there
    would make every logging call wait for it)."""
    m = _URL.fullmatch(url)
    if m is None:
        raise ViewerError(f"{url}: not a viewer address")
    try:
        with socket.create_connection((m["host"].strip("[]"), int(m["port"])), timeout=timeout_s):
            pass
    except OSError as err:
        raise ViewerError(f"{url}: no Rerun viewer is listening there ({err.strerror or err}); start one with "
                          "'rerun', or use --serve") from err


def free_port() -> int:
    """A TCP port on 127.0.0.1 that is free now."""
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _claim(port: int, what: str) -> int:
    """``port`` (0: a free one), after checking that it can be bound on 127.0.0.1."""
    if port == 0:
        return free_port()
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError as err:
            raise ViewerError(f"127.0.0.1:{port}: cannot serve the {what} there ({err.strerror}); choose another "
                              "port (0: any free one)") from err
    return port


def live_viewer(args: argparse.Namespace, config: RecordingConfig) -> LiveViewer | None:
    """Where ``--connect`` / ``--serve`` stream (None: neither given); a viewer to connect to must be running,
    ports to serve on must be free (:class:`ViewerError` otherwise)."""
    connect = getattr(args, "connect", None)
    serve = bool(getattr(args, "serve", False))
    if connect is None and not serve:
        return None
    url = None
    if connect is not None:
        url = viewer_url(connect)
        check_viewer(url)
    serve_port = _claim(config.grpc_port, "gRPC server") if serve else None
    web_port = _claim(config.web_port, "web viewer") if serve and config.web_viewer else None
    return LiveViewer(url, serve_port, web_port, config.server_memory_limit)


@dataclass(frozen=True, kw_only=True)
class LiveOptions:
    """The options of a command that records a run: where it streams live (``--connect``, ``--serve``) and its
    ``--recording.FIELD`` settings (:mod:`mcnkit.app.options` makes the flags)."""

    connect: str | None = None
    """stream every step live to a running Rerun viewer (start one with 'rerun'); URL: its gRPC address, a port or
    HOST:PORT (default rerun+http://127.0.0.1:9876/proxy)"""
    serve: bool = False
    """serve the recording live from a gRPC server on 127.0.0.1 (port --recording.grpc-port) and print the address
    to open it with ('rerun --connect URL'; a browser with --recording.web-viewer); keeps serving after the run
    until Ctrl-C (--recording.linger-s)"""
    recording: RecordingConfig = field(default_factory=RecordingConfig)
    """How the run is recorded."""


LIVE_CONST = {"connect": ""}
"""``--connect`` given without a URL: the default viewer (:func:`viewer_url`)."""
