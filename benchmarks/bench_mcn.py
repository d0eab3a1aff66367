"""Benchmark of MCN-SLAM (issue 6): its CPU cost against SLAM alone, and the cost of recording it to Rerun.

Each configuration runs in a subprocess of its own (``--child``), timed by its CPU clock around the filter loop (the log is
read into memory and the network loaded first):

* **MIT CSAIL**, 30 particles, K = 4 completions of the R best particles' maps at every filter update, against
  grid FastSLAM alone on the same log and seed (target: total CPU ≤ 1.5× SLAM alone);
* **recording overhead**: the same MCN-SLAM loop without and with a recording (every step recorded; the best
  map every 5 completions, as ``mcnkit run`` does), alternated ``--repeats`` times in one process after one
  warm-up run of each (so imports, JIT caches and the network's inference copy are paid once, outside the
  timing), on the demo apartment and on MIT CSAIL; the minimum of each is kept (target: ≤ 10 % of the step
  time).  CPU of every thread counts (Rerun encodes and writes in the background).  The one-time cost of
  importing rerun is reported apart (``import_rerun_cpu_s``).

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


def _child(mode: str, log: str, ranks: int, rrd: str, repeats: int = 2) -> None:
    """Runs loops in this process and prints their CPU seconds as JSON (the subprocess side)."""
    import numpy as np
    import torch

    from mcnkit.io import open_log

    torch.set_num_threads(1)
    with open_log(log) as reader:
        frames = list(reader.frames())
    from mcnkit.slam import FastSlam, SlamConfig

    config = SlamConfig(n_particles=30)
    if mode == "slam":
        cpu0 = time.process_time()
        slam = FastSlam(config, np.random.default_rng(0))
        for frame in frames:
            slam.step(frame)
        print(json.dumps({"cpu_s": time.process_time() - cpu0, "scans": len(frames), "updates": slam.n_updates}))
        return
    from mcnkit.mcn import McnConfig, McnSlam, load_model
    from mcnkit.run import run_mcn

    net = load_model("unet-explore")  # mcnkit run's default (same architecture and cost as "unet")

    def loop(record: bool) -> dict:
        mcn = McnSlam(config, net, McnConfig(samples=4, ranks=ranks, full_map_every=5 if record else 0),
                      np.random.default_rng(0), generator=torch.Generator().manual_seed(0))
        cpu0 = time.process_time()
        summary = run_mcn(frames, mcn, rrd=Path(rrd) if record else None, progress=False, optimize=False)
        out = {"cpu_s": time.process_time() - cpu0, "scans": len(frames), "updates": mcn.slam.n_updates,
               "completions": summary.completions, "cpu_s_in_recorder_calls": summary.cpu_s_recording}
        if record:
            out["rrd_mb"] = Path(rrd).stat().st_size / 1e6
        return out

    if mode == "mcn":
        print(json.dumps(loop(False)))
        return
    cpu0 = time.process_time()
    import mcnkit.viz  # noqa: F401  (rerun and pyarrow: a one-time cost)

    import_s = time.process_time() - cpu0
    loop(False)
    loop(True)  # warm-up of both paths
    plain = min((loop(False) for _ in range(repeats)), key=lambda r: r["cpu_s"])
    rec = min((loop(True) for _ in range(repeats)), key=lambda r: r["cpu_s"])
    print(json.dumps({"without": plain, "with_rrd": rec, "import_rerun_cpu_s": import_s}))


def _run(mode: str, log: Path, ranks: int, rrd: Path, repeats: int = 2) -> dict:
    out = subprocess.run([sys.executable, __file__, "--child", mode, str(log), str(ranks), str(rrd), str(repeats)],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.strip().splitlines()[-1])


def _demo_log(work: Path) -> Path:
    from mcnkit.sim import SimConfig, plan_raster, simulate, write_sim_log

    sim = simulate(plan_raster("procedural:3", 0.05, None), SimConfig(max_duration_s=120.0), 0)
    return write_sim_log(sim, work / "apartment.mcap", "mcap", overwrite=True)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--child", nargs=5, metavar=("MODE", "LOG", "RANKS", "RRD", "REPEATS"), help=argparse.SUPPRESS)
    parser.add_argument("--ranks", type=int, nargs="+", default=[1, 3], help="R values for the MIT run")
    parser.add_argument("--repeats", type=int, default=2, help="runs per configuration (the minimum is kept)")
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--results", type=Path, default=ROOT / "benchmarks" / "results")
    a = parser.parse_args()
    if a.child:
        _child(a.child[0], a.child[1], int(a.child[2]), a.child[3], int(a.child[4]))
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
            both = _run("mcn-rrd", log, r, work / "run.rrd", a.repeats)
            plain, rec = both["without"], both["with_rrd"]
            overhead = rec["cpu_s"] / plain["cpu_s"] - 1.0
            report["recording"][name] = {"ranks": r, **both, "overhead": overhead}
            print(f"recording, {name} (R={r}, K=4): {plain['cpu_s']:.2f} s -> {rec['cpu_s']:.2f} s CPU with a "
                  f"recording = {100 * overhead:+.1f} % ({rec['cpu_s_in_recorder_calls']:.2f} s in recorder calls; "
                  f"{rec['rrd_mb']:.1f} MB before compaction; importing rerun once: {both['import_rerun_cpu_s']:.2f} s;"
                  f" target <= 10 %: {'met' if overhead <= 0.10 else 'MISSED'})")
    a.results.mkdir(parents=True, exist_ok=True)
    (a.results / "mcn.json").write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {a.results / 'mcn.json'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
