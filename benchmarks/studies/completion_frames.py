"""Which frame a completion net was trained in, against the frame it is asked to complete.

The ``*-explore`` samplers learnt on pairs framed by the plan's bounding box: the house fills the 64 × 64 window, so
where the window ends the house ends. While exploring, the house's extent is unknown and ``mcnkit explore``
completes the seen part plus 2 m (:func:`mcnkit.grid.seen_window`): the house may end anywhere in that window or go
on past it. The ``*-seen`` samplers learnt on the same plans and scans framed that way (domain ``houseexpo-seen``).
Every net completes the same 1,000 test pairs in both frames (same plans, same scans: only the frame differs):
deterministic F (free) and mIoU of the unknown cells, and K = 8 samples of the first 100 (spread/error, ECE, F of
one sample and of the majority).  A third set holds the frame of a building wider than the window (30 m): the
test pairs of ``houseexpo-seen-wide`` whose seen cells reach the frame's edge, which happens only when the window is
the square around the robot (the seen part plus its margin never reaches the edge).

Writes ``benchmarks/results/completion_frames.json`` and ``.md``.  The first run builds both pair caches under
``data/cache`` (HouseExpo installed or in the shared data; about 5 min each on 2 cores).

    .venv/bin/python -m benchmarks.studies.completion_frames [--models sampler-explore sampler-seen ...] [--threads 2]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import numpy as np
import torch

from benchmarks.common import RESULTS
from mcnkit.completion.calibration import score_samples
from mcnkit.completion.data import load_domain_pairs
from mcnkit.completion.registry import MODELS
from mcnkit.completion.sample import complete, sample_completions
from mcnkit.completion.scores import score_maps
from mcnkit.datasets import PairSet
from mcnkit.mcn import load_model
from mcnkit.types import UNKNOWN

FRAMES = {"plan's box (houseexpo-explore)": "houseexpo-explore", "explorer's window (houseexpo-seen)": "houseexpo-seen"}
"""The two framings of the same test pairs, by the domain that builds them."""
AROUND_ROBOT = "square around the robot (houseexpo-seen-wide)"
"""The label of the pairs framed around the robot, seen farther than the window reaches."""


def _first(ps: PairSet, n: int) -> PairSet:
    return PairSet(ps.partial[:n], ps.target[:n], ps.ids[:n])


def around_robot(ps: PairSet) -> PairSet:
    """The pairs whose m_t has a seen cell on the frame's edge: framed by the square around the robot."""
    m = ps.partial
    edge = np.concatenate([m[:, 0], m[:, -1], m[:, :, 0], m[:, :, -1]], axis=1)
    keep = np.flatnonzero(np.any(edge != UNKNOWN, axis=1))
    return PairSet(m[keep], ps.target[keep], tuple(ps.ids[k] for k in keep))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--models", nargs="+", choices=list(MODELS),
                    default=["sampler-explore", "sampler-explore-large", "sampler-seen", "sampler-seen-large"],
                    help="shipped nets to score (default: the two explore and the two seen samplers)")
    ap.add_argument("--samples-maps", type=int, default=100, help="test pairs whose K = 8 samples are scored")
    ap.add_argument("--threads", type=int, default=2, help="torch threads")
    ap.add_argument("--json", type=Path, default=RESULTS / "completion_frames.json", help="output JSON (.md beside)")
    args = ap.parse_args(argv)
    torch.set_num_threads(args.threads)
    tests = {label: load_domain_pairs(d, 22000, 200, 1000, seed=0).test for label, d in FRAMES.items()}
    if len({t.ids for t in tests.values()}) != 1:
        raise SystemExit("the frames' test pairs are not the same plans: rebuild the caches")
    tests[AROUND_ROBOT] = around_robot(load_domain_pairs("houseexpo-seen-wide", 22000, 200, 1000, seed=0).test)
    rows: list[dict[str, Any]] = []
    for name in args.models:
        net = load_model(name)
        for label, ps in tests.items():
            t0 = time.perf_counter()
            s = score_maps(complete(net, ps.partial), ps.target, ps.partial, "free")
            few = _first(ps, args.samples_maps)
            samp = sample_completions(net, few.partial, 8, torch.Generator().manual_seed(0))
            k8 = score_samples(samp.samples, few.partial, few.target)
            row = {"model": name, "frame": label, "pairs": len(ps), "f_free": s.f_measure, "miou_unknown": s.miou_unknown,
                   "spread_over_error": k8.spread_over_error, "ece": k8.ece, "f_single": k8.f_single,
                   "f_majority": k8.f_majority, "seconds": round(time.perf_counter() - t0, 1)}
            rows.append(row)
            print(f"{name:22s} {label:36s} F {row['f_free']:.3f}  mIoU {row['miou_unknown']:.3f}  "
                  f"spread/error {row['spread_over_error']:.2f}  ECE {row['ece']:.3f}  "
                  f"F one {row['f_single']:.3f} majority {row['f_majority']:.3f}", flush=True)
    args.json.parent.mkdir(parents=True, exist_ok=True)
    command = "python -m benchmarks.studies.completion_frames --models " + " ".join(args.models)
    args.json.write_text(json.dumps({"rows": rows, "command": command}, indent=2))
    lines = [f"`{command}`", "", "| net | test pairs framed by | pairs | F free | mIoU unknown | spread/error | ECE | F one sample | F majority of 8 |",
             "|---|---|---|---|---|---|---|---|---|"]
    lines += [f"| `{r['model']}` | {r['frame']} | {r['pairs']} | {r['f_free']:.3f} | {r['miou_unknown']:.3f} | "
              f"{r['spread_over_error']:.2f} | {r['ece']:.3f} | {r['f_single']:.3f} | {r['f_majority']:.3f} |"
              for r in rows]
    args.json.with_suffix(".md").write_text("\n".join(lines) + "\n")
    print(f"wrote {args.json} and {args.json.with_suffix('.md')}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
