"""Benchmark of MCN-SLAM (issue 6): its CPU cost against SLAM alone, and the cost of recording it to Rerun.

Each run is a subprocess of its own (``--child``), timed by its own CPU clock around the filter loop (the log is
read into memory first; loading the network counts):

* **MIT CSAIL**, 30 particles, K = 4 completions of the R best particles' maps at every filter update, against
  grid FastSLAM alone on the same log and seed (target: total CPU ≤ 1.5× SLAM alone);
* **recording overhead**: the same MCN-SLAM loop with and without ``--rrd`` (every step recorded; the best
  full-resolution map every 5 completions, as ``mcnkit run`` does), on the demo apartment and on MIT CSAIL
  (target: ≤ 10 % of the step time).  CPU of every thread counts (Rerun encodes and writes in the background).

Writes ``benchmarks/results/mcn.json``.

    .venv/bin/python benchmarks/bench_mcn.py [--ranks 1 3] [--repeats 2] [--data ../shared/data]
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT.parent / "shared" / "data"


def _child(mode: str, log: str, ranks: int, rrd: str) -> None:
    """Runs one loop in this process and prints its CPU seconds as JSON (the subprocess side)."""
    import numpy as np
    import torch

    from mcnkit.io import open_log

    torch.set_num_threads(1)
    with open_log(log) as reader:
        frames = list(reader.frames())
    from mcnkit.slam import FastSlam, SlamConfig

    config = SlamConfig(n_particles=30)
    cpu0 = time.process_time()
    extra: dict[str, float] = {}
    if mode == "slam":
        slam = FastSlam(config, np.random.default_rng(0))
        for frame in frames:
            slam.step(frame)
        updates = slam.n_updates
    else:
        from mcnkit.mcn import McnConfig, McnSlam, load_model
        from mcnkit.run import run_mcn

        mcn = McnSlam(config, load_model("unet"), McnConfig(samples=4, ranks=ranks,
                                                               full_map_every=5 if mode == "mcn-rrd" else 0),
                      np.random.default_rng(0), generator=torch.Generator().manual_seed(0))
        summary = run_mcn(frames, mcn, rrd=Path(rrd) if mode == "mcn-rrd" else None, progress=False)
        updates = mcn.slam.n_updates
        extra = {"completions": summary.completions, "cpu_s_in_recorder_calls": summary.cpu_s_recording}
        if mode == "mcn-rrd":
            extra["rrd_mb"] = Path(rrd).stat().st_size / 1e6
    print(json.dumps({"cpu_s": time.process_time() - cpu0, "scans": len(frames), "updates": updates, **extra}))


def _run(mode: str, log: Path, ranks: int, rrd: Path) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", mode, str(log), str(ranks), str(rrd)],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def _demo_log(work: Path) -> Path:
    from mcnkit.sim import SimConfig, plan_raster, simulate, write_sim_log

    sim = simulate(plan_raster("procedural:3", 0.05, None), SimConfig(max_duration_s=120.0), 0)
    return write_sim_log(sim, work / "apartment.mcap", "mcap", overwrite=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--child", nargs=4, metavar=("MODE", "LOG", "RANKS", "RRD"), help=argparse.SUPPRESS)
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 3], help="R values for the MIT run")
    parser.add_argument("--repeats", type=int, default=2, help="runs per configuration (the minimum is kept)")
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--results", type=Path, default=ROOT / "benchmarks" / "results")
    a = parser.parse_args()
    if a.child:
        _child(a.child[0], a.child[1], int(a.child[2]), a.child[3])
        return 0
    mit = a.data / "reallab" / "mit-csail" / "mit-csail.clf"
    report: dict = {"mit_csail": {}, "recording": {}}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        demo = _demo_log(work)

        def best(mode: str, log: Path, ranks: int) -> dict:
            runs = [_run(mode, log, ranks, work / "run.rrd") for _ in range(a.repeats)]
            return min(runs, key=lambda r: r["cpu_s"])

        slam = best("slam", mit, 0)
        report["mit_csail"]["slam_alone"] = slam
        print(f"MIT CSAIL, 30 particles: SLAM alone {slam['cpu_s']:.1f} s CPU ({slam['updates']} filter updates)")
        for r in a.ranks:
            mcn = best("mcn", mit, r)
            ratio = mcn["cpu_s"] / slam["cpu_s"]
            report["mit_csail"][f"mcn_R{r}_K4"] = {**mcn, "ratio_to_slam": ratio}
            print(f"  MCN-SLAM R={r} K=4 at every update: {mcn['cpu_s']:.1f} s CPU = {ratio:.2f}x SLAM alone "
                  f"({mcn['completions']} completions; target <= 1.5x: {'met' if ratio <= 1.5 else 'MISSED'})")
        for name, log, r in (("demo_apartment", demo, 2), ("mit_csail", mit, 3)):
            plain, rec = best("mcn", log, r), best("mcn-rrd", log, r)
            overhead = rec["cpu_s"] / plain["cpu_s"] - 1.0
            report["recording"][name] = {"ranks": r, "without": plain, "with_rrd": rec, "overhead": overhead}
            print(f"recording, {name} (R={r}, K=4): {plain['cpu_s']:.2f} s -> {rec['cpu_s']:.2f} s CPU with --rrd "
                  f"= +{100 * overhead:.1f} % ({rec['rrd_mb']:.1f} MB; target <= 10 %: "
                  f"{'met' if overhead <= 0.10 else 'MISSED'})")
    a.results.mkdir(parents=True, exist_ok=True)
    (a.results / "mcn.json").write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {a.results / 'mcn.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
