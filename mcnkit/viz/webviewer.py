"""Rerun's web viewer as a subprocess bound to 127.0.0.1."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

__all__ = ["serve_web_viewer"]


def serve_web_viewer(port: int, grpc_url: str) -> subprocess.Popen[bytes]:
    """Rerun's web viewer on 127.0.0.1:``port``, connecting to ``grpc_url`` (the rerun binary itself, not the
    Python shim, so that ending this process ends the server; ``rr.serve_web_viewer`` binds every interface)."""
    import rerun_cli

    binary = Path(rerun_cli.__file__).parent / "rerun"
    return subprocess.Popen([str(binary), "--serve-web", "--bind", "127.0.0.1", "--web-viewer-port", str(port),
                             grpc_url], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env={**os.environ, "RERUN_ANALYTICS": "0"})
