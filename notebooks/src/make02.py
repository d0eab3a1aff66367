"""Generates notebooks/02_robot_logs.ipynb (outputs empty): .venv/bin/python notebooks/src/make02.py"""

from nbgen import code, md, save

cells = [
md("""# 02 · Robot logs: ROS1 bags, ROS2 bags, MCAP and CARMEN

Every robot log reaches SLAM the same way: `mcnkit.io.open_log(path)` recognises the format by its
content and yields time-ordered `Frame`s — a laser scan, its stamp in nanoseconds, and the odometry pose of
the robot base interpolated at that stamp.

In this notebook you will
1. simulate a short robot run in a procedural apartment and write it as a **ROS1 bag**, a **ROS2 bag** and an **MCAP** file;
2. open each one, look at its topics and its scanner;
3. open a real **CARMEN** log (MIT CSAIL, 2005) when the shared data is present;
4. plot a scan in the robot frame and in the world;
5. convert a log from one format to another and check that nothing changed."""),
code("""# Parameters: CI runs this notebook small (MCNKIT_CI=1); change them freely.
import os

CI = os.environ.get("MCNKIT_CI") == "1"
SIM_SECONDS = 10.0 if CI else 60.0       # length of the simulated run
APARTMENT = 3                            # procedural apartment number
SHARED_DATA = os.environ.get("MCNKIT_SHARED_DATA", "../../shared/data")"""),
code("""import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from mcnkit.io import LogContent, open_log, write_log
from mcnkit.io.info import describe
from mcnkit.sim import SimConfig, plan_raster, simulate

work = Path(tempfile.mkdtemp(prefix="mcnkit-02-"))
run = simulate(plan_raster(f"procedural:{APARTMENT}", 0.05, None), SimConfig(max_duration_s=SIM_SECONDS), seed=0)
content = run.to_log_content()
print(f"simulated {len(content.frames)} scans; writing three formats into {work}")
paths = {fmt: write_log(work / name, content, fmt)
         for fmt, name in [("ros1", "run.bag"), ("ros2-sqlite3", "run_ros2"), ("mcap", "run.mcap")]}"""),
md("""## What is inside each log
`describe` is what `mcnkit info LOG` prints: the format that was recognised, the topics with their types and
message counts, the LaserScan topic and the odometry source that were detected."""),
code("""for path in paths.values():
    with open_log(path) as log:
        info = describe(log)
    print(f"{path.name:10s} -> format {info['format']:13s} scan {info['scan_topic']}  odometry {info['odom_source']}")
    for t in info["topics"]:
        print(f"    {t['name']:15s} {t['count']:5d}  {t['type']}")"""),
md("""## A real log from 2005: MIT CSAIL (CARMEN format)
CARMEN logs are text: one `FLASER` line per scan with 361 ranges over 180° and the odometry pose.
81.91 m means *no return*; `Scan.valid` is False there."""),
code("""carmen = Path(SHARED_DATA) / "reallab/mit-csail/mit-csail.clf"
if carmen.exists():
    with open_log(carmen) as log:
        info = describe(log)
        frames = list(log.frames())
    print(info["format"], info["scans"], "scans of", info["scanner"]["beams"], "beams,",
          info["scanner"]["fov_deg"], "degrees; duration", info["duration_s"], "s")
    real_scan = frames[500].scan
    print(f"beams with a return in scan 500: {int(real_scan.valid.sum())} of {real_scan.spec.n_beams}")
else:
    frames = list(open_log(paths["mcap"]).frames())
    print(f"{carmen} not found: using the simulated run instead")"""),
md("""## Plot a scan
In the robot frame each beam is `(r cos θ, r sin θ)`; placing it in the world needs the robot pose, here the
raw odometry (which drifts: that is why we need SLAM)."""),
code("""scan = frames[min(500, len(frames) - 1)].scan
ok = scan.valid
th = scan.spec.angles_rad[ok]
r = scan.ranges_m[ok]
fig, axes = plt.subplots(1, 2, figsize=(11, 4.5))
axes[0].scatter(r * np.cos(th), r * np.sin(th), s=2)
axes[0].plot([0], [0], "r^")
axes[0].set_title("one scan, robot frame (x forward)")
axes[0].set_aspect("equal")
odom = np.array([f.odom.as_array() for f in frames])
axes[1].plot(odom[:, 0], odom[:, 1], lw=1)
axes[1].set_title(f"raw odometry path, {len(frames)} scans")
axes[1].set_aspect("equal")
plt.show()"""),
md("""## Convert, and check that nothing changed
`write_log` (and `mcnkit convert IN OUT`) writes LaserScan, Odometry, /tf and /tf_static. Reading the result
back gives the same frames: float32 ranges bit for bit, stamps to the nanosecond."""),
code("""src = carmen if carmen.exists() else paths["ros1"]
with open_log(src) as log:
    original = list(log.frames())
out = write_log(work / "converted.mcap", LogContent(original[:300]), "mcap")
with open_log(out) as log:
    back = list(log.frames())
same = all(a.stamp_ns == b.stamp_ns and np.array_equal(a.scan.ranges_m, b.scan.ranges_m) for a, b in zip(original, back, strict=False))
print(f"{out.name}: {len(back)} frames read back, identical: {same}")
assert same"""),
md("""From the command line the same is

```bash
mcnkit info ../shared/data/reallab/mit-csail/mit-csail.clf
mcnkit convert ../shared/data/reallab/mit-csail/mit-csail.clf mit.bag
mcnkit info mit.bag
```"""),
]
save(cells, "02_robot_logs.ipynb")
