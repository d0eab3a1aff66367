"""Generates notebooks/06_experiment_2.ipynb (outputs empty): .venv/bin/python notebooks/src/make06.py"""

from nbgen import code, md, save

cells = [
md("""# 06 · Experiment 2: MCN-SLAM in simulation

Experiment 1 (notebook 05) completed maps made by one Pseudo-SLAM scan. The paper's second experiment puts the
completion network **inside SLAM**: a robot explores a HouseExpo house in a simulator, grid FastSLAM (Gmapping)
builds the map, and the map of the best particle, $m_t$, is completed by the network. It is scored at the
**first iteration** (the first scan, before the robot moves) and at iteration **T−5** (five filter updates
before the end), against $m_T$ = the SLAM map after the whole run.

Protocol (`mcnkit.experiments.exp2`, the same as `mcnkit experiment exp2`):

1. **Houses**: the first HouseExpo test plans in the seeded order Experiment 1 uses (the paper drew 10 at
   random; with 50 the confidence intervals shrink).
2. **Robot**: `mcnkit.sim` explores the whole house (360° lidar, 8 m, drifting odometry). Each run is written as a
   ROS1 bag and read back with `open_log`, the path a real log takes.
3. **SLAM**: FastSLAM with gmapping's defaults and 30 particles. At every filter update the ancestry of the
   particle best *at that update* is remembered, so its map at any update is rebuilt exactly afterwards.
4. **Window**: the paper frames the whole house: every map of a house is pooled onto the same 64 × 64 window,
   $m_T$'s known extent padded square. Cells $m_T$ never saw (outside the outer walls, the padding) count as
   occupied, as in the training maps.
5. **Rows**: (A) pix2pix, (B) U-net (the shipped weights; the mean of K samples, the per-sample mean, and dropout
   off), (C) SLAM alone, (D) retrieval of the best-agreeing HouseExpo training map, and two trivial fills.

Scores: free space is the positive class (the paper's reading, notebook 05); the figure that a trivial fill
cannot game is the mean IoU over {free, occupied} on the cells unknown in $m_t$."""),
code("""# Parameters: CI runs this notebook small (MCNKIT_CI=1); change them freely.
import os
from pathlib import Path

CI = os.environ.get("MCNKIT_CI") == "1"
os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")  # offline viewer
SEED = 0
N_MAPS = 2 if CI else 10               # houses (the paper: 10)
N_MAPS_LARGE = None if CI else 50      # a second run for confidence intervals; None skips it
PARTICLES = 6 if CI else 30            # FastSLAM particles
SAMPLES = 4 if CI else 8               # K completions per map (dropout on)
MAX_DURATION_S = 40.0 if CI else 600.0 # simulated seconds per house (600: the whole house)
N_TRAIN = 200 if CI else 16000         # HouseExpo pair split (cached): its training maps are the bank of (D)
N_TEST_POOL = 20 if CI else 1000       # test pairs in that split; the houses are its first ones
THREADS = 1                            # torch CPU threads
VIEWER = not CI                        # the embedded Rerun viewer needs a browser front end
DATA = Path(os.environ.get("MCNKIT_DATA", "../data"))                          # `make data` installs HouseExpo here
SHARED_DATA = Path(os.environ.get("MCNKIT_SHARED_DATA", "../../shared/data"))  # used when data/ has no HouseExpo
OUT = Path("out")                      # this notebook's outputs (git-ignored): out/06/"""),
code("""import time

import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image, Markdown, display

from mcnkit.datasets import find_houseexpo
from mcnkit.experiments import Exp2Config, paper, run_exp2
from mcnkit.experiments.tables import read_csv

HOUSEEXPO = find_houseexpo(DATA) or find_houseexpo(SHARED_DATA)
if HOUSEEXPO is None:
    raise FileNotFoundError(f"HouseExpo is not in {DATA.resolve()}: run `make data` "
                            "(or `mcnkit data install houseexpo --from PATH_OR_URL`)")
CACHE = (OUT / "cache" / f"exp2-houseexpo-{N_TRAIN}") if CI else DATA / "cache" / f"houseexpo-{N_TRAIN}"
TEXT = {"iteration", "method", "variant", "positive_class", "map"}


def exp2(n_maps):
    \"\"\"Runs Experiment 2 on n_maps houses; returns (output dir, Markdown report, CSV rows).\"\"\"
    out = OUT / "06" / f"exp2-{n_maps}"
    cfg = Exp2Config(out_dir=str(out), n_maps=n_maps, samples=SAMPLES, seed=SEED, threads=THREADS,
                     particles=PARTICLES, max_duration_s=MAX_DURATION_S, n_train=N_TRAIN, n_test_pool=N_TEST_POOL,
                     houseexpo=str(HOUSEEXPO), cache_dir=str(CACHE), runs_dir=str(OUT / "06" / "runs"),
                     progress=False)
    t0 = time.perf_counter()
    report = run_exp2(cfg)
    print(f"Experiment 2 on {n_maps} houses: {time.perf_counter() - t0:.0f} s; {out}/exp2.csv, exp2.md, *.png")
    return out, report, read_csv(out / "exp2.csv", TEXT)


out, report, rows = exp2(N_MAPS)"""),
md("""## The report
`run_exp2` writes `exp2.csv` (one row per iteration × method × variant × positive class), `exp2_per_map.csv`,
`exp2_curve.csv` and `exp2.md` (below). It opens with the issue's checks on the U-net rows, then says where the
cells to complete lie (inside the house or outside its walls), then the tables; the paper's Table 2 comes after
ours."""),
code("""display(Markdown(report))"""),
md("""## Examples
Two rows per house: iteration 1, then iteration T−5. Columns: $m_t$ (grey = unknown), three U-net samples,
their mean, the per-cell uncertainty (entropy of the sampled labels), pix2pix's mean, the exploration-trained
U-net's mean, and $m_T$ (white = free,
black = occupied, the exterior included)."""),
code("""display(Image(filename=str(out / "exp2_examples.png")))"""),
md("""## F and mIoU per row, at both iterations
Blue: F-measure (free space positive); orange: mIoU on the cells unknown in $m_t$; whiskers: 95 % CI over the
houses. Black ticks: the paper's F for the row (Table 2; it reports no Gmapping row at T−5)."""),
code("""PAPER_F = {(r.method.split(")")[0] + ")", r.iteration): r.f_measure for r in paper.EXP2}  # the paper's Table 2


def bar_chart(rows, path):
    k = f"mean of {SAMPLES}"
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.5), sharex=True)
    for ax, it in zip(axes, ("1", "T-5"), strict=True):
        rs = [r for r in rows if r["iteration"] == it and r["positive_class"] == "free" and r["variant"] in ("-", k)]
        y = np.arange(len(rs))
        ax.barh(y - 0.2, [r["f_measure"] for r in rs], 0.4, xerr=[r["f_ci95"] for r in rs], color="C0",
                label="F (free positive)")
        ax.barh(y + 0.2, [r["miou_unknown"] for r in rs], 0.4, xerr=[r["miou_ci95"] for r in rs], color="C1",
                label="mIoU on unknown cells")
        for j, r in enumerate(rs):
            paper = PAPER_F.get((r["method"].split(")")[0] + ")", it))
            if paper is not None and r["method"].startswith(("(A)", "(B)", "(C)", "(D)")):
                ax.plot(paper, j - 0.2, "k|", ms=16, mew=2.5)
        ax.plot([], [], "k|", ms=10, mew=2.5, label="paper's F")
        ax.set_yticks(y, [r["method"] for r in rs], fontsize=8)
        ax.invert_yaxis()
        ax.set_xlim(0, 1)
        ax.grid(axis="x", alpha=0.3)
        ax.set_title(f"iteration {it.replace('-', '−')} ({int(rs[0]['n_maps'])} houses)", fontsize=10)
    axes[0].legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    display(Image(filename=str(path)))  # run_exp2 has switched matplotlib to its Agg backend


bar_chart(rows, out / "exp2_bars.png")"""),
md("""## What the numbers say
The cell below reads the table and states the comparison in words (nothing here is typed in by hand)."""),
code("""K = f"mean of {SAMPLES}"
get = {(r["iteration"], r["method"], r["variant"]): r for r in rows if r["positive_class"] == "free"}
c1, cl = get[("1", "(C) SLAM alone", "-")], get[("T-5", "(C) SLAM alone", "-")]
fill = {it: max(get[(it, m, "-")]["miou_unknown"] for m in ("unknown → all free", "unknown → all occupied"))
        for it in ("1", "T-5")}
print(f"Iteration 1: SLAM alone sees {1 - c1['unknown_share']:.0%} of the window; its F is {c1['f_measure']:.3f} "
      f"(precision {c1['precision']:.3f}, recall {c1['recall']:.3f}).")
for net in ("(B) U-net", "(B') U-net, exploration-trained"):
    if ("1", net, K) not in get:
        continue
    u1, ul = get[("1", net, K)], get[("T-5", net, K)]
    print(f"{net}:")
    print(f"  iteration 1: F {u1['f_measure']:.3f} = {u1['f_measure'] / c1['f_measure']:.2f}× SLAM alone "
          f"(the paper: 0.5275 vs 0.1671), mIoU on unknown cells {u1['miou_unknown']:.3f} vs {fill['1']:.3f} for the "
          "better trivial fill.")
    print(f"  iteration T−5: F {ul['f_measure']:.3f} (SLAM alone {cl['f_measure']:.3f}; the paper's U-net 0.6429), "
          f"mIoU on unknown cells {ul['miou_unknown']:.3f} vs {fill['T-5']:.3f} for the better trivial fill; it fills "
          f"{ul['exterior_predicted_free']:.0%} of the unknown exterior cells with free space.")"""),
md("""How to read it:

* At **iteration 1** the robot has one scan. Completion adds most of the house: F rises well above SLAM
  alone, and the mIoU on the unknown cells (which a trivial fill cannot game) is above both fills.
  Our simulated lidar (360°, 8 m) sees more in one scan than the paper's robot did (their Gmapping row has
  recall 0.10), so SLAM alone starts higher than in the paper.
* At **T−5** the house is almost fully mapped. What is still unknown lies mostly *outside* the outer walls
  (and in the square padding of an elongated house), which $m_T$ counts as occupied. The paper's networks (A) and
  (B) were trained on one-scan maps, where nearly everything unknown is the inside of the house, and they fill that
  exterior with free space: the all-occupied fill beats them on mIoU. (B') was trained on maps part-way through an
  exploration (1–12 scans of this robot's lidar, `mcnkit train --domain houseexpo-explore`): it has learnt that
  beyond closed outer walls there is no more house, keeps the exterior occupied, and beats every fill on mIoU at
  both iterations. On F, SLAM alone stays level with it at T−5 (0.980 vs 0.973 on 50 houses,
  `benchmarks/results/exp2/maps50`): with the house seen, a completion has little left to add. The "mIoU inside" column of the report (cells unknown in $m_t$ that $m_T$ observed) separates the two
  effects. The paper reports no SLAM-alone row at T−5.
* (D) retrieval is strong here: with a 360° scan, the observed cells pin down a training house of the same
  shape better than one 180°, 2 m scan does in Experiment 1.

## Along the run
`exp2_curve.csv`: the same scores at 0, 10, …, 100 % of each house's filter updates. SLAM alone climbs to F = 1
(at the end $m_t = m_T$); the completions help early and fall behind once most of the house is seen."""),
code("""display(Image(filename=str(out / "exp2_curve.png")))"""),
md("""## One MCN-SLAM run, recorded
`mcnkit.viz.run_mcn` runs MCN-SLAM (`McnSlam`: FastSLAM + completion of the R best particles' maps, K samples
each, at every filter update, on the window of the map seen so far) on the first house and records every step to
a Rerun file. With a ground truth it also scores each completion; the plot shows F of $m_t$ and of the completed
map along the run (here on McnSlam's own growing window, not on the experiment's whole-house window)."""),
code("""from mcnkit.mcn import McnConfig, McnSlam, load_model
from mcnkit.viz import run_mcn
from mcnkit.sim import SimConfig, plan_raster, simulate
from mcnkit.slam import SlamConfig
from mcnkit.types import FREE, OCCUPIED, TernaryMap

house = next(r["map"] for r in read_csv(out / "exp2_per_map.csv", TEXT))
raster = plan_raster(house, houseexpo_source=HOUSEEXPO)
sim = simulate(raster, SimConfig(max_duration_s=30.0 if CI else 120.0), seed=SEED)
truth = TernaryMap(np.where(raster.free, FREE, OCCUPIED).astype(np.float32), raster.grid)
mcn = McnSlam(SlamConfig(n_particles=PARTICLES), load_model("unet-explore"), McnConfig(samples=SAMPLES, ranks=2),
              np.random.default_rng(SEED), ground_truth=truth)
rrd = OUT / "06" / "mcn_run.rrd"
summary = run_mcn(sim.frames, mcn, rrd=rrd, ground_truth=truth, progress=False)
print(f"{house}: {summary.scans} scans, {summary.filter_updates} filter updates, {summary.completions} completions, "
      f"{summary.cpu_s:.1f} s CPU; recording {rrd}")
f_slam = [s["f_slam"] for s in summary.scores]
f_done = [s["f_completed"] for s in summary.scores]
fig, ax = plt.subplots(figsize=(7, 3))
ax.plot(f_slam, label="m_t (SLAM alone)")
ax.plot(f_done, label="mean completion (U-net)")
ax.set_xlabel("completion (filter update)")
ax.set_ylabel("F (free positive)")
ax.set_ylim(0, 1)
ax.grid(alpha=0.3)
ax.legend()
plt.show()"""),
code("""if VIEWER:
    from mcnkit.viz import recording_viewer

    recording_viewer(rrd).display()
else:
    print(f"no front end: open {rrd} with `rerun {rrd}`")"""),
md("""## More houses
Ten houses leave wide confidence intervals. The full mode runs the experiment again on 50 houses (the first
10 are the same, their SLAM runs are reused from `out/06/runs/`)."""),
code("""if N_MAPS_LARGE:
    out_l, report_l, rows_l = exp2(N_MAPS_LARGE)
    small = {(r["iteration"], r["method"], r["variant"]): r for r in rows if r["positive_class"] == "free"}
    lines = [f"| iteration | method | variant | F, {N_MAPS} houses | F, {N_MAPS_LARGE} houses | "
             f"mIoU, {N_MAPS} houses | mIoU, {N_MAPS_LARGE} houses |", "|---|---|---|---|---|---|---|"]
    for r in rows_l:
        if r["positive_class"] == "free" and r["variant"] != "per sample":
            s = small[(r["iteration"], r["method"], r["variant"])]
            lines.append(f"| {r['iteration']} | {r['method']} | {r['variant']} | {s['f_measure']:.4f} ± {s['f_ci95']:.4f} | "
                         f"{r['f_measure']:.4f} ± {r['f_ci95']:.4f} | {s['miou_unknown']:.4f} ± {s['miou_ci95']:.4f} | "
                         f"{r['miou_unknown']:.4f} ± {r['miou_ci95']:.4f} |")
    display(Markdown("\\n".join(lines)))
    display(Markdown(report_l.split("## iteration 1")[0]))  # its targets and the diagnosis
    bar_chart(rows_l, out_l / "exp2_bars.png")
else:
    print("N_MAPS_LARGE is None: skipped (set it to 50 in the parameters cell)")"""),
md("""From a terminal, the same experiment:

```bash
mcnkit experiment exp2 --out results/exp2 --n-maps 10
mcnkit experiment exp2 --out results/exp2-50 --n-maps 50
```"""),
]
save(cells, "06_experiment_2.ipynb")
