"""Settings of Experiments 1, 2 and 3 and their command-line options, apart from the code that runs them (so that
``mcnkit experiment --help`` loads neither torch nor the SLAM)."""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field

__all__ = ["Exp1Config", "Exp2Config", "Exp3Config", "add_exp1_arguments", "add_exp2_arguments",
           "add_exp3_arguments", "exp1_config_from_args", "exp2_config_from_args", "exp3_config_from_args"]


@dataclass(frozen=True)
class Exp1Config:
    """Experiment 1 settings: where to write, which weights, how many test maps, the pair splits to read."""

    out_dir: str = "results/exp1"
    weights_dir: str | None = None
    n_test: int = 100
    n_train: int = 16000
    n_procedural_train: int = 4000
    n_procedural_test: int = 100
    n_samples: int = 4
    n_examples: int = 4
    seed: int = 0
    houseexpo: str | None = None
    cache_dir: str | None = None
    threads: int = 2


@dataclass(frozen=True)
class Exp2Config:
    """Experiment 2 settings (see the module docstring for the protocol)."""

    out_dir: str = "results/exp2"
    n_maps: int = 10
    """Houses (the paper: 10; 50 for confidence intervals)."""
    samples: int = 8
    """K completions per map (dropout on)."""
    seed: int = 0
    threads: int = 1
    particles: int = 30
    models: tuple[str, ...] = ("pix2pix", "unet", "unet-explore")
    """Completion networks: short names of :func:`mcnkit.mcn.load_model` or checkpoint paths."""
    late: int = 5
    """The late iteration is T − ``late``."""
    size: int = 64
    n_train: int = 16000
    """HouseExpo pair split to read (cache key of Exp 1): its training maps are the bank of (D)."""
    n_test_pool: int = 1000
    """Test pairs in that split (cache key); the houses are its first ones."""
    houseexpo: str | None = None
    cache_dir: str | None = None
    maps: tuple[str, ...] = ()
    """Explicit plans (``houseexpo:ID`` / ``procedural:SEED``) instead of the HouseExpo test list."""
    lidar_range_m: float = 8.0
    lidar_fov_deg: float = 360.0
    lidar_beams: int = 360
    max_duration_s: float = 600.0
    log_format: str = "bag"
    """Write each simulated run as this format and read it back (``""``: use the frames directly)."""
    n_examples: int = 3
    curve: bool = True
    """Also score SLAM alone, the networks and the all-free fill along the run (``exp2_curve.*``)."""
    reuse_runs: bool = True
    """Reuse cached SLAM results (``runs_dir/*.npz``) made with the same settings."""
    runs_dir: str | None = None
    """Where each house's SLAM result is cached (default ``out_dir/runs``)."""
    progress: bool = True
    extra_notes: tuple[str, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        if self.n_maps < 1 or self.samples < 1 or self.particles < 1 or self.late < 0 or self.threads < 1:
            raise ValueError(f"invalid Exp2Config: {self}")


@dataclass(frozen=True)
class Exp3Config:
    """Experiment 3 settings (see the module docstring for the protocol)."""

    out_dir: str = "results/exp3"
    logs: tuple[str, ...] = ()
    """Robot logs (anything :func:`mcnkit.io.open_log` reads); empty: :func:`default_logs`."""
    points: tuple[float, ...] = (0.1, 0.25, 0.5, 0.75, 0.9)
    """Where along the run to complete, as fractions of the filter updates."""
    window_m: float = 16.0
    size: int = 64
    samples: int = 8
    models: tuple[str, ...] = ("unet", "unet-explore", "pix2pix")
    particles: int = 30
    seed: int = 0
    threads: int = 1
    max_scans: int | None = None
    """Use only the first scans of each log (tests, quick looks)."""
    convert: bool = True
    """Convert each log to a ROS1 bag in a temporary directory and read that back."""
    progress: bool = True

    def __post_init__(self) -> None:
        if not self.points or any(not 0.0 <= p <= 1.0 for p in self.points):
            raise ValueError(f"points must be fractions in [0, 1], got {self.points}")
        if self.samples < 1 or self.particles < 1 or self.window_m <= 0 or self.threads < 1:
            raise ValueError(f"invalid Exp3Config: {self}")


def add_exp1_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Adds Experiment 1's options (``--out`` included) to ``parser``."""
    d = Exp1Config()
    p = parser
    p.add_argument("--out", required=True, help="output directory (exp1.csv, exp1.md, PNG figures)")
    p.add_argument("--weights", default=None, help="directory with the checkpoints (default: shipped weights)")
    p.add_argument("--n-test", type=int, default=d.n_test, help="HouseExpo test maps (paper: 100; up to 1000)")
    p.add_argument("--n-train", type=int, default=d.n_train, help="HouseExpo pair split to read (cache key)")
    p.add_argument("--samples", type=int, default=d.n_samples, help="samples per example in the figure")
    p.add_argument("--seed", type=int, default=d.seed, help="seed of the test-map draw and of the samples (default 0)")
    p.add_argument("--houseexpo", default=None, help="HouseExpo json.tar.gz (default: installed, then ../shared/data)")
    p.add_argument("--cache", default=None, help="pair cache directory (default: <data>/cache/houseexpo-N)")
    p.add_argument("--threads", type=int, default=d.threads, help="torch CPU threads (default 2)")
    return parser


def exp1_config_from_args(args: argparse.Namespace) -> Exp1Config:
    """The :class:`Exp1Config` of options parsed with :func:`add_exp1_arguments`."""
    return Exp1Config(out_dir=args.out, weights_dir=args.weights, n_test=args.n_test, n_train=args.n_train,
                      n_samples=args.samples, seed=args.seed, houseexpo=args.houseexpo, cache_dir=args.cache,
                      threads=args.threads)


def add_exp2_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Adds Experiment 2's options (``--out`` included) to ``parser``."""
    d = Exp2Config()
    parser.add_argument("--out", required=True, help="output directory (exp2.csv, exp2.md, PNG figures)")
    parser.add_argument("--n-maps", type=int, default=d.n_maps, help="HouseExpo test houses (paper 10; 50 for CIs)")
    parser.add_argument("--samples", type=int, default=d.samples, help="K completions per map (dropout on)")
    parser.add_argument("--seed", type=int, default=d.seed, help="seed of the simulation, SLAM and sampling")
    parser.add_argument("--threads", type=int, default=d.threads, help="torch CPU threads")
    parser.add_argument("--particles", type=int, default=d.particles, help="FastSLAM particles")
    parser.add_argument("--models", nargs="+", default=list(d.models),
                        help="completion networks: unet, pix2pix, unet-explore (trained on exploration maps) or "
                             "checkpoint paths")
    parser.add_argument("--range", type=float, default=d.lidar_range_m, dest="lidar_range_m",
                        help="simulated lidar range [m]")
    parser.add_argument("--n-train", type=int, default=d.n_train, help="HouseExpo pair split to read (cache key)")
    parser.add_argument("--houseexpo", default=None, help="HouseExpo json.tar.gz (default: installed / shared)")
    parser.add_argument("--cache", default=None, help="pair cache directory (default: data/cache/houseexpo-N)")
    parser.add_argument("--maps", nargs="+", default=None, help="explicit plans (houseexpo:ID, procedural:SEED)")
    parser.add_argument("--no-curve", action="store_true", help="skip the scores along the run")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


def exp2_config_from_args(args: argparse.Namespace) -> Exp2Config:
    """The :class:`Exp2Config` of options parsed with :func:`add_exp2_arguments`."""
    return Exp2Config(out_dir=args.out, n_maps=args.n_maps, samples=args.samples, seed=args.seed,
                      threads=args.threads, particles=args.particles, models=tuple(args.models),
                      lidar_range_m=args.lidar_range_m, n_train=args.n_train, houseexpo=args.houseexpo,
                      cache_dir=args.cache, maps=tuple(args.maps or ()), curve=not args.no_curve,
                      progress=not args.quiet)


def add_exp3_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Adds Experiment 3's options (``--out`` included) to ``parser``."""
    d = Exp3Config()
    parser.add_argument("--out", required=True, help="output directory (exp3.csv, exp3.md, PNG figures)")
    parser.add_argument("--logs", nargs="+", default=None,
                        help="robot logs (default: MIT CSAIL and Intel in ../shared/data/reallab)")
    parser.add_argument("--points", type=float, nargs="+", default=list(d.points),
                        help="fractions of the filter updates at which to complete")
    parser.add_argument("--window", type=float, default=d.window_m, help="robot-centred window side [m]")
    parser.add_argument("--samples", type=int, default=d.samples, help="K completions per window (dropout on)")
    parser.add_argument("--models", nargs="+", default=list(d.models),
                        help="completion networks: unet, unet-explore, pix2pix or checkpoint paths")
    parser.add_argument("--particles", type=int, default=d.particles, help="FastSLAM particles")
    parser.add_argument("--seed", type=int, default=d.seed, help="seed of SLAM and sampling")
    parser.add_argument("--threads", type=int, default=d.threads, help="torch CPU threads")
    parser.add_argument("--max-scans", type=int, default=None, help="only the first scans of each log")
    parser.add_argument("--no-convert", action="store_true", help="read the logs directly (no ROS1 bag)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


def exp3_config_from_args(args: argparse.Namespace) -> Exp3Config:
    """The :class:`Exp3Config` of options parsed with :func:`add_exp3_arguments`."""
    return Exp3Config(out_dir=args.out, logs=tuple(args.logs or ()), points=tuple(args.points), window_m=args.window,
                      samples=args.samples, models=tuple(args.models), particles=args.particles, seed=args.seed,
                      threads=args.threads, max_scans=args.max_scans, convert=not args.no_convert,
                      progress=not args.quiet)
