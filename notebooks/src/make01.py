"""Generates notebooks/01_quickstart.ipynb (outputs empty): .venv/bin/python notebooks/src/make01.py"""

from nbgen import code, md, save

cells = [
md("""# 01 · Quickstart: the demo in the embedded viewer

This runs what `make demo` runs: a robot with a lidar explores a procedurally generated apartment (no dataset
needed), its log is written as MCAP, and **MCN-SLAM** runs on it: grid FastSLAM builds the map step by step and,
at every filter update, the shipped U-net samples several completions of the unseen part of the best particles'
maps. Every step is recorded to a Rerun file. Then the recording opens **inside the notebook** — scrub the step
slider (or the viewer's own timeline) to watch the particles, the map, the trajectory and the completions grow.

Everything runs offline: the viewer's code is served by this kernel (`RERUN_NOTEBOOK_ASSET=serve-local`)."""),
code("""# Parameters: CI runs this notebook small and without a viewer (MCNKIT_CI=1).
import os
from pathlib import Path

CI = os.environ.get("MCNKIT_CI") == "1"
os.environ.setdefault("RERUN_NOTEBOOK_ASSET", "serve-local")  # offline viewer
APARTMENT = 3
DURATION_S = 25.0 if CI else 120.0   # simulated seconds
PARTICLES = 10 if CI else 30
VIEWER = not CI                      # the embedded viewer needs a browser front end
OUT = Path("out") / "01"             # this notebook's outputs (git-ignored); `make demo` writes recordings/"""),
code("""import matplotlib.pyplot as plt
from IPython.display import display

from mcnkit.app.commands.demo import run_demo

result = run_demo(OUT / "demo", OUT / "demo.rrd", apartment=APARTMENT,
                  particles=PARTICLES, duration_s=DURATION_S, progress=False)"""),
md("""## Scrub the recording
The left view is the SLAM state: the best particle's map (grey = unknown, magenta tint = cells not yet seen),
the particles, the scan hits (orange), the SLAM trajectory (green) and the raw odometry (grey); under it the
scores against the ground truth (free-space F of the SLAM map and of the completed map, mIoU of the completed
unknown cells, sample diversity) and N_eff. On the right, one row per particle rank: its map m_t as the network
sees it (64 × 64), the sampled completions and their uncertainty; the ground truth and the event log are in tabs."""),
code("""if VIEWER:
    from mcnkit.viz.widgets import recording_player

    display(recording_player(result.rrd_path, result.scans))
else:
    print(f"no front end: open {result.rrd_path} with `rerun {result.rrd_path}`")"""),
md("""## The same, as static pictures
The map SLAM wrote (`map.png`, ROS `map_server` format next to it), the last completions (one row per particle
rank: m_t, samples, uncertainty), and the scores."""),
code("""fig, ax = plt.subplots(figsize=(6, 6))
ax.imshow(plt.imread(result.map_png), cmap="gray")
ax.set_title(f"SLAM map after {result.scans} scans")
ax.axis("off")
plt.show()
fig, ax = plt.subplots(figsize=(12, 5))
ax.imshow(plt.imread(result.completion_png))
ax.axis("off")
plt.show()
print(f"ATE RMSE: SLAM {result.ate_slam_m:.3f} m, odometry alone {result.ate_odometry_m:.3f} m")
print(f"free-space F at the first filter update: SLAM map {result.f_slam_first:.3f}, completed "
      f"{result.f_completed_first:.3f}; at the last: {result.f_slam_last:.3f} -> {result.f_completed_last:.3f}")"""),
md("""From a terminal:

```bash
make demo                          # the same run
.venv/bin/rerun recordings/demo.rrd   # the native viewer
mcnkit info recordings/demo/apartment.mcap
```"""),
]
save(cells, "01_quickstart.ipynb")
