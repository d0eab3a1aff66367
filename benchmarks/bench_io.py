"""Read speed of ``open_log(...).frames()``: a generated 20,000-scan, 360-beam log in every format.

Each log holds /scan, /odom, /tf and /tf_static (what ``mcnkit convert`` writes); a frame is a decoded
LaserScan with its odometry interpolated at the scan stamp, i.e. the full work SLAM needs per scan.
Target: ≥ 40,000 scans/s for ROS1 .bag and ROS2 mcap.

    .venv/bin/python -m benchmarks.bench_io [--scans 20000] [--repeats 3] [--json benchmarks/results/io.json]
"""

from __future__ import annotations

import argparse
import json
import platform
import tempfile
import time
from pathlib import Path

import numpy as np

from mcnkit.io import LogContent, open_log, write_log
from mcnkit.types import Frame, LidarSpec, Pose2D, Scan

TARGET_SCANS_PER_S = 40_000
FORMATS = {"ros1": "log.bag", "ros2-sqlite3": "sqlite3", "ros2-mcap": "ros2mcap", "mcap": "log.mcap",
           "mcap-ros1": "log_ros1.mcap"}


def generated_frames(n_scans: int, n_beams: int, seed: int = 0) -> list[Frame]:
    """A robot driving a 20 m circle at 10 Hz, with ranges that look like a room (some no-returns)."""
    rng = np.random.default_rng(seed)
    spec = LidarSpec(-np.pi, 2 * np.pi / n_beams, n_beams, 0.1, 30.0)
    t = np.arange(n_scans) * 0.1
    frames = []
    for i in range(n_scans):
        ranges = (3.0 + 2.0 * np.abs(np.sin(spec.angles_rad * 2 + 0.01 * i)) + rng.normal(0, 0.01, n_beams))
        ranges = ranges.astype(np.float32)
        ranges[rng.random(n_beams) < 0.05] = np.inf
        a = 0.05 * t[i]
        frames.append(Frame(int(1_700_000_000_000_000_000 + i * 100_000_000), Scan(ranges, spec),
                            Pose2D(10 * np.cos(a), 10 * np.sin(a), a + np.pi / 2)))
    return frames


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scans", type=int, default=20_000, help="scans in each generated log (default 20000)")
    ap.add_argument("--beams", type=int, default=360, help="beams per scan (default 360)")
    ap.add_argument("--repeats", type=int, default=3, help="best of N reads")
    ap.add_argument("--json", type=Path, default=Path("benchmarks/results/io.json"),
                    help="JSON report (default benchmarks/results/io.json)")
    args = ap.parse_args()
    frames = generated_frames(args.scans, args.beams)
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for fmt, name in FORMATS.items():
            path = Path(tmp) / name
            t0 = time.perf_counter()
            write_log(path, LogContent(frames), fmt)
            write_s = time.perf_counter() - t0
            size = sum(f.stat().st_size for f in path.rglob("*")) if path.is_dir() else path.stat().st_size
            best = float("inf")
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                with open_log(path) as log:
                    n = sum(1 for _ in log.frames())
                best = min(best, time.perf_counter() - t0)
            assert n == args.scans, f"{fmt}: read {n} of {args.scans} frames"
            rate = n / best
            target = TARGET_SCANS_PER_S if fmt in ("ros1", "ros2-mcap") else None
            results[fmt] = {"scans": n, "read_s": round(best, 3), "scans_per_s": round(rate),
                            "write_s": round(write_s, 2), "size_mb": round(size / 1e6, 1), "target": target,
                            "meets_target": None if target is None else rate >= target}
            flag = "" if target is None else ("  (target ≥ 40,000: met)" if rate >= target else "  (target ≥ 40,000: MISSED)")
            print(f"{fmt:13s} {rate:>9,.0f} scans/s  read {best:.3f} s  write {write_s:.1f} s  "
                  f"{size / 1e6:.1f} MB{flag}")
    args.json.parent.mkdir(parents=True, exist_ok=True)
    args.json.write_text(json.dumps({"benchmark": "bench_io", "scans": args.scans, "beams": args.beams,
                                     "machine": platform.platform(), "results": results}, indent=2))
    print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
