"""Configuration of the grid FastSLAM filter, with the ROS ``slam_gmapping`` defaults.

Every field keeps gmapping's meaning (its ROS parameter name is given in brackets) so that results
can be compared with gmapping's C++ core (its figures: `benchmarks/bench_slam.py`).

Example:
    >>> cfg = SlamConfig(n_particles=30)
    >>> cfg.gain
    0.011111111111111112
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mcnkit.types import LidarSpec

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
    """Beams are used for matching only up to this range; ``None``: ``max_range_m`` [maxUrange]."""
    map_range_m: float | None = None
    """The maps' ray casting (output map, the completion maps) clears space only up to this range; longer returns
    mark no hit (gmapping's maxUrange for its map).  ``None``: derived from the scanner, the range at which
    neighbouring beams land ``map_beam_spacing_cells`` cells apart (11.5 m for 1° beams at 5 cm, 23 m for 0.5°),
    at least ``map_min_range_m``: farther out the beams fan into stripes that leave most cells unseen, and a
    small heading error moves their end by more than a cell."""
    map_beam_spacing_cells: float = 4.0
    """See ``map_range_m``."""
    map_min_range_m: float = 8.0
    """See ``map_range_m``."""
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
    match_thin_m: float = 0.0
    """Scan matching uses one end point per square of this side (0: every beam): near the robot many beams hit
    the same cells, costing time but adding little (the map still gets every hit)."""
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
    motion_noise_from_log: bool = True
    """Scale the four coefficients above down to what the log's own odometry shows (:class:`mcnkit.slam.motion.
    NoiseScale`: the odometry increments against the scan-matched ones, over the last ``motion_noise_window``
    scans): gmapping's values are per step, and a log that keeps one scan per metre gets 10-17° of heading noise
    per scan where its odometry errs by a fraction of a degree, more than the hill climbing can pull back.  Never
    above the coefficients; needs ``track_every_scan``.  Off: gmapping's coefficients as they are.  Measured in the
    README ("SLAM on real buildings"): on, with ``motion_noise_step_floor``, the MIT Infinite Corridor goes from
    0.7-19 m ATE to 0.45-0.69 m, the Edmonton convention centre from 0.54-0.90 m to 0.15-0.17 m, and ACES no longer
    loses its map on one seed in six (8.2 m off)."""
    motion_noise_step_floor: bool = True
    """With ``motion_noise_from_log``: a step whose odometry and scan-matched increments disagree by more than the
    measured noise keeps noise that spans their disagreement (up to the coefficients): one of the two erred, and
    a cloud as tight as the usual error would hold no particle where the other one says.  Off, the Freiburg
    campus (outdoors, where scan matching errs grossly now and then) loses its map on two seeds of three (2.2 and
    3.8 m ATE against 0.27-0.30 m on)."""
    motion_noise_window: int = 200
    """Scans over which the odometry's error is measured (a log whose floor changes is followed)."""
    motion_noise_min_scale: float = 0.05
    """The coefficients are scaled by no less than this: the particles keep some spread however good the
    odometry (1/20 of gmapping's: about 0.6° of heading per metre)."""
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
    proposal: str = "gmapping"
    """How particles are drawn at a filter update: ``"improved"`` (Grisetti et al. 2007; :mod:`mcnkit.slam.proposal`):
    each particle's noise-free prediction is scan-matched and the particle drawn around the match with the
    covariance of match likelihood × motion model; ``"gmapping"``: the motion model's samples hill-climbed, as the
    OpenSLAM core does."""
    proposal_beams: float = 20.0
    """The scan's match curvature counts as that of this many independent beams (neighbouring beams see the same
    wall and are not independent evidence)."""
    wide_search: bool = True
    """Before the hill climbing, search the best particle's map over a wide window for a pose that explains the
    scan clearly better than the odometry's prediction, and move all particles there (:mod:`mcnkit.slam.widesearch`):
    recovers odometry that is far off.  Off: gmapping's proposal alone."""
    wide_window_m: float = 0.3
    """Wide search window, ± in x and y: this much ..."""
    wide_window_per_m: float = 1.0
    """... plus this times the odometry step since the last update (odometry can be off by the whole step) ..."""
    wide_max_window_m: float = 2.0
    """... up to this."""
    wide_window_rad: float = math.radians(8.0)
    """Wide search window in heading, ±: this much ..."""
    wide_window_rad_per_m: float = math.radians(10.0)
    """... plus this per metre of the odometry step ..."""
    wide_window_rad_per_rad: float = 0.3
    """... plus this fraction of the odometry turn ..."""
    wide_max_window_rad: float = math.radians(30.0)
    """... up to this."""
    unknown_motion_window_m: float = 2.0
    """Where the log holds no odometry for a scan's motion (``Frame.odom_known`` False: a gap in the odometry
    stream), the tracking searches the map over ± this much in x and y around the pose the previous scan's motion
    predicts (a robot that drove on at the same speed; 2 m covers one that stopped, one that went twice as far, and
    the 1 m steps of a sparse log) ..."""
    unknown_motion_window_rad: float = math.pi
    """... and this much in heading (π: any turn; the search is exact branch and bound, so only its cost grows)."""
    wide_resolution_m: float = 0.1
    """Cell size of the wide search's likelihood field (the hill climbing refines at ``resolution_m``)."""
    wide_sigma_m: float = 0.15
    """Likelihood field of the wide search: a hit explains end points within about this distance."""
    wide_min_score: float = 0.4
    """The wide optimum must reach this mean likelihood to be considered ..."""
    wide_jump_ratio: float = 0.8
    """... and the best pose near the prediction must score below this fraction of it for the particles to jump ..."""
    wide_max_near_score: float = 0.35
    """... and below this mean likelihood: only a prediction that explains little of the scan is searched around."""
    wide_recentre: bool = False
    """Also when the mode lies within the motion model's 3σ region, move the particle cloud onto it."""
    loop_closure: bool = True
    """Close loops through a pose graph over the filter updates (:mod:`mcnkit.slam.loops`); off: gmapping's filter
    alone, which closes a loop only when some particle happens to be close enough when it comes back."""
    loop_min_travel_m: float = 10.0
    """An update is a loop candidate for a new one only when the path driven between them is longer than this
    (closer ones are already in the particles' own maps)."""
    loop_window_m: float = 0.5
    """Loop search window, ± in x and y: this much ..."""
    loop_window_per_m: float = 0.02
    """... plus this per metre of path from the candidate through the pose graph (the path driven since it,
    shortened by the loops already closed: how far the estimate can have drifted from it; scan matching
    drifts ~1-2 % of the distance) ..."""
    loop_max_window_m: float = 8.0
    """... up to this (2 % of 400 m of path: the Freiburg campus drifted 5 m round a 640 m loop before closing it;
    the uniqueness, free-space and confirmation checks guard the wider search).  The window is a first guess: a
    match that peaks on its border (the map drifted more than that) doubles it, up to this (and
    ``loop_max_window_rad``), and is searched again."""
    loop_window_rad: float = math.radians(5.0)
    """Loop search window in heading (±), growing like the translation window ..."""
    loop_window_rad_per_m: float = math.radians(0.2)
    """... by this per metre of path ..."""
    loop_max_window_rad: float = math.radians(30.0)
    """... up to this."""
    loop_min_reach_m: float = 2.0
    """A candidate's estimated pose may lie beyond the window by the new scan's median range (scans about that far
    apart see the same things), but at least this ..."""
    loop_max_reach_m: float = 15.0
    """... and at most this."""
    loop_run_gap: int = 5
    """Candidates form one earlier pass through the area while their update numbers are at most this far apart ..."""
    loop_max_tries: int = 2
    """... and the nearest node of each of the nearest this many passes is tried."""
    loop_min_explained: float = 0.5
    """A loop match needs this mean likelihood over all the scan's points (half of the scan explained) ..."""
    loop_edge_length_m: float = 0.5
    """A closed loop counts as this much path when measuring drift through the graph."""
    loop_chain_m: float = 10.0
    """The local map of a candidate holds the scans within this much path of it."""
    loop_map_radius_m: float = 20.0
    """Points farther than this from the robot are left out of loop matching (bounds the search grid)."""
    loop_sigma_m: float = 0.1
    """Likelihood field of loop matching: a hit explains end points within about this distance."""
    loop_min_score: float = 0.6
    """... and this mean likelihood over those of its points that land where the old scans looked."""
    loop_ambiguity_m: float = 0.5
    """A loop match is ambiguous (rejected) when a pose this far or farther away scores ..."""
    loop_ambiguity_ratio: float = 0.9
    """... at least this fraction of its score (a corridor fits anywhere along its axis)."""
    loop_max_contradiction: float = 0.05
    """A loop match is rejected when more than this fraction of its end points land where the old scans saw
    empty space ..."""
    loop_free_margin_m: float = 0.2
    """... farther than this from any of their hits (a wrong match puts end points in open rooms)."""
    loop_confirm_nodes: int = 3
    """A loop match that would move the map waits for a second one, from one of the next this many updates ..."""
    loop_confirm_m: float = 0.1
    """... that places its node consistently: the two matched poses as far apart as the filter's poses, within
    this (plus 5 % of the distance) ..."""
    loop_confirm_rad: float = math.radians(2.0)
    """... and this in heading."""
    loop_sigma_xy_m: float = 0.05
    """Stated precision of a loop match in the pose graph (translation) ..."""
    loop_sigma_rad: float = math.radians(1.0)
    """... and heading."""
    loop_huber: float = 1e9
    """Loop edges whose error exceeds this many standard deviations pull linearly, not quadratically (Huber)."""
    loop_solve_chi2: float = 7.8
    """A loop match moves the map only when the estimate misses it by more than this squared Mahalanobis distance
    (in the match's information; 7.8: χ²'s 95 % point for 3 degrees of freedom); closer, its edge is kept for later
    solutions and nothing is solved.  Every solution bends the map a little (a match errs by a few centimetres): in
    an open hall seen out to 50 m the particles' maps already align a revisit, and at a bar of 1 the Acapulco
    convention centre was solved 75 times and ended 0.19-0.23 m off its reference (0.12-0.14 m now).  Alone, this
    bar left the MIT Infinite Corridor's along-axis drift uncorrected (0.57-1.25 m); with ``graph_step_match_info``
    it is 0.55-0.74 m (0.45-0.69 m at 1 without it)."""
    loop_max_chi2: float = 50.0
    """A loop edge whose squared Mahalanobis error after solving exceeds this is an outlier and dropped."""
    graph_step_match_info: bool = True
    """In the pose graph, each step between two updates also carries the information of the newer update's scan
    match (:func:`mcnkit.slam.proposal.match_information` on the map before it, capped like a loop edge at
    ``loop_sigma_xy_m`` / ``loop_sigma_rad``) on top of the motion model's ``graph_step_sigma_*``: stiff where the
    scan pinned the robot down, as loose as the motion model along a corridor's axis, so a loop's correction lands
    on the steps that could slip instead of being spread evenly (ACES seed 2 had drifted 0.61 m before its first
    loop; spread evenly, 0.17 m ATE was left).  Measured in the README ("SLAM on real buildings"), with
    ``loop_solve_chi2`` 7.8."""
    graph_step_sigma_m: float = 0.02
    """Stated precision of the filter's step between two updates in the pose graph: this much translation ..."""
    graph_step_sigma_per_m: float = 0.03
    """... plus this per metre of the step ..."""
    graph_step_sigma_rad: float = math.radians(0.5)
    """... and this much heading ..."""
    graph_step_sigma_rad_per_m: float = math.radians(1.0)
    """... plus this per metre of the step."""
    motion_from_tracking: bool = True
    """With ``track_every_scan``, the particles move by the tracked (scan-matched) motion between two scans
    instead of the raw odometry's: odometry that slips or lies is corrected at every scan, not only at updates."""
    occ_thresh: float = 0.25
    """Output map: a cell is occupied when hits / (hits + passes) exceeds this [occ_thresh]."""
    tile_cells: int = 16
    """Side of the copy-on-write map tiles shared between particles (a power of two; 16 = 0.8 m at 5 cm: the tile
    table of every particle spans the whole mapped area, so larger tiles keep it small on campus-sized maps)."""

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
        for name, opt in (("max_range_m", self.max_range_m), ("max_usable_range_m", self.max_usable_range_m),
                          ("map_range_m", self.map_range_m)):
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
        if self.proposal not in ("improved", "gmapping"):
            raise ValueError(f"proposal must be 'improved' or 'gmapping', got {self.proposal!r}")
        if self.tile_cells & (self.tile_cells - 1):
            raise ValueError(f"tile_cells must be a power of two, got {self.tile_cells}")

    def map_range(self, lidar: LidarSpec) -> float:
        """``map_range_m``, or its derivation from the scanner (see the field), never beyond the scanner's range."""
        limit = lidar.range_max_m - 0.01
        if self.map_range_m is not None:
            return min(self.map_range_m, limit)
        spaced = self.map_beam_spacing_cells * self.resolution_m / max(abs(lidar.angle_increment_rad), 1e-6)
        return min(max(spaced, self.map_min_range_m), limit)

    @property
    def gain(self) -> float:
        """The exponent applied to log-weight differences: ``1 / (ogain · n_particles)``."""
        return 1.0 / (self.ogain * self.n_particles)
