"""Generates notebooks/08_exploring_with_predicted_maps.ipynb (outputs empty): .venv/bin/python notebooks/src/make08.py"""

from nbgen import code, md, save

cells = [
md("""# 08 · Exploring with predicted maps

Until now the robot drove a path planned on the *true* floor plan. Here it explores on its own: every metre it
looks at its SLAM map, finds the **frontiers** (known free space next to unknown space) and chooses one to go to.
The loop (`mcnkit.explore`, the same as `mcnkit explore`): lidar → FastSLAM → planner → motion, until the reachable
free space is seen or the path budget is spent.

Two planners, the same robot, SLAM, sensor noise and stopping rule:

* **frontier** (Yamauchi 1997) goes to the nearest reachable frontier (by path length);
* **mcn** draws K completions of its map from the network, whole plausible houses, and scores each frontier by the
  unknown area a scan from there would see *through each sample's own walls*, averaged over the samples, divided
  by the path cost (+1 m). A doorway into a predicted room scores high; a corner whose unknown cells the samples
  close off with a wall scores low.

Coverage is measured on the ground truth: the share of the reachable free space (every free cell a scan from a
place the robot fits in could see) that the lidar has seen."""),
code("""# Parameters: CI runs this notebook small and without a viewer (MCNKIT_CI=1); change them freely.
import os

CI = os.environ.get("MCNKIT_CI") == "1"
os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")  # offline viewer
HOUSE = "procedural:2" if CI else "houseexpo:056774dc61f48c427d95a6f5ac84f753"  # Experiment 2's first test house
SEED = 0                        # start pose and noise: the same for both planners
BUDGET_M = 10.0 if CI else 120.0
SAMPLES = 2 if CI else 8        # K completions per planning step
MODEL = "sampler-seen"          # falls back to unet-explore when the sampler is not installed
RRD = None if CI else "../recordings/notebook_08"  # notebook_08_frontier.rrd, notebook_08_mcn.rrd
VIEWER = not CI                 # the embedded Rerun viewer needs a browser front end"""),
code("""import numpy as np
import torch
from IPython.display import HTML, display

from mcnkit.completion.registry import CheckpointError
from mcnkit.explore import ExploreConfig, Explorer, FrontierPlanner, GainConfig, McnPlanner
from mcnkit.explore.loop import seed_streams
from mcnkit.mcn import load_model
from mcnkit.sim import SimConfig, plan_raster
from mcnkit.viz.widgets import ExploreStepper

torch.set_num_threads(1)
try:
    raster = plan_raster(HOUSE)
except ValueError as err:  # HouseExpo not installed: a procedural apartment instead
    print(f"{err}\\n-> using procedural:2")
    raster = plan_raster("procedural:2")
try:
    net = load_model(MODEL)
except CheckpointError as err:
    print(f"{err}\\n-> using unet-explore")
    net = load_model("unet-explore")
config = ExploreConfig(budget_m=BUDGET_M)
gain = GainConfig(samples=SAMPLES)
mcn = McnPlanner(net, gain, SimConfig().lidar.range_max_m, torch.Generator().manual_seed(seed_streams(SEED)[2]))
explorers = {"frontier": Explorer(raster, FrontierPlanner(), config, seed=SEED),
             "mcn": Explorer(raster, mcn, config, seed=SEED)}
stepper = ExploreStepper(explorers, RRD, viewer=VIEWER)
print(f"{raster.name}: {explorers['mcn'].reachable.sum() * raster.grid.resolution_m ** 2:.0f} m² of reachable free "
      f"space; both robots start at ({explorers['mcn'].truth[0]:.1f}, {explorers['mcn'].truth[1]:.1f}) m")"""),
md("""## Step the robots
*step* drives both robots some frames, *next planning step* on to the next decision. The figure shows, for each
planner, the map it planned on, the frontier cells coloured by their segment's score (yellow best), the
viewpoints (one per segment, size by expected gain), the chosen goal (magenta star) and its path; on the right the
coverage curves; below, the K samples behind the `mcn` planner's last scores and where they disagree. The tables
say **why** each goal won: its gain, its path cost and the score they make."""),
code("""if VIEWER and stepper.viewer is not None:
    stepper.viewer.display()
display(stepper.widget())"""),
code("""stepper.next_plan()
stepper.next_plan()
display(HTML(stepper.why("frontier") + stepper.why("mcn")))
stepper.figure()"""),
md("""## What a viewpoint is worth
For the `mcn` planner's last goal: the share of the samples in which a scan from there sees each cell of the
completions' window. Where all samples put a wall the view stops; where they disagree it is partial. The gain is
the unknown area inside this view, averaged over the samples."""),
code("""import matplotlib.pyplot as plt

from mcnkit.explore.gain import sample_walls, visible_mask

d = stepper.decisions["mcn"]
if d is not None and d.prediction is not None and d.goal_xy_m is not None:
    pred, w = d.prediction, d.prediction.window
    origin = (d.goal_xy_m - [w.origin_x_m, w.origin_y_m]) / w.resolution_m
    walls = sample_walls(pred.samples, pred.partial, "unknown")
    view = np.mean([visible_mask(walls[k], origin, 180, 8.0 / w.resolution_m) for k in range(len(walls))], axis=0)
    fig, ax = plt.subplots(1, 2, figsize=(8, 4))
    ax[0].imshow(pred.partial, origin="lower", cmap="gray_r", vmin=0, vmax=1)
    ax[0].set_title("m_t on the window")
    ax[1].imshow(view * (pred.partial == 0.5), origin="lower", cmap="viridis", vmin=0, vmax=1)
    ax[1].set_title(f"unknown cells seen from the goal\\n(share of samples; gain {d.gain[d.choice]:.1f} m²)")
    for a in ax:
        a.plot(*origin, "m*", ms=12)
        a.set_xticks([]), a.set_yticks([])
    plt.show()"""),
md("""## Both to the end
The runs go on until the reachable free space is seen, no reachable frontier is left, or the budget is spent."""),
code("""stepper.run()
display(HTML(stepper.status()))
stepper.coverage()"""),
code("""from mcnkit.explore.metrics import final_map_f, summarize

rows = []
for name, ex in explorers.items():
    f_slam, f_done = final_map_f(ex, net, SAMPLES, torch.Generator().manual_seed(SEED))
    s = summarize(ex, f_slam, f_done)
    p90 = s.path_to_coverage_m["0.9"]
    rows.append(f"<tr><td>{name}</td><td>{'—' if p90 is None else f'{p90:.1f}'}</td><td>{s.path_length_m:.1f}</td>"
                f"<td>{s.coverage:.3f}</td><td>{s.planning_steps}</td><td>{1000 * s.plan_cpu_s_mean:.0f}</td>"
                f"<td>{s.f_slam:.3f}</td><td>{s.f_completed:.3f}</td></tr>")
display(HTML("<table><tr><th>planner</th><th>path to 90 % [m]</th><th>path [m]</th><th>coverage</th>"
             "<th>planning steps</th><th>CPU per step [ms]</th><th>F map</th><th>F completed</th></tr>"
             + "".join(rows) + "</table>"))"""),
md("""## Over many houses
One house says little: exploration results vary a lot from plan to plan. `benchmarks/bench_explore.py` runs both
planners on Experiment 2's 50 HouseExpo test houses and on procedural apartments with the same seeds, and reports
the mean path to 90 % coverage with a 95 % confidence interval from the per-house differences. Its last results,
if present, and the same benchmark on three seed sets pooled (`benchmarks/studies/explore_seeds.py`):"""),
code("""import json
from pathlib import Path

results = Path("../benchmarks/results/explore.json")
if results.exists():
    data = json.loads(results.read_text())
    for domain, d in data["domains"].items():
        p = d["paired"]["mcn"]
        if "saving" in p:
            print(f"{domain}: path to 90 % coverage {p['mean_frontier_m']:.1f} m (frontier) vs {p['mean_other_m']:.1f} m "
                  f"(mcn) over {p['both_finished']} houses: {100 * p['saving']:.1f} % shorter "
                  f"(95 % CI {100 * p['saving_ci95'][0]:.1f} to {100 * p['saving_ci95'][1]:.1f} %)")
else:
    print("no benchmark results yet: .venv/bin/python -m benchmarks.bench_explore")
pooled = Path("../benchmarks/results/explore_seeds.json")  # the same benchmark on three seed sets, pooled
if pooled.exists():
    for domain, d in json.loads(pooled.read_text())["domains"].items():
        per_set = " / ".join(f"{100 * x:.1f}" for x in d["saving_per_set"])
        print(f"{domain}, {d['seed_sets']} seed sets: {per_set} %, pooled {100 * d['saving']:.1f} % shorter "
              f"(95 % CI {100 * d['saving_ci95'][0]:.1f} to {100 * d['saving_ci95'][1]:.1f} %) over "
              f"{d['runs_both_finished']} runs; only frontier finished: {d['runs_only_frontier_finished']}")"""),
]
save(cells, "08_exploring_with_predicted_maps.ipynb")
