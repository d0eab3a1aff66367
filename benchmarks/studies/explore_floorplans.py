"""Exploring drawn floor plans of real buildings: the frontier planner and ``mcn`` on the KTH plans MapEx tests on.

MapEx (Ho et al., ICRA 2025) measures its exploration on 14 floor plans of KTH campus buildings (its repository's
``kth_test_maps``: each an ``occ_map.npy``, 0 = wall, 254 = free, 10 pixels per metre, black walls on a white
background with the outside white too).  This study gives each of them to both planners as ``mcnkit explore --map
image:FILE`` would: the array written as a PNG with a map_server YAML (0.1 m per pixel) into ``--maps``, the light
space outside the building's walls left out (:func:`mcnkit.datasets.images.outside_walls`).  Every (plan, seed,
planner) runs as ``bench_explore`` runs a house (same simulator, SLAM, stopping rule, ``mcn`` with
``mcnkit explore``'s default model at its default K samples) with a larger path budget; the report is that of ``explore_buildings`` (the path to 50 / 80 /
90 % coverage, the coverage at 100 / 200 / 300 m, the paired saving where both reached 90 %).  Writes
``explore_floorplans.json``, ``.md`` and ``.png`` into ``benchmarks/results/``; every run also goes to
``runs.jsonl`` in ``--maps`` as it ends.  The plans are not in the shared data; a snapshot of the MapEx repository
holds them:

    git clone https://github.com/castacks/MapEx /tmp/MapEx
    .venv/bin/python -m benchmarks.studies.explore_floorplans /tmp/MapEx/kth_test_maps --jobs 2
    .venv/bin/python -m benchmarks.studies.explore_floorplans /tmp/MapEx/kth_test_maps --only 50052750 --seeds 0
"""

from __future__ import annotations

import argparse
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from benchmarks.studies.explore_buildings import add_run_options, run_plans, write_report

PIXEL_M = 0.1
"""The KTH plans' pixel size in MapEx (``pixel_per_meter: 10`` in its configuration)."""


def write_plan(occ_map: Path, maps: Path) -> Path:
    """``maps/NAME.png`` and its ``NAME.yaml`` from a MapEx ``occ_map.npy`` (NAME: its folder's name)."""
    from PIL import Image

    name = occ_map.parent.name
    png = maps / f"{name}.png"
    pixels = np.load(occ_map)
    if pixels.dtype != np.uint8 or pixels.ndim != 2:
        raise SystemExit(f"{occ_map}: not a MapEx occupancy map (uint8, 2-D; got {pixels.dtype}, {pixels.shape})")
    Image.fromarray(pixels).save(png)
    png.with_suffix(".yaml").write_text(f"image: {png.name}\nresolution: {PIXEL_M}\norigin: [0.0, 0.0, 0.0]\n"
                                        "negate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n")
    return png


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("plans", type=Path, help="MapEx's kth_test_maps folder (one folder per plan with its occ_map.npy)")
    ap.add_argument("--maps", type=Path, default=Path("/tmp/mcnkit-floorplans"),
                    help="where the plans are written as PNG + YAML (default /tmp/mcnkit-floorplans)")
    ap.add_argument("--only", nargs="+", metavar="NAME", help="a subset of the plans, by folder name (default: all)")
    add_run_options(ap, [0], "explore_floorplans.json")
    args = ap.parse_args()
    t0 = time.perf_counter()
    found = sorted(args.plans.glob("*/occ_map.npy"))
    if not found:
        ap.error(f"{args.plans}: no */occ_map.npy (give MapEx's kth_test_maps folder)")
    if args.only:
        unknown = sorted(set(args.only) - {p.parent.name for p in found})
        if unknown:
            ap.error(f"--only: no plan {', '.join(unknown)} in {args.plans}")
        found = [p for p in found if p.parent.name in args.only]
    args.maps.mkdir(parents=True, exist_ok=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    plans = {p.parent.name: write_plan(p, args.maps) for p in found}
    with ProcessPoolExecutor(max(1, args.jobs)) as pool:
        rows = run_plans(pool, "floorplans", {name: f"image:{png}" for name, png in plans.items()}, args.seeds, args.model,
                         {"budget_m": args.budget_m, "stop_coverage": args.stop_coverage}, args.maps / "runs.jsonl", t0)
    write_report(rows, args.out, args.budget_m, {"study": "explore_floorplans", "source": str(args.plans),
                                                 "pixel_m": PIXEL_M, "budget_m": args.budget_m,
                                                 "stop_coverage": args.stop_coverage, "model": args.model,
                                                 "seeds": args.seeds}, t0)

if __name__ == "__main__":
    main()
