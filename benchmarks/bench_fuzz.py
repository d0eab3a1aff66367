"""Damaged data: seeded byte-flip mutants of a ROS1 bag, an MCAP, rosbag2 bags (sqlite3 and mcap storage, plain and
compressed by rosbag2 itself, by file and by message) and a CARMEN log.

The source logs are the first ``--scans`` scans of the Intel lab log (CARMEN text, kept as is), converted with
``write_log`` (what ``mcnkit convert`` runs) to the other formats.  Each mutant flips 1–16 bytes (XOR with a
random non-zero byte; for a rosbag2 folder, in its ``.db3``, ``.mcap`` or ``.db3.zstd`` file) and runs, in a child process of its own
(forked from a warm parent; killed after ``--timeout`` seconds; peak RSS from ``os.wait4``):

1. ``mcnkit info --json`` (through :func:`mcnkit.app.main.main`, output captured);
2. a full frame read (``open_log(...).frames()``), compared bit for bit with the clean log's frames;
3. a short SLAM run: :class:`mcnkit.slam.FastSlam` over the first ``--slam-scans`` frames, then its map.

Each mutant is classified by the worst that happened:

* ``hang`` (killed at the timeout), ``traceback`` (an exception other than the one-line ``LogError``),
  ``memory`` (peak RSS above ``--max-rss-mb``), ``impossible`` (a frame passed on with values no robot produces:
  checked here independently of the reader, see :func:`impossible`);
* ``clean error``: ``info`` or the frame read refused the log with one line (exit 2);
* ``warned``: read, with a warning saying what was skipped;
* ``unchanged``: read without a warning, frames and ``info`` identical to the clean log's;
* ``changed silently``: read without a warning, but frames or ``info`` differ (no checksum in the format to tell).

For the MCAP formats, every silently changed mutant is also checked with the ``mcap`` package's own CRC validation:
none of them may be one a CRC catches (a rosbag2 folder written by rosbags stores no CRCs; its silent changes, like
sqlite3's, are plausible values no checksum covers).

Then the hostile inputs of :mod:`benchmarks.hostile` (links to ``/dev/zero``, a FIFO, a ``.log.gz`` of one 3 GiB
line, a compression bomb, a sparse 10 GiB MCAP of zeros, a chunk claiming 3 GiB, a damaged sqlite3 bag, a CARMEN
line that lost a field) run the same way: each must be refused with one line (exit 2) or read with a warning and no
impossible step, within 10 s and 500 MB (``--no-hostile`` skips them).

    .venv/bin/python -m benchmarks.bench_fuzz --seed 0 --mutants 200 --workers 2 --out benchmarks/results/fuzz.json
"""

from __future__ import annotations

import argparse
import contextlib
import gzip
import io
import itertools
import json
import math
import os
import platform
import random
import resource
import shutil
import signal
import sys
import tempfile
import time
import traceback
import warnings
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from benchmarks import hostile
from benchmarks.common import ROOT, data_dir, save_report
from mcnkit.io import LogContent, LogError, open_log, write_log
from mcnkit.types import Frame

INTEL = Path("reallab", "intel", "intel-corrected.log.gz")
"""The source of every mutant, in the shared data folder (``--data``)."""
FORMATS = {"ros1": "log.bag", "mcap": "log.mcap", "ros2-sqlite3": "log_sqlite3", "carmen": "log.log",
           "ros2-mcap": "log_mcap", "mcap-ros1": "log_ros1.mcap", "ros2-sqlite3-file": "log_sqlite3_zstd",
           "ros2-mcap-message": "log_mcap_msgzstd"}
"""Every format the readers take; the four the readers were built for come first (``--formats`` picks)."""
COMPRESSED = {"ros2-sqlite3-file": ("ros2-sqlite3", "file"), "ros2-mcap-message": ("ros2-mcap", "message")}
"""The rosbag2 folders that rosbag2 compressed itself: format name -> (write_log's format, its compression)."""
MCAP_FORMATS = ("mcap", "ros2-mcap", "mcap-ros1", "ros2-mcap-message")
"""Formats whose data file is an MCAP: every silently changed mutant of these is checked against the CRCs."""
CLASSES = ["clean error", "warned", "unchanged", "changed silently", "impossible", "traceback", "hang", "memory"]

# What a robot can do, stated here independently of the reader's own rules (mcnkit.io.plausible): a scanner reaches
# 0 to 1 km (any reading outside its interval, or not finite, is "no return", ROS REP 117); odometry is finite and
# moves at most 10 m/s and a full turn per second between two scans, plus 2 m / 1 rad for coarse stamps; stamps do
# not go backwards.
SPEED_M_S, TURN_RAD_S, SLACK_M, SLACK_RAD = 10.0, 2 * math.pi, 2.0, 1.0


def impossible(frames: list[Frame]) -> str | None:
    """The first value in ``frames`` that no robot and scanner produce (None: all possible)."""
    prev: Frame | None = None
    for f in frames:
        spec = f.scan.spec
        if not (0 < spec.n_beams <= 100_000 and math.isfinite(spec.angle_increment_rad)
                and abs(spec.angle_increment_rad) * (spec.n_beams - 1) <= 2 * math.pi + 1e-6
                and 0 <= spec.range_min_m < spec.range_max_m <= 1000.0):
            return f"scanner {spec}"
        o = f.odom
        if not all(math.isfinite(v) and abs(v) <= 1e7 for v in (o.x_m, o.y_m, o.yaw_rad)):
            return f"odometry {o}"
        if f.stamp_ns < 0:
            return f"stamp {f.stamp_ns}"
        if prev is not None:
            dt = (f.stamp_ns - prev.stamp_ns) / 1e9
            if dt < 0:
                return f"stamp went back {dt} s"
            step = math.hypot(o.x_m - prev.odom.x_m, o.y_m - prev.odom.y_m)
            if step > SPEED_M_S * dt + SLACK_M:
                return f"odometry step {step:.3g} m in {dt:.3g} s"
            turn = abs((o.yaw_rad - prev.odom.yaw_rad + math.pi) % (2 * math.pi) - math.pi)
            if turn > TURN_RAD_S * dt + SLACK_RAD:
                return f"turn {turn:.3g} rad in {dt:.3g} s"
        prev = f
    return None


def carmen_slice(source: Path, n_scans: int, out: Path) -> Path:
    """The first ``n_scans`` FLASER scans of a CARMEN log (the Intel log's, with the ODOM / NEFF lines among them)."""
    lines, scans = [], 0
    with gzip.open(source, "rt", encoding="ascii") as f:
        for line in f:
            if line.startswith("FLASER"):
                if scans == n_scans:
                    break
                scans += 1
            lines.append(line)
    out.write_text("".join(lines))
    return out


def data_file(path: Path) -> Path:
    """The file the bytes are flipped in: the log itself, or a rosbag2 folder's .db3 / .mcap (or .db3.zstd)."""
    return next(p for p in sorted(path.iterdir()) if p.name.endswith((".db3", ".mcap", ".zstd"))) if path.is_dir() \
        else path


def frame_key(frames: list[Frame]) -> list[tuple[int, bytes, tuple[float, float, float]]]:
    return [(f.stamp_ns, f.scan.ranges_m.tobytes(), (f.odom.x_m, f.odom.y_m, f.odom.yaw_rad)) for f in frames]


def run_info(path: Path) -> tuple[int, dict[str, Any] | None, str]:
    """``mcnkit info --json PATH`` in this process: exit code, parsed output, stderr."""
    from mcnkit.app.main import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(["info", "--json", str(path)])
    info = json.loads(out.getvalue()) if code == 0 else None
    if info is not None:
        info.pop("path", None)
    return code, info, _plain(err.getvalue(), path)


def _plain(text: str, path: Path) -> str:
    """A message without the folder of the file it names (clean and damaged logs sit in different folders)."""
    return text.replace(str(path.parent), "DIR")


def read_frames(path: Path) -> tuple[list[Frame] | None, list[str], str | None]:
    """Frames (None: refused), the warnings (deduplicated, folder-free), and the one-line error."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            with open_log(path) as log:
                frames = list(log.frames())
        except LogError as err:
            return None, sorted({_plain(str(w.message), path) for w in caught}), str(err)
    return frames, sorted({_plain(str(w.message), path) for w in caught}), None


def short_slam(frames: list[Frame], n: int) -> None:
    from mcnkit.app.drive import drive
    from mcnkit.slam import FastSlam, SlamConfig

    slam = FastSlam(SlamConfig(n_particles=5), np.random.default_rng(0))
    drive(frames[:n], slam)
    if slam.n_scans:
        slam.best_ternary()


def examine(path: Path, clean: tuple[Any, Any, list[str]], slam_scans: int) -> dict[str, Any]:
    """Everything a user would run on one mutant; the classification is done by the parent.  ``clean``: the clean
    log's ``info``, frames and warnings (a warning the clean log gives too says nothing about the damage)."""
    clean_info, clean_frames, clean_warnings = clean
    res: dict[str, Any] = {}
    try:
        code, info, err = run_info(path)
        res["info_exit"] = code
        res["info_error"] = err.strip().splitlines()[-1] if code else None
        res["info_warned"] = any(line.startswith("warning:") and line[len("warning: "):] not in clean_warnings
                                 for line in err.splitlines())
        res["info_changed"] = info is not None and info != clean_info
        frames, warned, error = read_frames(path)
        res["warnings"] = [w for w in warned if w not in clean_warnings]
        res["error"] = error
        if frames is not None:
            res["frames"] = len(frames)
            res["changed"] = frame_key(frames) != clean_frames
            res["impossible"] = impossible(frames)
            short_slam(frames, slam_scans)
    except BaseException:  # noqa: BLE001 - what the benchmark looks for
        res["traceback"] = traceback.format_exc()[-2000:]
    return res


def mcap_crc_flags(path: Path) -> bool:
    """Whether the ``mcap`` package's own CRC validation (chunk and data-section CRCs) rejects the file: damage a
    checksum could have caught.  Other failures of that reader do not count (a file whose writer stored no CRCs —
    rosbags' MCAP storage writes 0 — has nothing to catch damage with)."""
    from mcap.reader import NonSeekingReader
    from mcap.stream_reader import CRCValidationError

    try:
        with open(path, "rb") as f:
            for _ in NonSeekingReader(f, validate_crcs=True).iter_records():
                pass
    except CRCValidationError:
        return True
    except Exception:  # noqa: BLE001 - damage elsewhere (framing, lengths): not a CRC's catch
        return False
    return False


def classify(res: dict[str, Any], max_rss_mb: float) -> str:
    if res.get("hang"):
        return "hang"
    if "traceback" in res or res.get("exit_code", 0) != 0:
        return "traceback"
    if res.get("peak_rss_mb", 0) > max_rss_mb:
        return "memory"
    if res.get("impossible"):
        return "impossible"
    if res.get("info_exit") not in (0, 2):
        return "traceback"
    if res.get("info_exit") == 2 or res.get("error"):
        return "clean error"
    if res.get("warnings") or res.get("info_warned"):
        return "warned"
    if res.get("changed") or res.get("info_changed"):
        return "changed silently"
    return "unchanged"


def mutate(clean: Path, work: Path, rng: random.Random) -> tuple[Path, list[int]]:
    raw = bytearray(data_file(clean).read_bytes())
    where = [rng.randrange(len(raw)) for _ in range(rng.randint(1, 16))]
    for i in where:
        raw[i] ^= rng.randint(1, 255)
    target = work / clean.name
    if clean.is_dir():
        shutil.copytree(clean, target)
        data_file(target).write_bytes(bytes(raw))
    else:
        target.write_bytes(bytes(raw))
    return target, where


def run_mutants(args: argparse.Namespace) -> dict[str, Any]:
    root = Path(tempfile.mkdtemp(prefix="mcnkit-fuzz-"))
    try:
        return _run(args, root)
    finally:
        shutil.rmtree(root, ignore_errors=True)


def _run(args: argparse.Namespace, root: Path) -> dict[str, Any]:
    (root / "clean").mkdir()
    src = carmen_slice(data_dir(args.data) / INTEL, args.scans, root / "clean" / FORMATS["carmen"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with open_log(src) as log:
            content = LogContent(list(log.frames()), ground_truth=log.ground_truth())
    clean = {"carmen": src} if "carmen" in args.formats else {}
    for fmt in [f for f in args.formats if f != "carmen"]:
        base, compression = COMPRESSED.get(fmt, (fmt, None))
        clean[fmt] = write_log(root / "clean" / FORMATS[fmt], content, base, mcap_chunk_bytes=args.mcap_chunk_kib << 10,
                               compression=compression)
    reference = {}
    for fmt, path in clean.items():
        code, info, _ = run_info(path)
        frames, warned, error = read_frames(path)
        assert code == 0 and frames is not None and not error, f"the clean {fmt} log does not read: {error}"
        short_slam(frames, args.slam_scans)  # warm: compiled code is cached before the children fork
        reference[fmt] = (info, frame_key(frames), warned)
    rng = random.Random(args.seed)
    jobs = []
    for fmt in args.formats:
        for k in range(args.mutants):
            jobs.append((fmt, k, random.Random(rng.getrandbits(64))))
    results: dict[str, list[dict[str, Any]]] = {fmt: [] for fmt in args.formats}
    running: dict[int, tuple[str, int, Path, float, list[int]]] = {}
    queue = list(jobs)
    t0 = time.perf_counter()
    while queue or running:
        while queue and len(running) < args.workers:
            fmt, k, mrng = queue.pop(0)
            work = root / f"{fmt}-{k}"
            work.mkdir()
            target, where = mutate(clean[fmt], work, mrng)
            out = work / "result.json"
            pid = os.fork()
            if pid == 0:  # child
                code = 0
                try:
                    resource.setrlimit(resource.RLIMIT_AS, (args.max_as_gb << 30, args.max_as_gb << 30))
                    res = examine(target, reference[fmt], args.slam_scans)
                    out.write_text(json.dumps(res))
                except BaseException:  # noqa: BLE001
                    code = 1
                os._exit(code)
            running[pid] = (fmt, k, out, time.perf_counter(), where)
        pid, status, usage = os.wait4(-1, os.WNOHANG)
        if pid == 0:
            time.sleep(0.02)
            for cpid, job in list(running.items()):
                if time.perf_counter() - job[3] > args.timeout:
                    os.kill(cpid, signal.SIGKILL)
            continue
        fmt, k, out, started, where = running.pop(pid)
        res = json.loads(out.read_text()) if out.exists() else {}
        killed = os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
        res.update(mutant=k, flipped=len(where), seconds=round(time.perf_counter() - started, 2),
                   peak_rss_mb=round(usage.ru_maxrss / 1024, 1), hang=killed,
                   exit_code=0 if killed else (os.WEXITSTATUS(status) if os.WIFEXITED(status) else -1))
        res["class"] = classify(res, args.max_rss_mb)
        if fmt in MCAP_FORMATS and res["class"] == "changed silently":
            res["mcap_crc_flags"] = mcap_crc_flags(data_file(out.parent / clean[fmt].name))
        shutil.rmtree(out.parent, ignore_errors=True)
        results[fmt].append(res)
        done = sum(len(v) for v in results.values())
        if done % 50 == 0:
            print(f"  {done}/{len(jobs)} mutants, {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    table = {}
    for fmt, rows in results.items():
        counts = Counter(r["class"] for r in rows)
        table[fmt] = {c: counts.get(c, 0) for c in CLASSES}
        table[fmt]["peak_rss_mb"] = max(r["peak_rss_mb"] for r in rows)
        table[fmt]["max_seconds"] = max(r["seconds"] for r in rows)
        if fmt in MCAP_FORMATS:
            table[fmt]["changed_silently_crc_flagged"] = sum(bool(r.get("mcap_crc_flags")) for r in rows)
    verdict = {
        "tracebacks": sum(t["traceback"] for t in table.values()),
        "hangs": sum(t["hang"] for t in table.values()),
        "over_memory": sum(t["memory"] for t in table.values()),
        "impossible_values_passed_on": sum(t["impossible"] for t in table.values()),
        "mcap_changed_silently": sum(t.get("changed_silently_crc_flagged", 0) for t in table.values()),
        "peak_rss_mb": max(t["peak_rss_mb"] for t in table.values()),
    }
    hostile_results = run_hostile(root, content, src, args.max_as_gb) if args.hostile else {}
    verdict["hostile_failed"] = [name for name, r in hostile_results.items() if r["problem"]]
    verdict["ok"] = (verdict["tracebacks"] == verdict["hangs"] == verdict["over_memory"]
                     == verdict["impossible_values_passed_on"] == verdict["mcap_changed_silently"] == 0
                     and not verdict["hostile_failed"])
    sizes = {fmt: data_file(p).stat().st_size for fmt, p in clean.items()}
    details = {fmt: [r for r in rows if r["class"] in ("traceback", "hang", "memory", "impossible", "changed silently")]
               for fmt, rows in results.items()}
    return {
        "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]),
        "seed": args.seed, "mutants_per_format": args.mutants, "scans": args.scans, "slam_scans": args.slam_scans,
        "source_bytes": sizes, "timeout_s": args.timeout, "max_rss_mb": args.max_rss_mb,
        "machine": platform.platform(), "wall_s": round(time.perf_counter() - t0, 1),
        "table": table, "verdict": verdict, "notable": details, "hostile": hostile_results,
    }


def largest_known_step(frames: list[Frame]) -> float:
    """The longest odometry step a frame says is known motion (m)."""
    steps = [math.hypot(b.odom.x_m - a.odom.x_m, b.odom.y_m - a.odom.y_m)
             for a, b in itertools.pairwise(frames) if b.odom_known]
    return max(steps, default=0.0)


def examine_hostile(path: Path) -> dict[str, Any]:
    """``mcnkit info`` and a full frame read of a hostile file, each timed."""
    res: dict[str, Any] = {}
    try:
        t0 = time.perf_counter()
        code, _, err = run_info(path)
        res.update(info_exit=code, info_stderr=err.strip().splitlines(), info_s=round(time.perf_counter() - t0, 2))
        t0 = time.perf_counter()
        frames, warned, error = read_frames(path)
        res.update(read_s=round(time.perf_counter() - t0, 2), warnings=warned, error=error,
                   frames=None if frames is None else len(frames),
                   largest_known_step_m=None if frames is None else round(largest_known_step(frames), 2))
    except BaseException:  # noqa: BLE001 - what the benchmark looks for
        res["traceback"] = traceback.format_exc()[-2000:]
    return res


def hostile_ok(expect: str, res: dict[str, Any]) -> str | None:
    """Why a hostile case's outcome is wrong (None: it is as it must be; see :mod:`benchmarks.hostile`)."""
    if res.get("hang"):
        return "hang"
    if "traceback" in res or res.get("exit_code", 0) != 0:
        return "traceback"
    if res["peak_rss_mb"] > hostile.MAX_RSS_MB or max(res["info_s"], res["read_s"]) > hostile.TIME_LIMIT_S:
        return "over memory or time"
    lines = res["info_stderr"]
    if not all(line.startswith(("warning: ", "mcnkit info: ")) for line in lines):
        return "a message over several lines"
    refused = res["info_exit"] == 2 and res["error"] is not None and len(lines) >= 1
    if expect == "refuse" and not refused:
        return "not refused"
    if expect == "read" and (res["info_exit"] != 0 or res["frames"] is None or not res["warnings"]):
        return "not read with a warning"
    if res["frames"] is not None and res["largest_known_step_m"] > hostile.MAX_KNOWN_STEP_M:
        return f"a known step of {res['largest_known_step_m']} m"
    return None


def run_hostile(root: Path, content: LogContent, carmen: Path, max_as_gb: int) -> dict[str, dict[str, Any]]:
    """Every case of :mod:`benchmarks.hostile`, each in a child process of its own (killed after twice the time
    limit), classified by :func:`hostile_ok`."""
    out = {}
    for k, name in enumerate(hostile.CASES):
        folder = root / f"hostile-{k}"
        folder.mkdir()
        expect, path = hostile.write_hostile(name, folder, content, carmen)
        result = folder / "result.json"
        t0 = time.perf_counter()
        pid = os.fork()
        if pid == 0:  # child
            code = 0
            try:
                resource.setrlimit(resource.RLIMIT_AS, (max_as_gb << 30, max_as_gb << 30))
                result.write_text(json.dumps(examine_hostile(path)))
            except BaseException:  # noqa: BLE001
                code = 1
            os._exit(code)
        while True:
            done, status, usage = os.wait4(pid, os.WNOHANG)
            if done:
                break
            if time.perf_counter() - t0 > 2 * hostile.TIME_LIMIT_S:
                os.kill(pid, signal.SIGKILL)
            time.sleep(0.02)
        killed = os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
        res = json.loads(result.read_text()) if result.exists() else {}
        res.update(expect=expect, seconds=round(time.perf_counter() - t0, 2), hang=killed,
                   peak_rss_mb=round(usage.ru_maxrss / 1024, 1),
                   exit_code=0 if killed else (os.WEXITSTATUS(status) if os.WIFEXITED(status) else -1))
        res["problem"] = hostile_ok(expect, res)
        out[name] = res
        shutil.rmtree(folder, ignore_errors=True)
    return out


def markdown(report: dict[str, Any]) -> str:
    cols = CLASSES
    lines = [f"Fuzz: `{report['command']}` (seed {report['seed']}, {report['mutants_per_format']} mutants per format, "
             f"1–16 flipped bytes, source: the first {report['scans']} Intel-lab scans)", "",
             "| format | " + " | ".join(cols) + " | peak RSS MB | slowest s |",
             "|---|" + "---|" * (len(cols) + 2)]
    for fmt, row in report["table"].items():
        lines.append(f"| {fmt} | " + " | ".join(str(row[c]) for c in cols)
                     + f" | {row['peak_rss_mb']:.0f} | {row['max_seconds']:.1f} |")
    if report.get("hostile"):
        lines += ["", "| hostile input | must | info exit | stderr lines | frames | largest known step m | peak RSS MB "
                  "| s | outcome |", "|---|---|---|---|---|---|---|---|---|"]
        for name, r in report["hostile"].items():
            lines.append(f"| {name} | {r['expect']} | {r.get('info_exit')} | {len(r.get('info_stderr', []))} "
                         f"| {r.get('frames')} | {r.get('largest_known_step_m')} | {r['peak_rss_mb']:.0f} "
                         f"| {r['seconds']} | {r['problem'] or 'as it must'} |")
    v = report["verdict"]
    lines += ["", f"tracebacks {v['tracebacks']}, hangs {v['hangs']}, over {report['max_rss_mb']:.0f} MB "
              f"{v['over_memory']}, impossible values passed on {v['impossible_values_passed_on']}, silently changed "
              f"MCAP mutants a CRC flags {v['mcap_changed_silently']}, hostile inputs not as they must be "
              f"{v['hostile_failed']} (peak RSS {v['peak_rss_mb']:.0f} MB): "
              + ("PASS" if v["ok"] else "FAIL")]
    return "\n".join(lines) + "\n"


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seed", type=int, default=0, help="random seed of the mutations (default 0)")
    p.add_argument("--mutants", type=int, default=200, help="mutants per format (default 200)")
    p.add_argument("--formats", nargs="+", default=list(FORMATS), choices=list(FORMATS),
                   help="formats to mutate (default: all eight; ros2-mcap is a rosbag2 folder with MCAP storage, "
                        "ros2-sqlite3-file and ros2-mcap-message rosbag2 folders compressed by file and by message)")
    p.add_argument("--scans", type=int, default=300, help="scans in the source logs (default 300)")
    p.add_argument("--mcap-chunk-kib", type=int, default=32,
                   help="chunk size of the source MCAP, KiB (default 32: several chunks, so a flip loses one chunk, not the log)")
    p.add_argument("--slam-scans", type=int, default=40, help="frames the short SLAM run takes (default 40)")
    p.add_argument("--workers", type=int, default=2, help="mutants examined at once (default 2)")
    p.add_argument("--timeout", type=float, default=120.0, help="seconds before a mutant counts as a hang (default 120)")
    p.add_argument("--max-rss-mb", type=float, default=1024.0, help="peak RSS allowed per mutant (default 1024)")
    p.add_argument("--max-as-gb", type=int, default=16, help="address-space limit of each child, GiB (default 16)")
    p.add_argument("--no-hostile", dest="hostile", action="store_false",
                   help="skip the hostile inputs of benchmarks/hostile.py (run by default)")
    p.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "fuzz.json",
                   help="JSON report (default benchmarks/results/fuzz.json); a markdown table goes beside it (.md)")
    p.add_argument("--data", help="the shared data folder (default: $MCNKIT_SHARED_DATA, else ../shared/data)")
    args = p.parse_args()
    intel = data_dir(args.data) / INTEL
    if not intel.exists():
        print(f"bench_fuzz: {intel}: the Intel lab log is needed (shared data; --data names its folder)", file=sys.stderr)
        return 2
    os.environ.setdefault("NUMBA_NUM_THREADS", "1")
    report = run_mutants(args)
    return save_report(args.out, report, markdown(report))


if __name__ == "__main__":
    sys.exit(main())
