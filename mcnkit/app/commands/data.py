"""``mcnkit data ...``: install HouseExpo, build/cache pairs, draw example pairs.

Each ``add_*_parser`` adds a subparser whose ``func`` takes the parsed arguments and returns an exit code:
0 on success, 2 with one line on stderr on bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from mcnkit.app.exits import fail
from mcnkit.datasets.houseexpo import HOUSEEXPO_SHA256, default_data_dir, find_houseexpo, install_houseexpo

if TYPE_CHECKING:
    from mcnkit.datasets.pairs import PairSet

__all__ = ["add_data_parser", "cmd_examples", "cmd_install", "cmd_pairs"]



def _houseexpo_source(args: argparse.Namespace) -> Path | None:
    return Path(args.houseexpo) if getattr(args, "houseexpo", None) else find_houseexpo()


def cmd_install(args: argparse.Namespace) -> int:
    """``mcnkit data install houseexpo --from PATH_OR_URL [--sha256 HEX] [--dest DIR]``."""
    try:
        target = install_houseexpo(args.source, args.dest, args.sha256)
    except (OSError, ValueError) as exc:
        return fail("data install", exc)
    print(f"installed {target}")
    return 0


def _stats_line(name: str, pairs: PairSet) -> dict[str, object]:
    from mcnkit.datasets.pairs import pair_stats

    st = pair_stats(pairs)
    return {
        "split": name,
        "n": st.n,
        "free_fraction": round(st.free_fraction, 4),
        "observed_share": round(st.observed_share, 4),
        "pooled_observed_share": round(st.pooled_observed_share, 4),
    }


def cmd_pairs(args: argparse.Namespace) -> int:
    """``mcnkit data pairs --out DIR``: build (or reuse the cached) pairs and print counts and statistics."""
    from mcnkit.datasets.pairs import PairConfig, load_or_build_houseexpo_pairs, procedural_pairs

    t0 = time.perf_counter()
    try:
        if args.domain == "procedural":
            splits = procedural_pairs(args.train, args.val, args.test, args.seed)
            out = Path(args.out)
            out.mkdir(parents=True, exist_ok=True)
            np.savez_compressed(
                out / "procedural-pairs.npz",
                **{
                    f"{s}_{k}": getattr(getattr(splits, s), k)
                    for s in ("train", "val", "test")
                    for k in ("partial", "target")
                },
            )
            rebuilt = True
        else:
            source = _houseexpo_source(args)
            if source is None:
                return fail("data pairs", "HouseExpo not installed; run `mcnkit data install houseexpo --from ...`")
            cfg = PairConfig(n_train=args.train, n_val=args.val, n_test=args.test, seed=args.seed)
            splits, rebuilt = load_or_build_houseexpo_pairs(
                source, args.out, cfg, args.train_list, args.test_list, progress=not args.no_progress
            )
    except (OSError, ValueError) as exc:
        return fail("data pairs", exc)
    report = {
        "domain": args.domain,
        "rebuilt": rebuilt,
        "seconds": round(time.perf_counter() - t0, 2),
        "build_seconds": splits.manifest.get("build_seconds"),
        "skipped": splits.manifest.get("skipped", 0),
        "skip_reasons": splits.manifest.get("skip_reasons", {}),
        "splits": [_stats_line(s, getattr(splits, s)) for s in ("train", "val", "test")],
    }
    print(json.dumps(report, indent=2))
    return 0


def cmd_examples(args: argparse.Namespace) -> int:
    """``mcnkit data examples --out FILE.png``: a grid of example pairs (m_t, mask, m_T) for both domains."""
    from matplotlib.figure import Figure

    from mcnkit.datasets.pairs import PairConfig, load_or_build_houseexpo_pairs, procedural_pairs

    rows: list[tuple[str, PairSet]] = []
    try:
        source = _houseexpo_source(args)
        if source is not None:
            cfg = PairConfig(n_train=0, n_val=0, n_test=args.n, seed=args.seed)
            cache = args.cache or default_data_dir() / "cache" / "examples"
            splits, _ = load_or_build_houseexpo_pairs(source, cache, cfg, progress=False)
            rows.append(("HouseExpo (pseudo-SLAM)", splits.test))
        else:
            print("mcnkit data examples: HouseExpo not installed, drawing the procedural domain only", file=sys.stderr)
        rows.append(("procedural (HOME'S masking)", procedural_pairs(0, 0, args.n, args.seed).test))
    except (OSError, ValueError) as exc:
        return fail("data examples", exc)
    n = args.n
    fig = Figure(figsize=(1.6 * n, 1.7 * 3 * len(rows)))
    axes = fig.subplots(len(rows) * 3, n, squeeze=False)
    for d, (title, pairs) in enumerate(rows):
        for k in range(n):
            images = (pairs.partial[k], pairs.partial_mask[k], pairs.target[k]) if k < len(pairs) else ()
            for j, label in enumerate(("m_t", "mask", "m_T")):
                ax = axes[3 * d + j, k]
                ax.set_xticks([])
                ax.set_yticks([])
                if images:
                    ax.imshow(images[j], origin="lower", cmap="gray_r", vmin=0.0, vmax=1.0, interpolation="nearest")
                if k == 0:
                    ax.set_ylabel(f"{label}\n{title.split()[0]}" if j == 0 else label, fontsize=8)
        axes[3 * d, 0].set_title(title, fontsize=9, loc="left")
    fig.suptitle("example pairs: m_t (partial), its unknown mask (white = known), m_T (target); black = occupied")
    fig.tight_layout()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    print(f"wrote {out}")
    return 0


def add_data_parser(subparsers: argparse._SubParsersAction) -> None:
    """Adds ``mcnkit data install|pairs|examples``."""
    data = subparsers.add_parser("data", help="install datasets, build training pairs, draw example pairs")
    sub = data.add_subparsers(dest="data_command", metavar="DATA_COMMAND", required=True)

    inst = sub.add_parser("install", help="install a dataset (HouseExpo) from a path or URL, checking its sha256")
    inst.add_argument("dataset", choices=["houseexpo"], help="the dataset (houseexpo: HouseExpo floor plans)")
    inst.add_argument("--from", dest="source", required=True, help="json.tar.gz path, file:// or http(s):// URL")
    inst.add_argument("--sha256", default=None, help=f"expected digest (default {HOUSEEXPO_SHA256[:12]}…; '' = skip)")
    inst.add_argument("--dest", default=None, help="data directory (default: $MCNKIT_DATA or ./data)")
    inst.set_defaults(func=cmd_install)

    pairs = sub.add_parser("pairs", help="build (or reuse the cached) 64x64 (m_t, m_T) pairs")
    pairs.add_argument("--out", required=True, help="cache directory")
    pairs.add_argument("--domain", choices=["houseexpo", "procedural"], default="houseexpo",
                       help="houseexpo: Pseudo-SLAM scans of HouseExpo plans (the paper); procedural: generated "
                            "apartments with HOME'S-style masks (default houseexpo)")
    pairs.add_argument("--houseexpo", help="json.tar.gz or json/ folder (default: the installed one)")
    pairs.add_argument("--train-list", help="official train id list (default: next to the archive)")
    pairs.add_argument("--test-list", help="official test id list (default: next to the archive)")
    pairs.add_argument("--train", type=int, default=5000, help="training pairs (default 5000)")
    pairs.add_argument("--val", type=int, default=200, help="validation pairs (default 200)")
    pairs.add_argument("--test", type=int, default=100, help="test pairs (default 100)")
    pairs.add_argument("--seed", type=int, default=0, help="seed of the split shuffle and the scans (default 0)")
    pairs.add_argument("--no-progress", action="store_true", help="no progress bar")
    pairs.set_defaults(func=cmd_pairs)

    ex = sub.add_parser("examples", help="write a PNG grid of example pairs (m_t, mask, m_T) for both domains")
    ex.add_argument("--out", required=True, help="PNG file")
    ex.add_argument("--n", type=int, default=6, help="examples per domain (default 6)")
    ex.add_argument("--seed", type=int, default=0, help="seed of the drawn examples (default 0)")
    ex.add_argument("--houseexpo", help="json.tar.gz or json/ folder (default: the installed one)")
    ex.add_argument("--cache", help="pair cache directory for the HouseExpo examples (default: <data>/cache/examples)")
    ex.set_defaults(func=cmd_examples)
