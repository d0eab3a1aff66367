"""``mcnkit data ...``: install HouseExpo, build/cache pairs, draw example pairs.

Each ``add_*_parser`` adds a subparser whose ``func`` takes the parsed arguments and returns an exit code:
0 on success, 2 with one line on stderr on bad input.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from mcnkit.app.exits import fail
from mcnkit.app.options import add_options
from mcnkit.completion.registry import DOMAINS
from mcnkit.datasets.houseexpo import HOUSEEXPO_SHA256, default_data_dir, find_houseexpo, install_houseexpo

if TYPE_CHECKING:
    from mcnkit.datasets.pairs import PairSet

__all__ = ["ExamplesOptions", "InstallOptions", "PairsOptions", "add_data_parser", "cmd_examples", "cmd_install", "cmd_pairs"]



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
    from mcnkit.datasets.pairs import domain_pair_config, load_or_build_houseexpo_pairs, procedural_pairs

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
            cfg = domain_pair_config(args.domain, args.train, args.val, args.test, args.seed)
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


@dataclass(frozen=True, kw_only=True)
class InstallOptions:
    """``mcnkit data install houseexpo --from PATH_OR_URL``."""

    dataset: Literal["houseexpo"]
    """the dataset (houseexpo: HouseExpo floor plans)"""
    source: str
    """json.tar.gz path, file:// or http(s):// URL"""
    sha256: str | None = None
    """expected digest (default: the published one; '' = skip)"""
    dest: str | None = None
    """data directory (default: $MCNKIT_DATA or ./data)"""


@dataclass(frozen=True, kw_only=True)
class PairsOptions:
    """``mcnkit data pairs --out DIR``."""

    out: str
    """cache directory"""
    domain: str = "houseexpo"
    """houseexpo: Pseudo-SLAM scans of HouseExpo plans (the paper); houseexpo-explore, houseexpo-seen,
    houseexpo-seen-wide: the pairs the exploration samplers learn from (see ``mcnkit train --help``); procedural:
    generated apartments with HOME'S-style masks"""
    houseexpo: str | None = None
    """json.tar.gz or json/ folder (default: the installed one)"""
    train_list: str | None = None
    """official train id list (default: next to the archive)"""
    test_list: str | None = None
    """official test id list (default: next to the archive)"""
    train: int = 5000
    """training pairs"""
    val: int = 200
    """validation pairs"""
    test: int = 100
    """test pairs"""
    seed: int = 0
    """seed of the split shuffle and the scans"""
    no_progress: bool = False
    """no progress bar"""


@dataclass(frozen=True, kw_only=True)
class ExamplesOptions:
    """``mcnkit data examples --out FILE.png``."""

    out: str
    """the PNG file to write"""
    n: int = 6
    """examples per domain"""
    seed: int = 0
    """seed of the drawn examples"""
    houseexpo: str | None = None
    """json.tar.gz or json/ folder (default: the installed one)"""
    cache: str | None = None
    """pair cache directory for the HouseExpo examples (default: <data>/cache/examples)"""


def add_data_parser(subparsers: argparse._SubParsersAction) -> None:
    """Adds ``mcnkit data install|pairs|examples``."""
    data = subparsers.add_parser("data", help="install datasets, build training pairs, draw example pairs")
    sub = data.add_subparsers(dest="data_command", metavar="DATA_COMMAND", required=True)
    inst = sub.add_parser("install", help="install a dataset (HouseExpo) from a path or URL, checking its sha256")
    add_options(inst, InstallOptions, positional=("dataset",), flags={"source": "--from"},
                help={"sha256": f"expected digest (default {HOUSEEXPO_SHA256[:12]}…; '' = skip)"})
    inst.set_defaults(func=cmd_install)
    pairs = sub.add_parser("pairs", help="build (or reuse the cached) 64x64 (m_t, m_T) pairs")
    add_options(pairs, PairsOptions, choices={"domain": DOMAINS})
    pairs.set_defaults(func=cmd_pairs)
    ex = sub.add_parser("examples", help="write a PNG grid of example pairs (m_t, mask, m_T) for both domains")
    add_options(ex, ExamplesOptions)
    ex.set_defaults(func=cmd_examples)
