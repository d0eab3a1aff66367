"""Benchmark of the grid FastSLAM on the real logs, against the gmapping anchors.

Runs, each in its own subprocess (so CPU time and peak RSS are the SLAM run's own):

* MIT CSAIL raw log, 30 particles, 0.05 m cells, seeds 0 1 2: Kümmerle relations error of every trajectory
  ``mcnkit slam`` writes (``trajectory.tum``, refined offline, is the one the targets judge); CPU s, wall s,
  peak RSS, filter updates; each seed also with the odometry ignored (``--slam.motion.odometry ignore``:
  lidar-only, every scan's motion found from the scans alone), run right after the one with odometry so that the
  CPU ratio of the two is measured under the same conditions;
* Intel lab (raw odometry rebuilt from the corrected log): ATE / RPE against the corrected poses;
* DP-SLAM loop5: loop closure, measured as the registration of the last scans against a map made only of
  the first scans (the corridor the loop starts in), from the SLAM poses: a closed loop needs ~no correction.

Writes ``benchmarks/results/slam.json`` and the maps ``benchmarks/results/slam_*.png``.

    .venv/bin/python -m benchmarks.bench_slam [--seeds 0 1 2] [--data ../shared/data]
"""

from __future__ import annotations

import argparse
import json
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from benchmarks.common import ROOT

DATA = ROOT.parent / "shared" / "data"
GMAPPING = {"translation_m": "0.047-0.049", "rotation_deg": "2.9-3.0", "cpu_s": "39.7-41.1", "rss_mb": "85-99"}


LIDAR_ONLY = ("--slam.motion.odometry", "ignore")


def _child(log: str, seed: int, out: str, *extra: str) -> int:
    """Runs ``mcnkit slam`` in this process (the subprocess side)."""
    from mcnkit.app.commands.slam import add_slam_parser

    parser = argparse.ArgumentParser()
    add_slam_parser(parser.add_subparsers())
    args = parser.parse_args(
        ["slam", log, "--particles", "30", "--resolution", "0.05", "--seed", str(seed), "--out", out, "--no-progress",
         *extra]
    )
    return int(args.func(args))


def _run(log: Path, seed: int, out: Path, extra: tuple[str, ...] = ()) -> dict:
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "benchmarks.bench_slam", "--child", str(log), str(seed), str(out), *extra],
                   check=True, stdout=subprocess.DEVNULL, cwd=ROOT)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    summary = json.loads((out / "summary.json").read_text())
    summary["process_cpu_s"] = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    summary["process_wall_s"] = time.perf_counter() - t0
    return summary


def _loop_closure(log: Path, poses: np.ndarray, n_reference: int = 60, n_last: int = 10) -> dict:
    """Median correction that registers each of the last scans against a map of the first scans only."""
    from mcnkit.geometry import relative
    from mcnkit.io import open_log
    from mcnkit.slam import SlamConfig, TiledHitMaps
    from mcnkit.slam.scanmatch import beam_points, match_particles, score_poses

    with open_log(log) as reader:
        frames = list(reader.frames())
    cfg = SlamConfig(n_particles=1)
    spec = frames[0].scan.spec
    maps = TiledHitMaps(1, cfg.resolution_m, cfg.map.tile_cells)
    laser = spec.base_to_laser.as_array()

    def beams(k: int) -> tuple[np.ndarray, np.ndarray]:
        rmax = spec.range_max_m - 0.01
        return beam_points(frames[k].scan.ranges_m, spec.angles_rad, laser, rmax, rmax, 0.05 * 2**0.5)

    for k in range(n_reference):
        end, _ = beams(k)
        xy = poses[k, :2] + end @ np.array(
            [[np.cos(poses[k, 2]), np.sin(poses[k, 2])], [-np.sin(poses[k, 2]), np.cos(poses[k, 2])]]
        )
        maps.integrate(xy[None, :, 0], xy[None, :, 1])
    corrections, agreement = [], []
    for k in range(len(frames) - n_last, len(frames)):
        end, back = beams(k)
        matched = match_particles(maps, poses[k : k + 1], end, back, cfg).poses[0]
        corrections.append(relative(poses[k], matched))
        agreement.append(score_poses(maps, 0, poses[k : k + 1], end, back, cfg)[0][0] / len(end))
    c = np.array(corrections)
    return {
        "n_reference_scans": n_reference,
        "n_scans": n_last,
        "translation_m": float(np.median(np.hypot(c[:, 0], c[:, 1]))),
        "rotation_deg": float(np.degrees(np.median(np.abs(c[:, 2])))),
        "agreement": float(np.median(agreement)),  # score per beam: 1 = every end point on a mapped wall
    }


def main() -> int:
    if len(sys.argv) >= 5 and sys.argv[1] == "--child":
        return _child(sys.argv[2], int(sys.argv[3]), sys.argv[4], *sys.argv[5:])
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--data", type=Path, default=DATA)
    parser.add_argument("--results", type=Path, default=ROOT / "benchmarks" / "results")
    parser.add_argument("--skip-other-logs", action="store_true", help="MIT CSAIL only")
    a = parser.parse_args()

    from mcnkit.io import open_log
    from mcnkit.metrics import (
        absolute_trajectory_error,
        read_relations,
        read_tum,
        relations_error,
        relative_pose_error,
    )

    a.results.mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="bench_slam_"))
    mit = a.data / "reallab" / "mit-csail" / "mit-csail.clf"
    relations = read_relations(a.data / "reallab" / "mit-csail" / "mit-csail.relations")
    report: dict = {"gmapping_anchor": GMAPPING, "mit_csail": [], "mit_csail_lidar_only": []}
    print("MIT CSAIL, 30 particles, 0.05 m (gmapping C++: 0.047-0.049 m, 2.9-3.0 deg, 39.7-41.1 s CPU, 85-99 MB)")
    print("relations error (mean ± std) of the six trajectories of the same run:")
    print("  refined  = trajectory.tum: the tracked trajectory with every scan moved onto the map of all the others")
    print("  tracked  = trajectory_tracked.tum: the best particle's corrected poses at updates (its ancestry, as gmapping")
    print("             reports them) and, between updates, the scan-by-scan tracking done online against its map")
    print("  online   = strictly causal: at every scan the pose of the particle that was best at that moment")
    print("  gmapping = last corrected pose + odometry between updates (the convention of the gmapping anchor)")
    print("  offline: smoothed = each correction spread over its interval; matched = every scan matched to the final map")
    print(" seed | refined: m / deg | tracked | online | gmapping | smoothed | matched | CPU s | wall s | RSS MB | updates")
    kinds = {"refined": "trajectory.tum", "tracked": "trajectory_tracked.tum", "online": "trajectory_online.tum", "gmapping": "trajectory_gmapping.tum",
             "smoothed": "trajectory_smoothed.tum", "matched": "trajectory_matched.tum"}
    lidar_rows = []
    for seed in a.seeds:
        out = work / f"mit_{seed}"
        s = _run(mit, seed, out)
        lidar = _run(mit, seed, work / f"mit_lidar_{seed}", LIDAR_ONLY)  # right after: the same conditions
        lidar_err = relations_error(read_tum(work / f"mit_lidar_{seed}" / "trajectory.tum"), relations)
        lidar_rows.append({"seed": seed, "relations_refined": lidar_err.as_dict(), **lidar,
                           "cpu_ratio": lidar["process_cpu_s"] / s["process_cpu_s"]})
        errs = {k: relations_error(read_tum(out / f), relations) for k, f in kinds.items()}
        row = {"seed": seed, **{f"relations_{k}": e.as_dict() for k, e in errs.items()}, **s}
        report["mit_csail"].append(row)
        shutil.copy(out / "map.png", a.results / f"slam_mit_csail_seed{seed}.png")
        cells = " | ".join(
            f"{e.translation_mean_m:.4f}±{e.translation_std_m:.3f} / {e.rotation_mean_deg:.2f}±{e.rotation_std_deg:.2f}"
            for e in errs.values()
        )
        print(
            f" {seed:4d} | {cells} | {s['process_cpu_s']:.1f} | {s['process_wall_s']:.1f} | "
            f"{s['peak_rss_mb']:.0f} | {s['filter_updates']}"
        )
    report["mit_csail_lidar_only"] = lidar_rows
    print("odometry ignored (lidar-only), trajectory.tum; CPU against the same seed's run with odometry just before:")
    for r in lidar_rows:
        e = r["relations_refined"]
        print(f" {r['seed']:4d} | {e['translation_mean_m']:.4f}±{e['translation_std_m']:.3f} / "
              f"{e['rotation_mean_deg']:.2f}±{e['rotation_std_deg']:.2f} | CPU {r['process_cpu_s']:.1f} s "
              f"({r['cpu_ratio']:.2f}x) | {r['unknown_motion_scans']} scans without odometry")
    rows = report["mit_csail"]
    for k in kinds:
        t = [r[f"relations_{k}"]["translation_mean_m"] for r in rows]
        r_ = [r[f"relations_{k}"]["rotation_mean_deg"] for r in rows]
        print(f" {k:9s}: translation {min(t):.4f}-{max(t):.4f} m, rotation {min(r_):.2f}-{max(r_):.2f} deg")
    cpu = [r["process_cpu_s"] for r in rows]
    worst_t = max(r["relations_refined"]["translation_mean_m"] for r in rows)
    worst_r = max(r["relations_refined"]["rotation_mean_deg"] for r in rows)
    report["targets"] = {
        "translation_m<=0.050": worst_t <= 0.050, "rotation_deg<=3.0": worst_r <= 3.0,
        "cpu_s<=40": max(cpu) <= 40.0, "peak_rss_mb<=300": max(r["peak_rss_mb"] for r in rows) <= 300.0,
        "lidar_only_translation_m<=0.036": max(r["relations_refined"]["translation_mean_m"] for r in lidar_rows) <= 0.036,
        "lidar_only_cpu_ratio<=1.3": max(r["cpu_ratio"] for r in lidar_rows) <= 1.3,
    }
    print(" targets (trajectory.tum, worst seed): " + ", ".join(f"{k} {'met' if v else 'MISSED'}"
                                                               for k, v in report["targets"].items()))
    print(
        f" CPU per run (whole process incl. imports): {min(cpu):.1f}-{max(cpu):.1f} s; filter loop only: "
        f"{min(r['cpu_s_filter'] for r in rows):.1f}-{max(r['cpu_s_filter'] for r in rows):.1f} s; "
        f"peak RSS {max(r['peak_rss_mb'] for r in rows):.0f} MB"
    )

    if not a.skip_other_logs:
        intel = a.data / "reallab" / "intel" / "intel-corrected.log.gz"
        s = _run(intel, 0, work / "intel")
        with open_log(intel) as reader:
            gt = reader.ground_truth()
        assert gt is not None
        intel_row: dict = {**s}
        for name in ("trajectory", "trajectory_tracked", "trajectory_online", "trajectory_gmapping", "trajectory_matched",
                     "trajectory_smoothed"):
            est = read_tum(work / "intel" / f"{name}.tum")
            intel_row[name] = {
                "ate": absolute_trajectory_error(est, gt).as_dict(),
                "rpe": relative_pose_error(est, gt).as_dict(),
            }
        with open_log(intel) as reader:
            odom = np.array([f.odom.as_array() for f in reader.frames()])
        from mcnkit.types import Trajectory

        intel_row["odometry_ate"] = absolute_trajectory_error(Trajectory(gt.stamps_ns, odom), gt).as_dict()
        report["intel"] = intel_row
        shutil.copy(work / "intel" / "map.png", a.results / "slam_intel.png")
        t, to, tg = intel_row["trajectory"], intel_row["trajectory_online"], intel_row["trajectory_gmapping"]
        print(
            f"Intel lab: ATE rmse {t['ate']['rmse_m']:.3f} m (max {t['ate']['max_m']:.3f}); online (causal) "
            f"{to['ate']['rmse_m']:.3f} m; gmapping convention {tg['ate']['rmse_m']:.3f} m; RPE "
            f"{t['rpe']['translation_mean_m']:.3f} m / {t['rpe']['rotation_mean_deg']:.2f} deg; odometry ATE "
            f"{intel_row['odometry_ate']['rmse_m']:.2f} m; CPU {s['process_cpu_s']:.1f} s, "
            f"{s['filter_updates']} updates"
        )

        loop5 = a.data / "reallab" / "dpslam-loop5" / "loop5.log"
        s = _run(loop5, 0, work / "loop5")
        closure = _loop_closure(loop5, read_tum(work / "loop5" / "trajectory.tum").poses)  # online poses
        with open_log(loop5) as reader:
            closure_odom = _loop_closure(loop5, np.array([f.odom.as_array() for f in reader.frames()]))
        report["loop5"] = {**s, "closure": closure, "closure_odometry": closure_odom}
        shutil.copy(work / "loop5" / "map.png", a.results / "slam_loop5.png")
        print(
            f"DP-SLAM loop5: {s['scans']} scans, {s['filter_updates']} updates, CPU {s['process_cpu_s']:.1f} s; "
            f"loop closure: last {closure['n_scans']} scans registered against the map of the first "
            f"{closure['n_reference_scans']} need {closure['translation_m']:.3f} m / {closure['rotation_deg']:.2f} deg "
            f"of correction (median), score per beam {closure['agreement']:.2f} (odometry poses: "
            f"{closure_odom['agreement']:.2f}); map: {a.results / 'slam_loop5.png'}"
        )

    (a.results / "slam.json").write_text(json.dumps(report, indent=2) + "\n")
    print(f"wrote {a.results / 'slam.json'} and maps slam_*.png")
    shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
