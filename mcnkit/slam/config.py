"""Configuration of the grid FastSLAM filter, with the ROS ``slam_gmapping`` defaults, in named sections.

Every field that gmapping has keeps its meaning (its ROS parameter name is given in brackets) so that results can
be compared with gmapping's C++ core (its figures: `benchmarks/bench_slam.py`).  The sections: ``motion`` (the
odometry's noise), ``matching`` (the scan matcher), ``updates`` (when and how the particles are updated), ``wide``
(the wide search that recovers bad odometry), ``loops`` (finding loop closures), ``graph`` (the pose graph that
closes them), ``offline`` (the whole log as one pose graph once the run is over) and ``map`` (the maps' ray
casting and tiles).  On the command line they are ``--slam.SECTION.FIELD`` flags, in a TOML file
``[slam.SECTION]`` tables.

Example:
    >>> cfg = SlamConfig(n_particles=30, loops=LoopsConfig(closure=False))
    >>> cfg.gain, cfg.loops.closure
    (0.011111111111111112, False)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Literal

from mcnkit.types import LidarSpec

__all__ = [
    "FLAT_NAMES",
    "GraphConfig",
    "LoopsConfig",
    "MapConfig",
    "MatchingConfig",
    "MotionConfig",
    "OfflineConfig",
    "SlamConfig",
    "UpdatesConfig",
    "WideConfig",
    "nest_flat_config",
]


def _positive(section: object, *names: str) -> None:
    for name in names:
        value = getattr(section, name)
        if not value > 0:
            raise ValueError(f"{name} must be > 0, got {value}")


@dataclass(frozen=True)
class MotionConfig:
    """The odometry: whether the filter uses it, its noise (how far the particles spread between filter updates),
    and the motion found from the scans alone where it is missing or ignored."""

    odometry: Literal["use", "ignore"] = "use"
    """``use`` the log's odometry where it holds some; ``ignore`` it: every scan's motion is found from the scans
    alone (lidar-only), as in a log without odometry, so that any log can be run the way a handheld scanner's
    would be (``summary.json`` says ``"lidar_only": true``)."""
    check_odometry: bool = False
    """Where the odometry of a step is unlike what the robot has been doing (the motion prior), also find the step
    from the scans alone and keep that instead when the scans explain it better (wheels that slip or spin).  Off
    unless asked: it adds a wide scan search on every such step, and a motion prior that is unsure can outvote good
    odometry."""
    srr: float = 0.1
    """Odometry error in translation as a function of translation [srr]."""
    srt: float = 0.2
    """Odometry error in rotation as a function of translation [srt]."""
    str_: float = 0.1
    """Odometry error in translation as a function of rotation [str]."""
    stt: float = 0.2
    """Odometry error in rotation as a function of rotation [stt]."""
    noise_from_log: bool = True
    """Scale the four coefficients above down to what the log's own odometry shows (the odometry increments
    against the scan-matched ones over the last ``noise_window`` scans; :class:`mcnkit.slam.motion.NoiseScale`):
    gmapping's values are per step, and a log that keeps one scan per metre would get 10-17° of heading noise per
    scan where its odometry errs by a fraction of a degree, more than the hill climbing can pull back.  Never above
    the coefficients; needs ``matching.track_every_scan``.  Off: gmapping's coefficients as they are."""
    noise_step_floor: bool = True
    """With ``noise_from_log``: a step whose odometry and scan-matched increments disagree by more than the
    measured noise keeps noise that spans their disagreement (up to the coefficients): one of the two erred, and a
    cloud as tight as the usual error would hold no particle where the other one says (outdoors, scan matching
    errs grossly now and then)."""
    noise_window: int = 200
    """Scans over which the odometry's error is measured (a log whose floor changes is followed)."""
    noise_min_scale: float = 0.05
    """The coefficients are scaled by no less than this: the particles keep some spread however good the
    odometry (1/20 of gmapping's: about 0.6° of heading per metre)."""
    from_tracking: bool = True
    """With ``matching.track_every_scan``, the particles move by the tracked (scan-matched) motion between two
    scans instead of the raw odometry's: odometry that slips or lies is corrected at every scan, not only at
    updates."""
    unknown_window_m: float = 2.0
    """Where no odometry gives a scan's motion (none in the log, a gap or a jump in it: ``Frame.odom_known``
    False; ``odometry`` ignored; or odometry the scans contradict), the tracking searches the map for the scan
    around where the motion prior (:class:`mcnkit.slam.scanmotion.MotionPrior`) predicts it, within at most ± this
    much in x and y of the pose before (2 m covers the 1 m steps of a log that keeps one scan per metre; the window
    shrinks to twice the fastest motion over one scan the log has shown)."""
    unknown_window_rad: float = math.pi
    """Heading window (±) of that search, at most (π: any turn; the search is exact branch and bound, so only its
    cost grows; it shrinks like ``unknown_window_m``)."""
    unseen_explains: float = 0.5
    """In the search for a scan's motion where the log holds no odometry for it, how much a return that lands where
    no scan has looked yet explains (0 to 1; a return on a mapped wall explains 1, one in space the scans saw free
    0).  0.5, the ternary maps' unknown, neither confirms nor contradicts a pose, so a scan that reaches past the
    map's edge (a robot driving into new ground) is not beaten by a look-alike pose that folds it back onto mapped
    walls; it also leaves unpunished a pose that puts returns behind a wall.  0 scores such a return as one in
    space seen free (docs/slam.md, *Without odometry*, says what each costs on which logs)."""
    prior_window: int = 50
    """Steps over which the motion prior (:class:`mcnkit.slam.scanmotion.MotionPrior`) measures how well constant
    velocity and constant step predict this log's tracked motion, and how far off they are."""
    prior_min_sigma_m: float = 0.02
    """The motion prior's spread in x and y is never below this (a robot that drove steadily may still brake)."""
    prior_min_sigma_rad: float = math.radians(1.0)
    """The motion prior's spread in heading is never below this."""

    def __post_init__(self) -> None:
        if self.odometry not in ("use", "ignore"):
            raise ValueError(f"odometry must be 'use' or 'ignore', got {self.odometry!r}")
        if not 0.0 <= self.unseen_explains <= 1.0:
            raise ValueError(f"unseen_explains must be in [0, 1], got {self.unseen_explains}")
        _positive(self, "unknown_window_m", "unknown_window_rad", "prior_window", "prior_min_sigma_m",
                  "prior_min_sigma_rad")
        for name in ("srr", "srt", "str_", "stt"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")


@dataclass(frozen=True)
class MatchingConfig:
    """The scan matcher: which beams it uses, how it scores a pose and how it climbs to the best one."""

    max_range_m: float | None = None
    """Beams longer than this are ignored entirely; ``None``: the scanner's ``range_max_m`` - 0.01 [maxRange]."""
    max_usable_range_m: float | None = None
    """Beams are used for matching only up to this range; ``None``: ``max_range_m`` [maxUrange]."""
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
    thin_m: float = 0.0
    """Scan matching uses one end point per square of this side (0: every beam): near the robot many beams hit
    the same cells, costing time but adding little (the map still gets every hit)."""
    lskip: int = 0
    """Use one beam out of ``lskip + 1`` when matching [lskip]."""
    minimum_score: float = 0.0
    """A match is accepted only if its score exceeds this, else the odometry pose is kept [minimumScore]."""
    pinned_ratio: float = 0.0
    """Keep a match's correction only along the directions its scan pins down: the match's translation away from
    the predicted pose is kept in full along the direction the score curves most, and along the other in the share
    ``λ₂ / (pinned_ratio · λ₁)`` (at most 1) of the score's curvatures there, so a scan of two parallel walls (a
    corridor, a short-range scanner in a hallway) leaves the odometry's step along them, where the score is flat and
    the climb drifts on its noise.  0: the climb's pose as found (gmapping)."""
    free_check: bool = False
    """Match an end point only to cells whose neighbour one cell back along the beam holds no hit (gmapping
    intends this check but computes the "free" cell with a map-origin offset that puts it far away, so in practice
    it never rejects: off reproduces gmapping, and is faster)."""
    track_every_scan: bool = True
    """Between filter updates, also scan-match the best particle's pose at every scan against its map (one
    particle, causal: only the map built so far) from two starts, the previous scan's tracked pose moved by the
    odometry change and gmapping's pose (the last corrected pose plus the odometry change, which cannot drift),
    keeping the better-scoring match.  It changes no weight and no map, only the reported online trajectory
    (``FastSlam.trajectory(mode="online")``).  Off: the reported pose between updates is gmapping's."""
    self_hit_m: float = 0.3
    """Returns shorter than this that stay at one range on one beam while the robot makes a quarter turn in place are
    the robot's own body (the standoffs and camera mount around a TurtleBot 4's scanner) and are dropped as no return
    from then on (:mod:`mcnkit.slam.selfhits`: driving along a wall at a fixed clearance keeps a beam's range too, a
    quarter turn in place does not); a robot whose body reaches farther from its scanner needs more; 0: keep every
    return [m]."""
    self_hit_tolerance_m: float = 0.05
    """A beam's short returns within this of the first one it gave are the robot's own [m]."""
    deskew: bool = True
    """Where the scanner says when it measured each beam (``LaserScan.time_increment``), move each return to where
    the robot was at the scan's stamp, the robot moving through the sweep as it moved over the step before
    (:mod:`mcnkit.slam.deskew`): a spinning scanner on a turning robot otherwise smears every turn."""

    def __post_init__(self) -> None:
        _positive(self, "sigma_m2", "lstep_m", "astep_rad", "lsigma_m2", "self_hit_tolerance_m")
        if not 0.0 <= self.pinned_ratio <= 1.0:
            raise ValueError(f"pinned_ratio must be in [0, 1], got {self.pinned_ratio}")
        if self.self_hit_m < 0:
            raise ValueError(f"self_hit_m must be >= 0, got {self.self_hit_m}")
        for name in ("max_range_m", "max_usable_range_m"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise ValueError(f"{name} must be > 0 or None, got {value}")
        for name in ("kernel_size", "iterations", "lskip"):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")


@dataclass(frozen=True)
class UpdatesConfig:
    """When the filter updates its particles, how it draws and weighs them, and when it resamples."""

    linear_m: float = 1.0
    """Run a filter update after travelling this far since the last one [linearUpdate]."""
    angular_rad: float = 0.5
    """Run a filter update after turning this much since the last one [angularUpdate]."""
    resample_threshold: float = 0.5
    """Resample when Neff < resample_threshold · N [resampleThreshold]."""
    ogain: float = 3.0
    """Weight flattening: weights ∝ exp((logw - max logw) / (ogain · N)) [ogain]."""
    proposal: Literal["gmapping", "improved"] = "gmapping"
    """How particles are drawn at a filter update: ``gmapping``, the motion model's samples hill-climbed as the
    OpenSLAM core does; ``improved`` (Grisetti et al. 2007, :mod:`mcnkit.slam.proposal`), each particle's
    noise-free prediction scan-matched and the particle drawn around the match with the covariance of match
    likelihood × motion model."""
    proposal_beams: float = 20.0
    """With the improved proposal, the scan's match curvature counts as that of this many independent beams
    (neighbouring beams see the same wall and are not independent evidence)."""

    def __post_init__(self) -> None:
        _positive(self, "linear_m", "angular_rad", "ogain")
        if not 0.0 <= self.resample_threshold <= 1.0:
            raise ValueError(f"resample_threshold must be in [0, 1], got {self.resample_threshold}")
        if self.proposal not in ("improved", "gmapping"):
            raise ValueError(f"proposal must be 'improved' or 'gmapping', got {self.proposal!r}")


@dataclass(frozen=True)
class WideConfig:
    """The wide search: before the hill climbing, a branch-and-bound search of the best particle's map around the
    odometry's prediction, which recovers odometry that is far off (:mod:`mcnkit.slam.widesearch`).  Its window
    grows with the odometry step: ``window_m + window_per_m · step`` up to ``max_window_m`` in x and y, and
    ``window_rad + window_rad_per_m · step + window_rad_per_rad · turn`` up to ``max_window_rad`` in heading."""

    search: bool = True
    """Search the best particle's map over a wide window for a pose that explains the scan clearly better than
    the odometry's prediction, and move all particles there.  Off: gmapping's proposal alone."""
    window_m: float = 0.3
    """Wide search window in x and y (±) before it grows with the odometry step."""
    window_per_m: float = 1.0
    """Growth of the x/y window per metre of odometry step since the last update (odometry can be off by the
    whole step)."""
    max_window_m: float = 2.0
    """Largest x/y window (±)."""
    window_rad: float = math.radians(8.0)
    """Wide search window in heading (±) before it grows with the odometry step."""
    window_rad_per_m: float = math.radians(10.0)
    """Growth of the heading window per metre of odometry step."""
    window_rad_per_rad: float = 0.3
    """Growth of the heading window as a fraction of the odometry turn."""
    max_window_rad: float = math.radians(30.0)
    """Largest heading window (±)."""
    resolution_m: float = 0.1
    """Cell size of the wide search's likelihood field (the hill climbing refines at the map's resolution)."""
    sigma_m: float = 0.15
    """Likelihood field of the wide search: a hit explains end points within about this distance."""
    min_score: float = 0.4
    """The wide optimum must reach this mean likelihood for the particles to jump to it."""
    jump_ratio: float = 0.8
    """The particles jump only when the best pose near the prediction scores below this fraction of the wide
    optimum."""
    max_near_score: float = 0.35
    """The particles jump only when the best pose near the prediction scores below this mean likelihood: only a
    prediction that explains little of the scan is searched around."""
    recentre: bool = False
    """Also when the mode lies within the motion model's 3σ region, move the particle cloud onto it."""


@dataclass(frozen=True)
class LoopsConfig:
    """Finding loop closures: which earlier filter updates are candidates, how widely each is searched, and the
    checks a match must pass before it enters the pose graph (:mod:`mcnkit.slam.loops`).  The search window grows
    with the path from the candidate through the graph: ``window_m + window_per_m · path`` up to ``max_window_m``
    in x and y, ``window_rad + window_rad_per_m · path`` up to ``max_window_rad`` in heading."""

    closure: bool = True
    """Close loops through a pose graph over the filter updates; off: gmapping's filter alone, which closes a loop
    only when some particle happens to be close enough when it comes back."""
    min_travel_m: float = 10.0
    """An update is a loop candidate for a new one only when the path driven between them is longer than this
    (closer ones are already in the particles' own maps)."""
    window_m: float = 0.5
    """Loop search window in x and y (±) before it grows with the path."""
    window_per_m: float = 0.02
    """Growth of the x/y window per metre of path from the candidate through the pose graph (the path driven since
    it, shortened by the loops already closed: how far the estimate can have drifted; scan matching drifts ~1-2 %
    of the distance)."""
    max_window_m: float = 8.0
    """Largest x/y window (±; 2 % of 400 m of path).  The window is a first guess: a match that peaks on its border
    (the map drifted more than that) doubles it, up to this and ``max_window_rad``, and is searched again; the
    uniqueness, free-space and confirmation checks guard the wider search."""
    window_rad: float = math.radians(5.0)
    """Loop search window in heading (±) before it grows with the path."""
    window_rad_per_m: float = math.radians(0.2)
    """Growth of the heading window per metre of path."""
    max_window_rad: float = math.radians(30.0)
    """Largest heading window (±)."""
    min_reach_m: float = 2.0
    """A candidate's estimated pose may lie beyond the window by the new scan's median range (scans about that far
    apart see the same things), but at least this."""
    max_reach_m: float = 15.0
    """That reach beyond the window is at most this."""
    run_gap: int = 5
    """Candidates form one earlier pass through the area while their update numbers are at most this far apart."""
    max_tries: int = 2
    """The nearest node of each of the nearest this many earlier passes is tried."""
    min_explained: float = 0.5
    """A loop match needs this mean likelihood over all the scan's points (half of the scan explained)."""
    edge_length_m: float = 0.5
    """A closed loop counts as this much path when measuring drift through the graph."""
    chain_m: float = 10.0
    """The local map of a candidate holds the scans within this much path of it."""
    map_radius_m: float = 20.0
    """Points farther than this from the robot are left out of loop matching (bounds the search grid)."""
    sigma_m: float = 0.1
    """Likelihood field of loop matching: a hit explains end points within about this distance."""
    min_score: float = 0.6
    """A loop match needs this mean likelihood over those of its points that land where the old scans looked."""
    ambiguity_m: float = 0.5
    """A loop match is ambiguous (rejected) when a pose this far or farther away scores at least
    ``ambiguity_ratio`` of its score (a corridor fits anywhere along its axis)."""
    ambiguity_ratio: float = 0.9
    """See ``ambiguity_m``: the share of the best score at which a distant pose makes a match ambiguous."""
    max_contradiction: float = 0.05
    """A loop match is rejected when more than this fraction of its end points land where the old scans saw empty
    space, farther than ``free_margin_m`` from any of their hits (a wrong match puts end points in open rooms)."""
    free_margin_m: float = 0.2
    """See ``max_contradiction``: how far from the old scans' hits an end point in their free space contradicts."""
    confirm_nodes: int = 3
    """A loop match that would move the map waits for a second one, from one of the next this many updates, that
    places its node consistently (within ``confirm_m`` and ``confirm_rad``)."""
    confirm_m: float = 0.1
    """Consistent confirmation: the two matched poses as far apart as the filter's poses, within this (plus 5 % of
    the distance)."""
    confirm_rad: float = math.radians(2.0)
    """Consistent confirmation: within this in heading."""


@dataclass(frozen=True)
class GraphConfig:
    """The pose graph over the filter updates: how precise its loop edges and steps are stated to be, and when a
    loop match is solved for (:mod:`mcnkit.slam.posegraph`).  A step's stated precision is ``step_sigma_m +
    step_sigma_per_m · length`` in translation and ``step_sigma_rad + step_sigma_rad_per_m · length`` in heading."""

    loop_sigma_xy_m: float = 0.05
    """Stated precision of a loop match in the pose graph (translation)."""
    loop_sigma_rad: float = math.radians(1.0)
    """Stated precision of a loop match in the pose graph (heading)."""
    loop_huber: float = 1e9
    """Loop edges whose error exceeds this many standard deviations pull linearly, not quadratically (Huber)."""
    solve_chi2: float = 7.8
    """A loop match moves the map only when the estimate misses it by more than this squared Mahalanobis distance
    (in the match's information; 7.8: χ²'s 95 % point for 3 degrees of freedom); closer, its edge is kept for later
    solutions and nothing is solved.  Every solution bends the map a little (a match errs by a few centimetres),
    and in an open hall the particles' maps already align a revisit."""
    max_chi2: float = 50.0
    """A loop edge whose squared Mahalanobis error after solving exceeds this is an outlier and dropped."""
    step_match_info: bool = True
    """Each step between two updates also carries the information of the newer update's scan match
    (:func:`mcnkit.slam.proposal.match_information` on the map before it, capped like a loop edge at
    ``loop_sigma_xy_m`` / ``loop_sigma_rad``) on top of the motion model's ``step_sigma_*``: stiff where the scan
    pinned the robot down, as loose as the motion model along a corridor's axis, so a loop's correction lands on
    the steps that could slip instead of being spread evenly."""
    step_sigma_m: float = 0.02
    """Stated precision of the filter's step between two updates in translation, before it grows with the step."""
    step_sigma_per_m: float = 0.03
    """Growth of the step's translation sigma per metre of the step."""
    step_sigma_rad: float = math.radians(0.5)
    """Stated precision of the filter's step in heading, before it grows with the step."""
    step_sigma_rad_per_m: float = math.radians(1.0)
    """Growth of the step's heading sigma per metre of the step."""


@dataclass(frozen=True)
class OfflineConfig:
    """What is done once the run is over: the whole log solved as one pose graph (:mod:`mcnkit.slam.wholegraph`):
    which scans are linked, how their matches are made, and how precise the odometry and the filter's steps are
    stated to be."""

    whole_graph: bool = False
    """Solve the whole log as one graph before the refinement (``trajectory.tum`` and the map come from its
    solution).  Off unless asked: it holds a long corridor's seeds together and lowers MIT CSAIL's relations error
    and FHW's ATE, but loses ground on Acapulco and the Freiburg campus and about doubles a run's CPU (docs/slam.md,
    "The whole log as one graph")."""
    steps: int = 2
    """Each node is matched with the next this many nodes."""
    revisit_m: float = 8.0
    """Two nodes within this distance ..."""
    revisit_rad: float = 1.0
    """... and this heading of each other are matched (a revisit) ..."""
    revisit_path_m: float = 3.0
    """... when at least this much driving lies between them: another pass through one place, or the same pass
    farther on than the next ``steps`` nodes (why: :mod:`mcnkit.slam.wholegraph`)."""
    revisit_bin: int = 2
    """One revisit pair per block of this many × this many nodes."""
    window_m: float = 0.3
    """A neighbour's match is searched within ± this of the run's relative pose (x and y) ..."""
    revisit_window_m: float = 0.5
    """... a revisit's within ± this ..."""
    window_rad: float = math.radians(4.0)
    """... and both within ± this in heading."""
    min_score: float = 0.4
    """A match must reach this mean likelihood over the returns that take part."""
    max_range_m: float = 20.0
    """Returns up to this range take part (beyond it the beams fan out wider than the likelihood field)."""
    resolution_m: float = 0.05
    """Cell size of each scan's likelihood field."""
    sigma_m: float = 0.05
    """Width of each scan's likelihood field."""
    icp_sigma_m: float = 0.02
    """A return's distance from the other scan's wall, one standard deviation (range noise and the outline's
    straight lines) ..."""
    icp_huber_m: float = 0.03
    """... beyond this it pulls linearly (clutter, a door that moved) ..."""
    icp_reach_m: float = 0.1
    """... and a return farther than this from every wall of the other scan is left out (the search radius
    shrinks to it from ``window_m`` as the fit settles)."""
    min_pinned: float = 0.1
    """A match's weaker translation direction counts only where it is pinned at least this share as well as the
    stronger one (along a corridor's axis it is not)."""
    beams: float = 20.0
    """A match's information counts as that of this many independent beams (neighbours hit the same wall)."""
    cap_sigma_m: float = 0.005
    """A match is never stated more precise than this in translation ..."""
    cap_sigma_rad: float = math.radians(0.05)
    """... and this in heading."""
    odom_sigma_m: float = 0.01
    """Stated precision of the odometry's step in translation, before it grows with the step ..."""
    odom_sigma_per_m: float = 0.01
    """... by this per metre."""
    odom_sigma_rad: float = math.radians(0.3)
    """Stated precision of the odometry's step in heading, before it grows ..."""
    odom_sigma_rad_per_m: float = math.radians(0.5)
    """... by this per metre of the step ..."""
    odom_sigma_rad_per_rad: float = 0.03
    """... and this per radian turned."""
    step_sigma_m: float = GraphConfig.step_sigma_m
    """Where no odometry links two nodes, the filter's step is stated this precise in translation (as the online
    graph states it, ``GraphConfig``) ..."""
    step_sigma_per_m: float = GraphConfig.step_sigma_per_m
    """... growing by this per metre ..."""
    step_sigma_rad: float = GraphConfig.step_sigma_rad
    """... and this precise in heading ..."""
    step_sigma_rad_per_m: float = GraphConfig.step_sigma_rad_per_m
    """... growing by this per metre ..."""
    step_sigma_rad_per_rad: float = 0.05
    """... and this per radian turned."""
    huber: float = 3.0
    """Scan-to-scan edges whose error exceeds this many standard deviations pull linearly (Huber)."""
    calibrate: bool = True
    """After each pass, scale each kind of edge's stated precision (odometry, filter steps, neighbours' matches,
    revisits) to what its errors at the solution show, and solve once more."""
    max_chi2: float = 9.0
    """A revisit or odometry edge whose squared Mahalanobis error after solving exceeds this is dropped and the
    graph solved again (a revisit matched around a wrong estimate, odometry the scans contradict)."""
    passes: int = 2
    """Solutions; before each, the revisits are found again around the poses so far."""
    iterations: int = 50
    """Least-squares iterations per solution at most."""

    def __post_init__(self) -> None:
        _positive(self, "steps", "revisit_m", "revisit_rad", "revisit_bin", "window_m", "revisit_window_m",
                  "window_rad", "max_range_m", "resolution_m", "sigma_m", "icp_sigma_m", "icp_huber_m", "icp_reach_m",
                  "min_pinned", "beams", "cap_sigma_m", "cap_sigma_rad", "odom_sigma_m", "odom_sigma_rad",
                  "step_sigma_m", "step_sigma_rad", "huber", "max_chi2", "passes", "iterations")


@dataclass(frozen=True)
class MapConfig:
    """The maps: how far the scans are ray cast, when a cell counts as occupied, the tiles particles share."""

    range_m: float | None = None
    """The maps' ray casting (output map, the completion maps) clears space only up to this range; longer returns
    mark no hit (gmapping's maxUrange for its map).  ``None``: derived from the scanner, the range at which
    neighbouring beams land ``beam_spacing_cells`` cells apart (11.5 m for 1° beams at 5 cm, 23 m for 0.5°), at
    least ``min_range_m``: farther out the beams fan into stripes that leave most cells unseen, and a small heading
    error moves their end by more than a cell."""
    beam_spacing_cells: float = 4.0
    """Without ``range_m``: ray cast out to where neighbouring beams land this many cells apart."""
    min_range_m: float = 8.0
    """Without ``range_m``: ray cast at least this far."""
    occ_thresh: float = 0.25
    """Output map: a cell is occupied when hits / (hits + passes) exceeds this [occ_thresh]."""
    tile_cells: int = 16
    """Side of the copy-on-write map tiles shared between particles (a power of two; 16 = 0.8 m at 5 cm: the tile
    table of every particle spans the whole mapped area, so larger tiles keep it small on campus-sized maps)."""

    def __post_init__(self) -> None:
        if self.range_m is not None and not self.range_m > 0:
            raise ValueError(f"range_m must be > 0 or None, got {self.range_m}")
        if not 0.0 < self.occ_thresh < 1.0:
            raise ValueError(f"occ_thresh must be in (0, 1), got {self.occ_thresh}")
        _positive(self, "tile_cells")
        if self.tile_cells & (self.tile_cells - 1):
            raise ValueError(f"tile_cells must be a power of two, got {self.tile_cells}")


@dataclass(frozen=True)
class SlamConfig:
    """Parameters of :class:`mcnkit.slam.FastSlam` (defaults: ROS ``slam_gmapping``), in sections."""

    n_particles: int = 30
    """Number of particles [particles]."""
    resolution_m: float = 0.05
    """Cell size of the particle maps and of the output map [delta]."""
    motion: MotionConfig = field(default_factory=MotionConfig)
    """The odometry (used or ignored) and its noise."""
    matching: MatchingConfig = field(default_factory=MatchingConfig)
    """The scan matcher."""
    updates: UpdatesConfig = field(default_factory=UpdatesConfig)
    """When and how the particles are updated and resampled."""
    wide: WideConfig = field(default_factory=WideConfig)
    """The wide search that recovers bad odometry."""
    loops: LoopsConfig = field(default_factory=LoopsConfig)
    """Finding loop closures."""
    graph: GraphConfig = field(default_factory=GraphConfig)
    """The pose graph that closes them."""
    offline: OfflineConfig = field(default_factory=OfflineConfig)
    """The whole log as one pose graph once the run is over."""
    map: MapConfig = field(default_factory=MapConfig)
    """The maps' ray casting, occupancy threshold and tiles."""

    def __post_init__(self) -> None:
        _positive(self, "n_particles", "resolution_m")

    def map_range(self, lidar: LidarSpec) -> float:
        """``map.range_m``, or its derivation from the scanner (see the field), never beyond the scanner's range."""
        limit = lidar.range_max_m - 0.01
        if self.map.range_m is not None:
            return min(self.map.range_m, limit)
        spaced = self.map.beam_spacing_cells * self.resolution_m / max(abs(lidar.angle_increment_rad), 1e-6)
        return min(max(spaced, self.map.min_range_m), limit)

    @property
    def gain(self) -> float:
        """The exponent applied to log-weight differences: ``1 / (updates.ogain · n_particles)``."""
        return 1.0 / (self.updates.ogain * self.n_particles)



FLAT_NAMES: dict[str, str] = {
    "srr": "motion.srr", "srt": "motion.srt", "str_": "motion.str_", "stt": "motion.stt",
    "motion_noise_from_log": "motion.noise_from_log", "motion_noise_step_floor": "motion.noise_step_floor",
    "motion_noise_window": "motion.noise_window", "motion_noise_min_scale": "motion.noise_min_scale",
    "motion_from_tracking": "motion.from_tracking", "unknown_motion_window_m": "motion.unknown_window_m",
    "unknown_motion_window_rad": "motion.unknown_window_rad",
    **{name: f"matching.{name}" for name in ("max_range_m", "max_usable_range_m", "sigma_m2", "kernel_size",
                                              "lstep_m", "astep_rad", "iterations", "lsigma_m2", "lskip",
                                              "minimum_score", "free_check", "track_every_scan")},
    "match_thin_m": "matching.thin_m",
    "linear_update_m": "updates.linear_m", "angular_update_rad": "updates.angular_rad",
    **{name: f"updates.{name}" for name in ("resample_threshold", "ogain", "proposal", "proposal_beams")},
    "wide_search": "wide.search",
    **{f"wide_{name}": f"wide.{name}" for name in (
        "window_m", "window_per_m", "max_window_m", "window_rad", "window_rad_per_m", "window_rad_per_rad",
        "max_window_rad", "resolution_m", "sigma_m", "min_score", "jump_ratio", "max_near_score", "recentre")},
    "loop_closure": "loops.closure",
    **{f"loop_{name}": f"loops.{name}" for name in (
        "min_travel_m", "window_m", "window_per_m", "max_window_m", "window_rad", "window_rad_per_m",
        "max_window_rad", "min_reach_m", "max_reach_m", "run_gap", "max_tries", "min_explained", "edge_length_m",
        "chain_m", "map_radius_m", "sigma_m", "min_score", "ambiguity_m", "ambiguity_ratio", "max_contradiction",
        "free_margin_m", "confirm_nodes", "confirm_m", "confirm_rad")},
    **{f"loop_{name}": f"graph.loop_{name}" for name in ("sigma_xy_m", "sigma_rad", "huber")},
    "loop_solve_chi2": "graph.solve_chi2", "loop_max_chi2": "graph.max_chi2",
    **{f"graph_{name}": f"graph.{name}" for name in (
        "step_match_info", "step_sigma_m", "step_sigma_per_m", "step_sigma_rad", "step_sigma_rad_per_m")},
    **{f"map_{name}": f"map.{name}" for name in ("range_m", "beam_spacing_cells", "min_range_m")},
    "occ_thresh": "map.occ_thresh", "tile_cells": "map.tile_cells",
}
"""The flat field names of SlamConfig before it had sections (``summary.json`` files written then) -> their
``SECTION.FIELD`` now."""


def nest_flat_config(table: dict[str, Any]) -> dict[str, Any]:
    """A SlamConfig table with the flat names of :data:`FLAT_NAMES` (an old ``summary.json``'s ``config``) moved
    into their sections; a table without them is returned as it is, and other keys are kept as they are (an
    unknown one is reported when the table is read)."""
    if not any(key in FLAT_NAMES for key in table):
        return table
    nested: dict[str, Any] = {}
    for key, value in table.items():
        section, _, name = FLAT_NAMES.get(key, key).rpartition(".")
        (nested.setdefault(section, {}) if section else nested)[name] = value
    return nested
