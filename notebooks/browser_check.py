"""Open a notebook in JupyterLab in headless Chromium, run it, and save a screenshot.

Everything stays on this machine: JupyterLab binds 127.0.0.1, Chromium resolves no other host, and the
Rerun viewer's assets are served by the kernel (``RERUN_NOTEBOOK_ASSET=serve-local``).  Needs Debian's
``chromium`` (``apt-get install chromium``).  Run from the project root:

    .venv/bin/python notebooks/browser_check.py notebooks/03_fastslam_step_by_step.ipynb out.png [--wait 150]

Exit code 0 when the screenshot was saved and the notebook reported no error.
"""

from __future__ import annotations

import argparse
import base64
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request
from pathlib import Path

import websocket

CHROMIUM_FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE 127.0.0.1, EXCLUDE localhost",
]


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait_http(url: str, seconds: float) -> None:
    end = time.time() + seconds
    while time.time() < end:
        try:
            urllib.request.urlopen(url, timeout=2).read()
            return
        except OSError:
            time.sleep(0.5)
    raise TimeoutError(f"{url} did not answer within {seconds:.0f} s")


class _Page:
    """The smallest Chrome DevTools Protocol client: evaluate JavaScript, take screenshots."""

    def __init__(self, debug_port: int) -> None:
        _wait_http(f"http://127.0.0.1:{debug_port}/json/version", 30)
        targets = json.load(urllib.request.urlopen(f"http://127.0.0.1:{debug_port}/json", timeout=5))
        page = next(t for t in targets if t["type"] == "page")
        self.ws = websocket.create_connection(page["webSocketDebuggerUrl"], timeout=60)
        self.n = 0

    def call(self, method: str, **params: object) -> dict:  # type: ignore[type-arg]
        self.n += 1
        self.ws.send(json.dumps({"id": self.n, "method": method, "params": params}))
        while True:
            msg = json.loads(self.ws.recv())
            if msg.get("id") == self.n:
                return msg.get("result", {})  # type: ignore[no-any-return]

    def js(self, expression: str) -> object:
        r = self.call("Runtime.evaluate", expression=expression, awaitPromise=True, returnByValue=True)
        return r.get("result", {}).get("value")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("notebook", type=Path)
    ap.add_argument("png", type=Path)
    ap.add_argument("--wait", type=float, default=150.0, help="seconds to let the notebook run and the viewer draw")
    ap.add_argument("--size", default="1600,1400")
    args = ap.parse_args()
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    if chromium is None:
        print("browser_check: chromium not found (apt-get install chromium)", file=sys.stderr)
        return 2
    # JupyterLab saves what it runs: work on a copy, so the repository's notebooks stay without outputs.
    work = Path(tempfile.mkdtemp(prefix="mcnkit-browser-"))
    root = work / "project"
    (root / "notebooks").mkdir(parents=True)
    (root / "recordings").mkdir()
    shutil.copy(args.notebook, root / "notebooks" / args.notebook.name)
    nb_rel = Path("notebooks") / args.notebook.name
    lab_port, debug_port = _free_port(), _free_port()
    env = dict(os.environ, RERUN_NOTEBOOK_ASSET="serve-local", RERUN_ANALYTICS="0")
    env.pop("MCNKIT_CI", None)
    lab = subprocess.Popen(
        [sys.executable, "-m", "jupyterlab", "--no-browser", "--ip=127.0.0.1", f"--port={lab_port}",
         "--IdentityProvider.token=", "--ServerApp.password=", "--ServerApp.disable_check_xsrf=True",
         "--LabApp.expose_app_in_browser=True", "--allow-root", f"--ServerApp.root_dir={root}"],
        stdout=open(work / "lab.log", "w"), stderr=subprocess.STDOUT, env=env,
    )
    browser = None
    try:
        _wait_http(f"http://127.0.0.1:{lab_port}/api", 60)
        url = f"http://127.0.0.1:{lab_port}/lab/tree/{nb_rel}"
        browser = subprocess.Popen(
            [chromium, *CHROMIUM_FLAGS, f"--remote-debugging-port={debug_port}", f"--user-data-dir={work / 'chrome'}",
             f"--window-size={args.size}", url],
            stdout=open(work / "chromium.log", "w"), stderr=subprocess.STDOUT,
        )
        page = _Page(debug_port)
        for _ in range(120):  # wait until JupyterLab has opened the notebook and its kernel is idle
            ready = page.js("(() => { const a = window.jupyterapp; const w = a && a.shell.currentWidget;"
                            " return !!(w && w.sessionContext && w.sessionContext.session"
                            " && w.sessionContext.session.kernel && w.sessionContext.isReady); })()")
            if ready:
                break
            time.sleep(1)
        else:
            raise TimeoutError("JupyterLab did not open the notebook with a running kernel")
        page.js("window.jupyterapp.commands.execute('notebook:run-all-cells')")
        time.sleep(args.wait)
        errors = page.js("document.querySelectorAll('.jp-OutputArea-output[data-mime-type=\"application/vnd.jupyter.stderr\"]').length")
        tracebacks = page.js("Array.from(document.querySelectorAll('.jp-RenderedText')).filter(e => e.innerText.includes('Traceback')).length")
        page.js("(() => { const c = document.querySelector('.jp-OutputArea canvas');"
                " if (c) c.scrollIntoView({block: 'start'}); })()")  # the viewer, and the widgets below it
        time.sleep(5)
        shot = page.call("Page.captureScreenshot", format="png", captureBeyondViewport=False)
        args.png.parent.mkdir(parents=True, exist_ok=True)
        args.png.write_bytes(base64.b64decode(str(shot["data"])))
        print(f"saved {args.png}; stderr outputs: {errors}, tracebacks: {tracebacks}; logs in {work}")
        return 0 if not tracebacks else 1
    finally:
        if browser is not None:
            browser.terminate()
        lab.terminate()
        try:
            lab.wait(10)
        except subprocess.TimeoutExpired:
            lab.kill()


if __name__ == "__main__":
    sys.exit(main())
