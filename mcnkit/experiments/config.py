"""Settings of Experiments 1, 2 and 3, apart from the code that runs them (so that ``mcnkit experiment --help``
loads neither torch nor the SLAM).  Every field is a flag of its ``mcnkit experiment`` command
(:mod:`mcnkit.app.commands.experiment`)."""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["Exp1Config", "Exp2Config", "Exp3Config"]


@dataclass(frozen=True)
class Exp1Config:
    """Experiment 1 settings: where to write, which weights, how many test maps, the pair splits to read."""

    out_dir: str = "results/exp1"
    """output directory (exp1.csv, exp1.md, PNG figures)"""
    weights_dir: str | None = None
    """directory with the checkpoints (default: shipped weights)"""
    n_test: int = 100
    """HouseExpo test maps (paper: 100; up to 1000)"""
    n_train: int = 16000
    """HouseExpo pair split to read (cache key)"""
    n_procedural_train: int = 4000
    """procedural pair split to read (cache key)"""
    n_procedural_test: int = 100
    """procedural test apartments"""
    n_samples: int = 4
    """samples per example in the figure"""
    n_examples: int = 4
    """examples in the figure"""
    seed: int = 0
    """seed of the test-map draw and of the samples"""
    houseexpo: str | None = None
    """HouseExpo json.tar.gz (default: installed, then ../shared/data)"""
    cache_dir: str | None = None
    """pair cache directory (default: <data>/cache/houseexpo-N)"""
    threads: int = 2
    """torch CPU threads"""


@dataclass(frozen=True)
class Exp2Config:
    """Experiment 2 settings (see :mod:`mcnkit.experiments.exp2` for the protocol)."""

    out_dir: str = "results/exp2"
    """output directory (exp2.csv, exp2.md, PNG figures)"""
    n_maps: int = 10
    """HouseExpo test houses (paper 10; 50 for confidence intervals)"""
    samples: int = 8
    """K completions per map (dropout on)"""
    seed: int = 0
    """seed of the simulation, SLAM and sampling"""
    threads: int = 1
    """torch CPU threads"""
    particles: int = 30
    """FastSLAM particles"""
    models: tuple[str, ...] = ("pix2pix", "unet", "unet-explore")
    """completion networks: unet, pix2pix, unet-explore (trained on exploration maps) or checkpoint paths"""
    late: int = 5
    """the late iteration is T minus this"""
    size: int = 64
    """cells per side of the window every map of a house is pooled on"""
    n_train: int = 16000
    """HouseExpo pair split to read (cache key of Exp 1): its training maps are the bank of the retrieval row"""
    n_test_pool: int = 1000
    """test pairs in that split (cache key); the houses are its first ones"""
    houseexpo: str | None = None
    """HouseExpo json.tar.gz (default: installed / shared)"""
    cache_dir: str | None = None
    """pair cache directory (default: data/cache/houseexpo-N)"""
    maps: tuple[str, ...] = ()
    """explicit plans (houseexpo:ID, procedural:SEED) instead of the HouseExpo test list"""
    lidar_range_m: float = 8.0
    """simulated lidar range [m]"""
    lidar_fov_deg: float = 360.0
    """simulated lidar field of view [deg]"""
    lidar_beams: int = 360
    """simulated lidar beams per scan"""
    max_duration_s: float = 600.0
    """simulated seconds at most per house"""
    log_format: str = "bag"
    """write each simulated run as this format and read it back ('': use the frames directly)"""
    n_examples: int = 3
    """houses drawn in the example figure"""
    curve: bool = True
    """also score SLAM alone, the networks and the all-free fill along the run (exp2_curve.*)"""
    reuse_runs: bool = True
    """reuse cached SLAM results (``runs_dir/*.npz``) made with the same settings"""
    runs_dir: str | None = None
    """where each house's SLAM result is cached (default OUT/runs)"""
    progress: bool = True
    """show a progress bar"""
    extra_notes: tuple[str, ...] = field(default_factory=tuple)
    """lines added to the notes of the report"""

    def __post_init__(self) -> None:
        for name, least in (("n_maps", 1), ("samples", 1), ("particles", 1), ("late", 0), ("threads", 1)):
            if getattr(self, name) < least:
                raise ValueError(f"{name} must be >= {least}, got {getattr(self, name)}")


@dataclass(frozen=True)
class Exp3Config:
    """Experiment 3 settings (see :mod:`mcnkit.experiments.exp3` for the protocol)."""

    out_dir: str = "results/exp3"
    """output directory (exp3.csv, exp3.md, PNG figures)"""
    logs: tuple[str, ...] = ()
    """robot logs (default: MIT CSAIL and Intel in ../shared/data/reallab)"""
    points: tuple[float, ...] = (0.1, 0.25, 0.5, 0.75, 0.9)
    """fractions of the filter updates at which to complete"""
    window_m: float = 16.0
    """robot-centred window side [m]"""
    size: int = 64
    """cells per side of the network's window"""
    samples: int = 8
    """K completions per window (dropout on)"""
    models: tuple[str, ...] = ("unet", "unet-explore", "pix2pix")
    """completion networks: unet, unet-explore, pix2pix or checkpoint paths"""
    particles: int = 30
    """FastSLAM particles"""
    seed: int = 0
    """seed of SLAM and sampling"""
    threads: int = 1
    """torch CPU threads"""
    max_scans: int | None = None
    """only the first scans of each log (tests, quick looks)"""
    convert: bool = True
    """convert each log to a ROS1 bag in a temporary directory and read that back"""
    progress: bool = True
    """show a progress bar"""

    def __post_init__(self) -> None:
        if not self.points or any(not 0.0 <= p <= 1.0 for p in self.points):
            raise ValueError(f"points must be fractions in [0, 1], got {self.points}")
        for name, least in (("samples", 1), ("particles", 1), ("threads", 1)):
            if getattr(self, name) < least:
                raise ValueError(f"{name} must be >= {least}, got {getattr(self, name)}")
        if self.window_m <= 0:
            raise ValueError(f"window_m must be > 0, got {self.window_m}")
