"""Logs of any size in bounded memory: ``info``, a full frame read and ``slam`` on large logs of every format.

For each format of :mod:`benchmarks.big_logs` (ROS1 indexed and truncated, MCAP chunked, unindexed, truncated and
whole-file zstd, rosbag2 sqlite3 and mcap, a CARMEN ``.gz``) and each size (default 0.5 and 2 GB: MIT CSAIL's scans
and odometry beside a 600 KB/message camera topic), the log is written under ``--tmp``, then each of these runs in
a child process of its own, its peak RSS taken from ``os.wait4`` and its wall time measured:

* ``info``: ``mcnkit info --json LOG``;
* ``frames``: ``open_log(LOG).frames()`` read to the end (scans/s = frames / wall time);
* ``anyreader``: rosbags' ``AnyReader`` deserialising the same LaserScans, where it reads the format (the
  reference the issue compares the scan throughput with);
* ``scans``: mcnkit decoding the same LaserScans; it runs in the same child as ``anyreader``, both timed from
  opening the log, after their imports, twice each, the best taken: the like-for-like ratio the must-show judges
  (``frames`` ÷ AnyReader is given too: a frame is more work, odometry interpolated and every rule checked);
* ``slam``: the documented ``mcnkit slam LOG --particles 30 --resolution 0.05`` (:func:`benchmarks.common.slam_command`;
  ``--particles`` changes the count: the reading is the same, the filter's own memory scales with it).

The log is deleted before the next one is written.  Must show (issue 31): peak RSS of ``info``, ``frames`` and
``slam`` within 50 MB between the sizes and at most 500 MB for every format; scans/s on the big indexed bag and
MCAP at least ``AnyReader``'s.

    nice -n 10 .venv/bin/python -m benchmarks.bench_big_logs [--sizes-mb 512 2048] [--formats ...] [--tmp /tmp]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from benchmarks.big_logs import FORMATS, mit_frames, remove, write_big
from benchmarks.common import RESULTS, SLAM_ENV, data_dir, save_report, slam_command

MAX_RSS_MB = 500.0
MAX_RSS_GROWTH_MB = 50.0
ANYREADER_FORMATS = ("ros1", "mcap", "mcap-unindexed", "ros2-sqlite3", "ros2-mcap")
"""Formats rosbags' AnyReader opens (plain ROS2-profile MCAP, bags and rosbag2 folders; not cut or compressed)."""

_FRAMES = """
import sys, time, warnings
from mcnkit.io import open_log
warnings.simplefilter("ignore")
t0 = time.perf_counter()
with open_log(sys.argv[1]) as log:
    n = sum(1 for _ in log.frames())
print(n, time.perf_counter() - t0)
"""

_SCANS = """
import json, sys, time, warnings
from pathlib import Path
warnings.simplefilter("ignore")
from mcnkit.io import open_log
from rosbags.highlevel import AnyReader
path, any_reader = Path(sys.argv[1]), sys.argv[2] == "1"

def ours():
    t0 = time.perf_counter()
    with open_log(path) as log:
        if hasattr(log, "_src"):  # a bag or MCAP: its LaserScans decoded, as AnyReader is asked to
            decoder, src = log._decoder, log._src
            n = sum(1 for conn, _, raw in src.messages([log.scan_topic]) if decoder.scan(raw, conn.encoding))
        else:
            n = sum(1 for _ in log.messages("/scan"))
    return n, time.perf_counter() - t0

def theirs():
    t0 = time.perf_counter()
    with AnyReader([path]) as r:
        conns = [c for c in r.connections if c.topic == "/scan"]
        n = sum(1 for c, _, raw in r.messages(connections=conns) if r.deserialize(raw, c.msgtype) is not None)
    return n, time.perf_counter() - t0

res = {"scans": min((ours() for _ in range(2)), key=lambda r: r[1])}
if any_reader:
    try:
        res["anyreader"] = min((theirs() for _ in range(2)), key=lambda r: r[1])
    except Exception as err:
        res["anyreader_error"] = f"{type(err).__name__}: {err}"[:200]
print(json.dumps(res))
"""


_TIME = Path("/usr/bin/time")
"""GNU time: it forks the command itself, so the command's peak RSS is its own.  (A child forked from this process
would count this process's RSS at the fork: ``ru_maxrss`` survives ``exec``.)"""


def run_child(cmd: list[str], timeout: float) -> dict[str, Any]:
    """Runs ``cmd`` (killed after ``timeout`` s); its exit code, wall time, peak RSS (MB: GNU time's ``%M`` where
    installed, else ``os.wait4``'s, which includes this process's RSS at the fork), stdout and the last line of
    stderr."""
    timed = _TIME.exists()
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err:
        t0 = time.perf_counter()
        proc = subprocess.Popen([str(_TIME), "-f", "MAXRSS_KB %M", *cmd] if timed else cmd, stdout=out, stderr=err,
                                env=SLAM_ENV, text=True, start_new_session=True)
        timer = threading.Timer(timeout, lambda: os.killpg(proc.pid, signal.SIGKILL))
        timer.start()
        try:
            _, status, usage = os.wait4(proc.pid, 0)
        finally:
            timer.cancel()
        proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here: Popen must not wait again
        wall = time.perf_counter() - t0
        out.seek(0)
        err.seek(0)
        stdout, lines = out.read(), err.read().strip().splitlines()
    rss_kb = float(usage.ru_maxrss)
    if timed and lines and lines[-1].startswith("MAXRSS_KB "):
        rss_kb = float(lines.pop().split()[1])
    return {"exit": proc.returncode, "wall_s": round(wall, 2), "peak_rss_mb": round(rss_kb / 1024, 1),
            "stdout": stdout, "stderr": lines[-1] if lines else ""}


def measure(fmt: str, path: Path, work: Path, timeout: float, particles: int) -> dict[str, Any]:
    """Every measurement of one log (see the module docstring)."""
    py = sys.executable
    out: dict[str, Any] = {"bytes": sum(f.stat().st_size for f in path.rglob("*")) if path.is_dir()
                           else path.stat().st_size}
    info = run_child([py, "-m", "mcnkit.app.main", "info", "--json", str(path)], timeout)
    out["info"] = {k: info[k] for k in ("exit", "wall_s", "peak_rss_mb", "stderr")}
    frames = run_child([py, "-c", _FRAMES, str(path)], timeout)
    n, secs = [*frames["stdout"].split(), "0", "0"][:2]
    out["frames"] = {k: frames[k] for k in ("exit", "wall_s", "peak_rss_mb", "stderr")}
    out["frames"].update(frames=int(n), read_s=round(float(secs), 2),
                         scans_per_s=round(int(n) / float(secs)) if float(secs) else None)
    scans = run_child([py, "-c", _SCANS, str(path), "1" if fmt in ANYREADER_FORMATS else "0"], timeout)
    res = json.loads(scans["stdout"]) if scans["exit"] == 0 else {}
    for key in ("scans", "anyreader"):
        if key in res:
            count, t = res[key]
            out[key] = {"scans": count, "read_s": round(t, 2), "scans_per_s": round(count / t)}
    if "anyreader_error" in res:
        out["anyreader"] = {"error": res["anyreader_error"]}
    if "scans_per_s" in out.get("anyreader", {}):
        any_rate = out["anyreader"]["scans_per_s"]
        out["frames_vs_anyreader"] = round(out["frames"]["scans_per_s"] / any_rate, 2)
        out["scans_vs_anyreader"] = round(out["scans"]["scans_per_s"] / any_rate, 2)
    slam_out = work / "slam"
    shutil.rmtree(slam_out, ignore_errors=True)
    cmd = slam_command(path, 0, slam_out)
    cmd[cmd.index("--particles") + 1] = str(particles)
    slam = run_child(cmd, timeout)
    out["slam"] = {k: slam[k] for k in ("exit", "wall_s", "peak_rss_mb", "stderr")}
    summary = slam_out / "summary.json"
    if summary.exists():
        s = json.loads(summary.read_text())
        out["slam"]["scans"] = s.get("scans")
    shutil.rmtree(slam_out, ignore_errors=True)
    return out


def verdict(results: dict[str, dict[str, Any]], sizes: list[int]) -> dict[str, Any]:
    """The must-show checks over all formats."""
    small, big = str(min(sizes)), str(max(sizes))
    worst_rss = max(r[k]["peak_rss_mb"] for by in results.values() for r in by.values()
                    for k in ("info", "frames", "slam"))
    growth = {fmt: {k: round(by[big][k]["peak_rss_mb"] - by[small][k]["peak_rss_mb"], 1)
                    for k in ("info", "frames", "slam")}
              for fmt, by in results.items() if small in by and big in by}
    failures = {fmt: by[big]["frames"]["exit"] != 0 or by[big]["slam"]["exit"] != 0 or by[big]["info"]["exit"] != 0
                for fmt, by in results.items() if big in by}
    ratios = {fmt: results[fmt][big].get("scans_vs_anyreader") for fmt in ("ros1", "mcap") if fmt in results}
    out = {"peak_rss_mb_max": worst_rss, "rss_growth_mb": growth,
           "max_growth_mb": max((abs(v) for g in growth.values() for v in g.values()), default=0.0),
           "scans_vs_anyreader_big": ratios,
           "frames_vs_anyreader_big": {fmt: results[fmt][big].get("frames_vs_anyreader") for fmt in ratios},
           "failed": [f for f, bad in failures.items() if bad]}
    out["ok"] = (worst_rss <= MAX_RSS_MB and out["max_growth_mb"] <= MAX_RSS_GROWTH_MB and not out["failed"]
                 and all(r is not None and r >= 1.0 for r in ratios.values()))
    return out


def markdown(report: dict[str, Any]) -> str:
    lines = [f"Big logs: `{report['command']}` ({report['machine']})", "",
             "| format | size | file MB | info MB / s | frames MB / s | frames scans/s | scans/s | AnyReader scans/s "
             "| scans ÷ AnyReader | frames ÷ AnyReader | slam MB / s |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for fmt, by in report["results"].items():
        for size, r in by.items():
            any_rate = r.get("anyreader", {}).get("scans_per_s", r.get("anyreader", {}).get("error", "—"))
            lines.append(
                f"| {fmt} | {size} MB | {r['bytes'] / 1e6:.0f} | {r['info']['peak_rss_mb']:.0f} / {r['info']['wall_s']} "
                f"| {r['frames']['peak_rss_mb']:.0f} / {r['frames']['wall_s']} | {r['frames'].get('scans_per_s')} "
                f"| {r.get('scans', {}).get('scans_per_s', '—')} | {any_rate} | {r.get('scans_vs_anyreader', '—')} "
                f"| {r.get('frames_vs_anyreader', '—')} "
                f"| {r['slam']['peak_rss_mb']:.0f} / {r['slam']['wall_s']} |")
    v = report["verdict"]
    lines += ["", f"peak RSS at most {v['peak_rss_mb_max']:.0f} MB (limit {MAX_RSS_MB:.0f}), largest growth from the "
              f"small to the big log {v['max_growth_mb']:.0f} MB (limit {MAX_RSS_GROWTH_MB:.0f}), throughput ÷ "
              f"AnyReader's on the big indexed logs: scans {v['scans_vs_anyreader_big']} (limit 1.0), frames "
              f"{v['frames_vs_anyreader_big']}, "
              f"failed {v['failed']}: "
              + ("PASS" if v["ok"] else "FAIL")]
    return "\n".join(lines) + "\n"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes-mb", type=int, nargs="+", default=[512, 2048], help="log sizes, MB (default 512 2048)")
    p.add_argument("--formats", nargs="+", default=list(FORMATS), choices=list(FORMATS))
    p.add_argument("--tmp", type=Path, default=Path(tempfile.gettempdir()), help="where the logs are written")
    p.add_argument("--timeout", type=float, default=1800.0, help="seconds per child process")
    p.add_argument("--particles", type=int, default=30, help="particles of the slam run (default 30, as documented)")
    p.add_argument("--data", help="the shared data folder (default: $MCNKIT_SHARED_DATA or ../shared/data)")
    p.add_argument("--out", type=Path, default=RESULTS / "big_logs.json")
    p.add_argument("--render", type=Path, help="judge and tabulate an earlier report (JSON) instead of running")
    args = p.parse_args()
    if args.render:
        report = json.loads(args.render.read_text())
        report["verdict"] = verdict(report["results"], report["sizes_mb"])
        return save_report(args.out, report, markdown(report))
    clf = data_dir(args.data) / "reallab" / "mit-csail" / "mit-csail.clf"
    frames = mit_frames(clf)
    work = Path(tempfile.mkdtemp(prefix="mcnkit-big-", dir=args.tmp))
    results: dict[str, dict[str, Any]] = {}
    t0 = time.perf_counter()
    try:
        for fmt in args.formats:
            for size in args.sizes_mb:
                path = work / FORMATS[fmt]
                w0 = time.perf_counter()
                write_big(fmt, path, size << 20, clf, frames)
                wrote = time.perf_counter() - w0
                r = measure(fmt, path, work, args.timeout, args.particles)
                r["write_s"] = round(wrote, 1)
                results.setdefault(fmt, {})[str(size)] = r
                remove(path)
                print(f"{fmt:15s} {size:5d} MB  info {r['info']['peak_rss_mb']:6.0f} MB  frames "
                      f"{r['frames']['peak_rss_mb']:6.0f} MB {r['frames'].get('scans_per_s')} scans/s  slam "
                      f"{r['slam']['peak_rss_mb']:6.0f} MB {r['slam']['wall_s']} s  AnyReader "
                      f"{r.get('anyreader', {}).get('scans_per_s', '-')}", file=sys.stderr, flush=True)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    report = {"command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]), "machine": platform.platform(),
              "sizes_mb": args.sizes_mb, "wall_s": round(time.perf_counter() - t0, 1), "results": results}
    report["verdict"] = verdict(results, args.sizes_mb)
    return save_report(args.out, report, markdown(report))


if __name__ == "__main__":
    sys.exit(main())
