"""Configuration of the grid FastSLAM filter, with the ROS ``slam_gmapping`` defaults.

Every field keeps gmapping's meaning (its ROS parameter name is given in brackets) so that results
can be compared with the C++ core measured in ``design/ANCHORS.md``.

Example:
    >>> cfg = SlamConfig(n_particles=30)
    >>> cfg.gain
    0.011111111111111112
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["SlamConfig"]


@dataclass(frozen=True)
class SlamConfig:
    """Parameters of :class:`mcnkit.slam.FastSlam` (defaults: ROS ``slam_gmapping``)."""

    n_particles: int = 30
    """Number of particles [particles]."""
    resolution_m: float = 0.05
    """Cell size of the particle maps and of the output map [delta]."""
    max_range_m: float | None = None
    """Beams longer than this are ignored entirely; ``None``: the scanner's ``range_max_m`` - 0.01 [maxRange]."""
    max_usable_range_m: float | None = None
    """Beams are used for matching and mapping only up to this range; ``None``: ``max_range_m`` [maxUrange]."""
    sigma_m2: float = 0.05
    """Scan-matcher score: each beam adds ``exp(-d²/sigma_m2)``, d the end point to cell-mean distance [sigma]."""
    kernel_size: int = 1
    """Half-width of the cell neighbourhood searched for a match of each end point [kernelSize]."""
    lstep_m: float = 0.05
    """Initial translational step of the hill-climbing optimiser [lstep]."""
    astep_rad: float = 0.05
    """Initial angular step of the hill-climbing optimiser [astep]."""
    iterations: int = 5
    """Number of step halvings before the optimiser stops [iterations]."""
    lsigma_m2: float = 0.075
    """Importance weight: each beam adds ``-d²/lsigma_m2`` to the log-likelihood [lsigma]."""
    ogain: float = 3.0
    """Weight flattening: weights ∝ exp((logw - max logw) / (ogain · N)) [ogain]."""
    lskip: int = 0
    """Use one beam out of ``lskip + 1`` when matching [lskip]."""
    minimum_score: float = 0.0
    """A match is accepted only if its score exceeds this, else the odometry pose is kept [minimumScore]."""
    srr: float = 0.1
    """Odometry error in translation as a function of translation [srr]."""
    srt: float = 0.2
    """Odometry error in rotation as a function of translation [srt]."""
    str_: float = 0.1
    """Odometry error in translation as a function of rotation [str]."""
    stt: float = 0.2
    """Odometry error in rotation as a function of rotation [stt]."""
    linear_update_m: float = 1.0
    """Run a filter update after travelling this far since the last one [linearUpdate]."""
    angular_update_rad: float = 0.5
    """... or after turning this much [angularUpdate]."""
    resample_threshold: float = 0.5
    """Resample when Neff < resample_threshold · N [resampleThreshold]."""
    free_check: bool = False
    """Match an end point only to cells whose neighbour one cell back along the beam holds no hit.

    gmapping intends this check, but computes the "free" cell with a map-origin offset that puts it far away
    (unknown, counted as free), so in practice it never rejects: off reproduces gmapping, and is faster.
    """
    track_every_scan: bool = True
    """Between filter updates, also scan-match the best particle's pose at every scan against its map (one
    particle, causal: only the map built so far) from two starts — the previous scan's tracked pose moved by the
    odometry change, and gmapping's pose (the last corrected pose plus the odometry change, which cannot drift) —
    keeping the better-scoring match.  It changes no weight and no map: only the
    reported online trajectory (``FastSlam.trajectory(mode="online")``).  Off: the reported pose between updates
    is gmapping's."""
    occ_thresh: float = 0.25
    """Output map: a cell is occupied when hits / (hits + passes) exceeds this [occ_thresh]."""
    tile_cells: int = 8
    """Side of the copy-on-write map tiles shared between particles (a power of two; 8 = 0.4 m at 5 cm)."""

    def __post_init__(self) -> None:
        positive = {
            "n_particles": self.n_particles,
            "resolution_m": self.resolution_m,
            "sigma_m2": self.sigma_m2,
            "lstep_m": self.lstep_m,
            "astep_rad": self.astep_rad,
            "lsigma_m2": self.lsigma_m2,
            "ogain": self.ogain,
            "linear_update_m": self.linear_update_m,
            "angular_update_rad": self.angular_update_rad,
            "tile_cells": self.tile_cells,
        }
        for name, value in positive.items():
            if not value > 0:
                raise ValueError(f"{name} must be > 0, got {value}")
        for name, opt in (("max_range_m", self.max_range_m), ("max_usable_range_m", self.max_usable_range_m)):
            if opt is not None and not opt > 0:
                raise ValueError(f"{name} must be > 0 or None, got {opt}")
        for name, value in (("srr", self.srr), ("srt", self.srt), ("str_", self.str_), ("stt", self.stt)):
            if value < 0:
                raise ValueError(f"motion noise {name} must be >= 0, got {value}")
        if self.kernel_size < 0 or self.iterations < 0 or self.lskip < 0:
            raise ValueError("kernel_size, iterations and lskip must be >= 0")
        if not 0.0 <= self.resample_threshold <= 1.0:
            raise ValueError(f"resample_threshold must be in [0, 1], got {self.resample_threshold}")
        if not 0.0 < self.occ_thresh < 1.0:
            raise ValueError(f"occ_thresh must be in (0, 1), got {self.occ_thresh}")
        if self.tile_cells & (self.tile_cells - 1):
            raise ValueError(f"tile_cells must be a power of two, got {self.tile_cells}")

    @property
    def gain(self) -> float:
        """The exponent applied to log-weight differences: ``1 / (ogain · n_particles)``."""
        return 1.0 / (self.ogain * self.n_particles)
