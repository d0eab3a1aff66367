"""Generates notebooks/03_fastslam_step_by_step.ipynb (outputs empty): .venv/bin/python notebooks/src/make03.py"""

from nbgen import code, md, save

cells = [
md("""# 03 · FastSLAM step by step

A robot explores an apartment it has never seen. Its wheel odometry drifts; its lidar sees walls. Grid
FastSLAM (a Rao-Blackwellized particle filter, as in gmapping) keeps **N hypotheses** of the robot's path, each
with its own map:

1. **predict** — every particle moves by the odometry increment plus sampled noise;
2. **correct** — after the robot moved 1 m or turned 0.5 rad, each particle scan-matches against *its own* map
   and is weighted by how well the scan fits;
3. **resample** — when the weights are too uneven (N_eff < N/2), good particles are copied and bad ones die;
4. **map** — each particle writes the scan into its map.

Use the buttons to step the filter; the viewer shows the particles (size and colour = weight), the best
particle's map, its trajectory (green) and the raw odometry (grey). The slider moves the viewer's time cursor."""),
code("""# Parameters: CI runs this notebook small and without a viewer (MCNKIT_CI=1).
import os

CI = os.environ.get("MCNKIT_CI") == "1"
SIM_SECONDS = 20.0 if CI else 90.0   # length of the simulated run
PARTICLES = 10 if CI else 30
APARTMENT = 3
VIEWER = not CI                      # the embedded Rerun viewer needs a browser front end
RRD = "../recordings/notebook_03.rrd\""""),
code("""from pathlib import Path

import numpy as np
from IPython.display import display

from mcnkit.sim import SimConfig, plan_raster, simulate
from mcnkit.types import TernaryMap
from mcnkit.viz.widgets import SlamStepper

raster = plan_raster(f"procedural:{APARTMENT}", 0.05, None)
run = simulate(raster, SimConfig(max_duration_s=SIM_SECONDS), seed=0)
truth_map = TernaryMap(np.where(raster.free, 0.0, 1.0).astype(np.float32), raster.grid)
print(f"{len(run.frames)} scans of {run.frames[0].scan.spec.n_beams} beams")
stepper = SlamStepper(run.frames, RRD, particles=PARTICLES, viewer=VIEWER, ground_truth=truth_map)"""),
md("""## The stepper
`step` runs as many scans as *scans/step* says; `reset` starts again with the particle count and odometry
noise you chose (try 3 particles and noise ×5: the filter loses track)."""),
code("""if VIEWER:
    stepper.logger.viewer.display()
display(stepper.widget())"""),
code("""stepper.step(len(run.frames) // 3)
print(stepper.status())
stepper.figure()"""),
md("""## Watching resampling
Every filter update re-weights the particles. N_eff = 1 / Σ w² says how many particles really carry weight;
below N/2 the filter resamples."""),
code("""stepper.step(len(run.frames))
print(stepper.status())
print("\\n".join(stepper.events[-8:]) or "no resampling yet")
stepper.figure()"""),
md("""## How good is the estimate?
Absolute trajectory error (after a rigid alignment) of the SLAM trajectory and of the raw odometry, against
the simulator's ground truth."""),
code("""from mcnkit.metrics import absolute_trajectory_error

slam_ate = absolute_trajectory_error(stepper.slam.trajectory(), run.ground_truth)
odom_ate = absolute_trajectory_error(run.odometry, run.ground_truth)
print(f"ATE RMSE: SLAM {slam_ate.rmse_m:.3f} m, odometry alone {odom_ate.rmse_m:.3f} m")
stepper.logger.close()
print(f"recording: {Path(RRD).resolve()}  (open it with: rerun {RRD})")"""),
]
save(cells, "03_fastslam_step_by_step.ipynb")
