"""A Rao-Blackwellized particle filter with gmapping's proposal, closed into loops by a pose graph: :class:`FastSlam`.

Per scan (:meth:`FastSlam.step`):

1. **Tracking**: the best particle's pose is matched against its map at every scan (``track_every_scan``): the
   odometry's prediction is first searched wide on a coarse likelihood field of the map (exact branch and bound,
   :mod:`mcnkit.slam.widesearch`), so odometry that slips, lies or points the wrong way by 10° is caught, then
   hill-climbed at full resolution.  The particles move by that tracked motion with gmapping's sampled noise
   (``motion_from_tracking``), scaled to what the log's own odometry shows against the tracking, but never below
   this step's own disagreement between the two (``motion_noise_from_log``, :class:`mcnkit.slam.motion.NoiseScale`).  Where no odometry
   gives a scan's motion (none in the log, a gap or a jump in it: ``Frame.odom_known`` False; ``motion.odometry``
   ignored: lidar-only; or a step whose odometry is unlike what the robot was doing while the scans side with what
   it was doing: a wheel that spins or slips) the tracking finds it from the scans alone, around the motion prior's
   prediction (:mod:`mcnkit.slam.scanmotion`, :func:`mcnkit.slam.widesearch.unknown_motion_match`), and the
   particles spread by what that match leaves open.
2. **Filter update**, once the robot has travelled ``linear_update_m`` or turned ``angular_update_rad``: every
   particle is scan-matched against its own map (gmapping's hill climbing, or the improved proposal), its
   log-weight gains the match log-likelihood, the weights are flattened (``ogain``), the set is resampled (low
   variance) when Neff < ``resample_threshold`` · N, and the scan's end points are written into every map.
3. **Loop closing** (:mod:`mcnkit.slam.loops`): the update becomes a node of a pose graph; when a wide match of
   its scan against older scans, confirmed by a second one, disagrees with the estimate, the graph is solved and
   every particle is put on the solution: the ancestry of all becomes the solved trajectory and the maps are
   rebuilt on it (:meth:`FastSlam._reanchor`).

The reported trajectory is the *best* particle's (highest log-likelihood summed over its ancestry): its corrected
poses at the filter updates and, between updates, those poses moved by the tracking.  The output map is rebuilt
from that trajectory and the update scans by ray casting, with free space out to the map range (see
``SlamConfig.map_range_m``).

Example:
    >>> slam = FastSlam(SlamConfig(n_particles=10), np.random.default_rng(0))  # doctest: +SKIP
    >>> for frame in log.frames():                                              # doctest: +SKIP
    ...     step = slam.step(frame)
    >>> grid = slam.best_map()                                                  # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from mcnkit.geometry import compose, relative
from mcnkit.grid import log_odds_to_ternary
from mcnkit.slam.config import SlamConfig
from mcnkit.slam.correlative import LikelihoodGrid
from mcnkit.slam.deskew import deskew_ranges
from mcnkit.slam.lineage import LineageMap
from mcnkit.slam.loops import LoopCloser
from mcnkit.slam.maps import TiledHitMaps
from mcnkit.slam.motion import MotionNoise, NoiseScale, motion_std, sample_motion
from mcnkit.slam.proposal import match_information, proposal_covariance
from mcnkit.slam.raycast import ray_cast_counts, ray_cast_strips
from mcnkit.slam.refine import REFINE_RANGE_M, refine_poses
from mcnkit.slam.resample import effective_sample_size, low_variance_resample, normalize_log_weights
from mcnkit.slam.scanmatch import beam_points, match_particles, match_scans_to_map, score_poses
from mcnkit.slam.scanmotion import MotionGuess, MotionPrior, motion_covariance, sample_increments
from mcnkit.slam.selfhits import SelfHits
from mcnkit.slam.wholegraph import WholeGraphScans, WholeGraphStats, odometry_links, whole_log_graph
from mcnkit.slam.widesearch import seen_grid, tracking_grid, unknown_motion_match, wide_match
from mcnkit.types import Frame, GridSpec, LidarSpec, OccupancyGrid, TernaryMap, Trajectory

__all__ = ["FastSlam", "LogLikelihoodHook", "SlamStep", "counts_to_grid"]

F64 = NDArray[np.float64]
LogLikelihoodHook = Callable[[NDArray[np.float64], NDArray[np.float64]], NDArray[np.float64]]
"""``hook(poses (N, 3), end_points_base (M, 2)) -> (N,)`` extra log-likelihood per particle at a filter update."""

_MAX_SWEEP_MOTION = (0.5, 0.5)  # m, rad: more within one sweep is an odometry jump, not a motion to undo


@dataclass(frozen=True)
class SlamStep:
    """What one :meth:`FastSlam.step` did: particle states after the step and the filter's bookkeeping."""

    index: int
    """Scan number (0-based)."""
    stamp_ns: int
    poses: F64
    """Particle base poses (N, 3) ``[x_m, y_m, yaw_rad]`` after this step."""
    weights: F64
    """Normalised (flattened) weights (N,) after this step."""
    neff: float
    """Effective sample size computed at the last filter update (before any resampling)."""
    updated: bool
    """True when this scan triggered a filter update (match, weigh, resample?, map write)."""
    resampled: bool
    best_index: int
    """The particle with the highest accumulated log-likelihood."""
    best_pose: F64
    match_scores: F64 | None = None
    """Scan-match score per particle (N,) when ``updated`` (None on the first scan and between updates)."""


def counts_to_grid(
    spec: GridSpec, hits: NDArray[np.integer], passes: NDArray[np.integer], occ_thresh: float
) -> OccupancyGrid:
    """Hit/pass counts → log-odds grid whose sign is the map_server decision at ``occ_thresh``.

    ``log_odds = logit(p) - logit(occ_thresh)`` with ``p = hits / (hits + passes)`` clipped to
    [0.001, 0.999]: positive (occupied) iff ``p > occ_thresh``, exactly 0 (unknown) where nothing was seen.
    """
    total = passes.astype(np.float32)
    total += hits
    seen = total > 0
    log_odds = np.zeros(spec.shape, np.float32)
    p = hits[seen] / total[seen]  # only seen cells: less memory than whole-grid temporaries
    del total
    np.clip(p, 1e-3, 1 - 1e-3, out=p)
    lo = np.log(p / (1 - p)) - np.float32(math.log(occ_thresh / (1 - occ_thresh)))
    lo[lo == 0] = -1e-3
    log_odds[seen] = lo
    return OccupancyGrid(spec, log_odds)


class FastSlam:
    """Grid FastSLAM with a scan-matched proposal; feed it frames in time order with :meth:`step`."""

    def __init__(self, config: SlamConfig, rng: np.random.Generator, lidar: LidarSpec | None = None) -> None:
        self.config = config
        self.rng = rng
        self._noise = MotionNoise(config.motion.srr, config.motion.srt, config.motion.str_, config.motion.stt)
        self.noise_scale = NoiseScale(config.motion.noise_window, min_scale=config.motion.noise_min_scale)
        """How much of the motion model's noise this log's odometry needs (``SlamConfig.motion_noise_from_log``)."""
        self._lidar = lidar
        n = config.n_particles
        self.maps = TiledHitMaps(n, config.resolution_m, config.map.tile_cells)
        self.poses = np.zeros((n, 3))
        self.log_weights = np.zeros(n)  # since the last resampling
        self.log_weight_sums = np.zeros(n)  # over the whole ancestry: picks the best particle
        self.neff = float(n)
        self.n_scans = 0
        self.n_updates = 0
        self.n_resamples = 0
        self.n_loop_corrections = 0
        self.n_wide_jumps = 0
        self.n_unknown_motion = 0
        """Scans whose motion no odometry gave (``Frame.odom_known`` False, or ``motion.odometry`` ignored), found
        by scan matching around the motion prior."""
        self.n_odometry_rejected = 0
        """Scans whose odometry the wide search found far off (a wheel slipped): their motion was found like that of
        a scan without odometry."""
        self.prior = MotionPrior(config.motion.prior_window,
                                 np.array([config.motion.unknown_window_m / 3] * 2 + [config.motion.unknown_window_rad / 3]),
                                 np.array([config.motion.prior_min_sigma_m] * 2 + [config.motion.prior_min_sigma_rad]))
        """The robot's recent tracked motion: what a scan's motion is searched around where no odometry gives it."""
        self.whole_graph_stats: WholeGraphStats | None = None
        """What the last whole-log graph used (``OfflineConfig``): None until one was solved."""
        self.self_hits = SelfHits(config.matching.self_hit_m, config.matching.self_hit_tolerance_m)
        """The robot's own returns (``MatchingConfig.self_hit_m``), dropped from every scan before it is used."""
        self._last_odom = np.zeros(3)
        self._linear_m = 0.0
        self._angular_rad = 0.0
        self._history = np.zeros((64, n, 3))  # (K, N, 3) corrected poses at updates, per lineage
        self._update_odom: list[F64] = []
        self._update_ranges: list[NDArray[np.float32]] = []
        self._scan_stamps: list[int] = []
        self._scan_odom: list[F64] = []
        self._scan_odom_used: list[bool] = []  # the odometry gave the motion from the scan before (OfflineConfig)
        self._scan_update: list[int] = []  # index of the last update at or before each scan
        self._scan_ranges: list[NDArray[np.float32]] = []  # every scan, for trajectory(mode="matched")
        self._scan_online: list[F64] = []  # the online pose of every scan (see SlamConfig.track_every_scan)
        # the robot's motion over the last scan, in its own frame: what a scan whose motion the log does not hold is
        # predicted from (not the difference of two online poses: the best particle may change between them)
        self._last_motion = np.zeros(3)
        self._fresh_scan = 0  # the last scan whose odometry differed from the scan's before (see _after_stall)
        self._scan_tracked: list[F64] = []  # that pose relative to the best particle's last update pose
        self._update_hits: list[F64] = []  # hit points (M, 2) of every update scan, base frame
        self._update_tracked: list[F64] = []  # the online pose at every update (where tracking restarts)
        self._grid: LikelihoodGrid | None = None  # the best particle's map near the robot, for the wide search
        # the same with the cells no scan has seen explaining motion.unseen_explains, for the unknown-motion search
        # (made when first needed after each update), and the best particle's ray-cast counts it is read from
        self._grid_seen: LikelihoodGrid | None = None
        self._seen: LineageMap | None = None
        self.loops = LoopCloser(config, config.resolution_m)
        """The pose graph over the filter updates that closes loops (see :mod:`mcnkit.slam.loops`)."""
        self.extra_log_likelihood: LogLikelihoodHook | None = None
        """Optional term added to every particle's log-weight at each filter update, after scan matching and
        before normalisation (MCN-SLAM's completion-based weighting uses it); None: gmapping's weights only."""

    @property
    def lidar(self) -> LidarSpec | None:
        """The scanner of the first frame (None before it)."""
        return self._lidar

    @property
    def update_ranges(self) -> Sequence[NDArray[np.float32]]:
        """The ranges of every filter-update scan so far, in order (do not modify)."""
        return self._update_ranges

    def ranking(self) -> NDArray[np.int64]:
        """Particle indices from the best (highest log-likelihood over its ancestry) to the worst."""
        return np.argsort(-self.log_weight_sums, kind="stable")

    def beam_limits(self) -> tuple[float, float]:
        """``(max_range_m, map_range_m)`` of the maps' ray casting (needs the first frame): beams longer than the
        first are skipped; longer than the second, they clear space up to it and mark no hit."""
        if self._lidar is None:
            raise RuntimeError("no scan processed yet")
        max_range, _ = self._ranges(self._lidar)
        return max_range, self.config.map_range(self._lidar)

    @property
    def lidar_only(self) -> bool:
        """True when no odometry reached the filter: ignored (``motion.odometry``), or missing from every scan."""
        return self.config.motion.odometry == "ignore" or (self.n_scans > 1 and self.n_unknown_motion == self.n_scans - 1)

    def odometry_note(self) -> str | None:
        """One line on the steps whose motion came from the scans alone where the log has odometry (gaps, jumps,
        slips), or None when there were none or the run was lidar-only."""
        if self.lidar_only or not (self.n_unknown_motion or self.n_odometry_rejected):
            return None
        return (f"odometry: {self.n_unknown_motion + self.n_odometry_rejected} of {max(self.n_scans - 1, 1)} steps had "
                f"none the filter could use ({self.n_unknown_motion} missing in the log, {self.n_odometry_rejected} "
                "contradicted by the scans): their motion was found from the scans alone")

    def notes(self) -> list[str]:
        """The lines a finished run reports: :meth:`odometry_note` and :meth:`self_hit_note` where they say
        something."""
        return [n for n in (self.odometry_note(), self.self_hit_note()) if n is not None]

    def self_hit_note(self) -> str | None:
        """One line on the returns of the robot's own body that were dropped, or None when there were none."""
        hits = self.self_hits
        if not hits.n_dropped:
            return None
        beams, released = hits.beams, hits.released
        parts = []
        if len(beams):
            listed = ", ".join(str(b) for b in beams[:8]) + (", ..." if len(beams) > 8 else "")
            parts.append(f"{len(beams)} beam{'s' * (len(beams) != 1)} ({listed}) return within {self.config.matching.self_hit_m:g} m at one "
                         "range while it moves")
        if len(released):
            parts.append(f"{len(released)} beam{'s' * (len(released) != 1)} taken for it until its returns moved")
        return (f"the robot's own body: {'; '.join(parts)}; {hits.n_dropped} returns taken for it were dropped "
                "(--slam.matching.self-hit-m 0 keeps them)")

    @property
    def best_index(self) -> int:
        """Particle with the highest log-likelihood summed over its ancestry."""
        return int(np.argmax(self.log_weight_sums))

    def _ranges(self, lidar: LidarSpec) -> tuple[float, float]:
        max_range = self.config.matching.max_range_m if self.config.matching.max_range_m is not None else lidar.range_max_m - 0.01
        usable = self.config.matching.max_usable_range_m if self.config.matching.max_usable_range_m is not None else max_range
        return max_range, min(usable, max_range)

    def _beams(self, frame: Frame) -> tuple[F64, F64, F64]:
        """End points and back points (M', 2) of the usable beams that scan matching uses (thinned to one end point
        per ``match_thin_m`` square), and the end points (M, 2) of all usable beams (the map's hits); base frame."""
        lidar = frame.scan.spec
        max_range, usable = self._ranges(lidar)
        end, back = beam_points(frame.scan.ranges_m, lidar.angles_rad, lidar.base_to_laser.as_array(), max_range,
                                usable, math.sqrt(2.0) * self.config.resolution_m, self.config.matching.lskip)
        hits = end
        if self.config.matching.lskip:
            hits, _ = beam_points(frame.scan.ranges_m, lidar.angles_rad, lidar.base_to_laser.as_array(), max_range,
                                  usable, 0.0)
        if self.config.matching.thin_m > 0 and len(end):
            keys = np.floor(end / self.config.matching.thin_m).astype(np.int64)
            _, first = np.unique(keys[:, 0] * 1_000_003 + keys[:, 1], return_index=True)
            keep = np.sort(first)
            end, back = np.ascontiguousarray(end[keep]), np.ascontiguousarray(back[keep])
        return end, back, hits

    def step(self, frame: Frame) -> SlamStep:
        """Processes one frame: tracking, motion, and a filter update when the robot moved far enough."""
        cfg = self.config
        if self._lidar is None:
            self._lidar = frame.scan.spec
        valid = frame.scan.valid
        if not valid.all():  # REP 117: below range_min (too close, a driver's error code) or beyond range_max: none
            frame = replace(frame, scan=replace(frame.scan, ranges_m=np.where(valid, frame.scan.ranges_m, np.nan)))
        if cfg.matching.self_hit_m > 0:
            moved = self._last_motion  # over the previous step: this one's is found below, from the filtered scan
            ranges = self.self_hits.filter(frame.scan.ranges_m, math.hypot(moved[0], moved[1]), abs(float(moved[2])))
            frame = replace(frame, scan=replace(frame.scan, ranges_m=ranges))
        first = self.n_scans == 0
        known = frame.odom_known and cfg.motion.odometry == "use"
        # ignored odometry stays frozen where the first scan was (nothing of it reaches the filter)
        odom = frame.odom.as_array() if cfg.motion.odometry == "use" else (np.zeros(3) if first else self._last_odom)
        move = relative(self._last_odom, odom)
        step_move = self._after_stall(move) if known and not first else move  # the odometry's step, where it applies
        if cfg.matching.deskew and frame.scan.spec.time_increment_s and not first:
            frame = self._deskewed(frame, step_move if known else None)
        beams = self._beams(frame)
        odom_used = False
        if first:
            self.poses[:] = odom
            tracked = odom.copy()
        else:
            residual = None  # this step's odometry against its scan-matched motion (the noise floor)
            dt_s = (frame.stamp_ns - self._scan_stamps[-1]) * 1e-9
            guess = self.prior.predict(dt_s if dt_s > 0 else None)
            found = self._track(beams, odom, step_move) if known else None
            cov = None  # the spread of a motion found from the scans alone
            if found is not None and cfg.motion.check_odometry and self._unlike_prior(step_move, guess):  # slipping wheels?
                alt, alt_cov = self._track_unknown_motion(beams, odom, guess)
                scans_say = alt if self._explains_better(alt, found, beams) else found
                if not self._unlike_prior(relative(self._scan_online[-1], scans_say), guess):  # as the robot went
                    found, tracked, cov = None, scans_say, alt_cov
            odom_used = found is not None
            if found is not None:
                tracked = found
                self._last_motion = relative(self._scan_online[-1], tracked)
                if cfg.motion.noise_from_log and cfg.matching.track_every_scan:
                    residual = self.noise_scale.add(step_move, self._last_motion, self._noise)
            else:  # no odometry for this motion, or one the scans contradict: found from the scans alone
                self.n_odometry_rejected += int(known)
                self.n_unknown_motion += int(not known)
                if cov is None:  # where odometry was rejected the robot did something unusual: no steps' density
                    tracked, cov = self._track_unknown_motion(beams, odom, guess, usual=not known)
                self._last_motion = move = relative(self._scan_online[-1], tracked)
            self.prior.add(self._last_motion, dt_s, guess)
            self._linear_m += math.hypot(move[0], move[1])
            self._angular_rad += abs(move[2])
            if cov is not None:  # the particles spread by what the match left undetermined
                self.poses = sample_increments(self.poses, self._last_motion, cov, self.rng)
            else:
                if cfg.motion.from_tracking and cfg.matching.track_every_scan:  # the scan-matched motion moves them
                    before, after = self._scan_online[-1], tracked
                else:
                    before, after = self._last_odom, odom
                noise = (self.noise_scale.noise(self._noise, residual if cfg.motion.noise_step_floor else None)
                         if cfg.motion.noise_from_log else self._noise)
                self.poses = sample_motion(self.poses, before, after, noise, self.rng)
        if first or not known or not np.array_equal(odom, self._last_odom):
            self._fresh_scan = self.n_scans  # this scan's odometry is new (or there is none to stall)
        self._last_odom = odom
        updated = first or self._linear_m >= cfg.updates.linear_m or self._angular_rad >= cfg.updates.angular_rad
        resampled = False
        scores = None
        if updated:
            resampled, scores = self._update(frame, first, beams, tracked)
        online = self.poses[self.best_index].copy() if updated else tracked
        self._scan_online.append(online)
        self._scan_tracked.append(relative(self._history[self.n_updates - 1, self.best_index], online))
        self._scan_stamps.append(frame.stamp_ns)
        self._scan_odom.append(odom)
        self._scan_odom_used.append(odom_used)
        self._scan_update.append(self.n_updates - 1)
        self._scan_ranges.append(np.asarray(frame.scan.ranges_m, dtype=np.float32))
        self.n_scans += 1
        best = self.best_index
        return SlamStep(
            self.n_scans - 1,
            frame.stamp_ns,
            self.poses.copy(),
            normalize_log_weights(self.log_weights, cfg.gain),
            self.neff,
            updated,
            resampled,
            best,
            self.poses[best].copy(),
            scores,
        )

    def _deskewed(self, frame: Frame, odometry_step: F64 | None) -> Frame:
        """``frame`` with its scan deskewed (:func:`~mcnkit.slam.deskew.deskew_ranges`): the robot moving through
        the sweep at its velocity since the scan before, by the odometry's step where it has one (``odometry_step``,
        as :meth:`_after_stall` applies it), else by the scans (the tracked motion of the step before).  As logged
        where that velocity would turn or move the robot more than ``_MAX_SWEEP_MOTION`` within the sweep (an
        odometry jump, not a motion)."""
        if odometry_step is not None:
            dt_s, motion = (frame.stamp_ns - self._scan_stamps[-1]) * 1e-9, odometry_step
        elif len(self._scan_stamps) >= 2:
            dt_s, motion = (self._scan_stamps[-1] - self._scan_stamps[-2]) * 1e-9, self._last_motion
        else:
            return frame
        spec = frame.scan.spec
        if dt_s <= 0:
            return frame
        velocity = motion / dt_s
        sweep = float(spec.beam_times_s.max()) * velocity
        if math.hypot(sweep[0], sweep[1]) > _MAX_SWEEP_MOTION[0] or abs(float(sweep[2])) > _MAX_SWEEP_MOTION[1]:
            return frame
        return replace(frame, scan=replace(frame.scan, ranges_m=deskew_ranges(frame.scan.ranges_m, spec, velocity)))

    def _after_stall(self, move: F64) -> F64:
        """The odometry's step ``move`` as applied from the pose of the scan where the odometry last changed.

        Odometry that stalls (repeats its pose for a few scans while the scans see the robot move: a driver that
        missed its messages) and then catches up holds the stalled scans' motion in one step; applied from the last
        pose, which the scan matching already moved through the stall, it overshoots by all of it (MIT CSAIL's
        odometry stands still for four scans while the robot turns 60°, then turns 85° in one).  Applied from the
        pose before the stall it predicts where the robot is.  Unchanged where the odometry did not stall, or where
        the robot did not move while it did (a robot at rest)."""
        stalled_from = self._fresh_scan
        if stalled_from >= self.n_scans - 1 or not move.any():
            return move
        since = relative(self._scan_online[stalled_from], self._scan_online[-1])
        if math.hypot(since[0], since[1]) < self.config.resolution_m and abs(float(since[2])) < math.radians(1.0):
            return move
        return relative(self._scan_online[-1], compose(self._scan_online[stalled_from], move))

    def _from_update(self, odom: F64) -> F64:
        """gmapping's pose at this scan: the best particle's pose at the last update plus the odometry since."""
        return compose(self._history[self.n_updates - 1, self.best_index], relative(self._update_odom[-1], odom))

    def _track(self, beams: tuple[F64, F64, F64], odom: F64, move: F64) -> F64 | None:
        """The best particle's pose at this scan as known online (see ``SlamConfig.track_every_scan``); None when
        the wide search finds the scan far from where the odometry puts it (the odometry slipped or lied: the
        step's motion is then found from the scans alone, as where the log holds none)."""
        cfg = self.config
        best = self.best_index
        from_update = self._from_update(odom)
        if not cfg.matching.track_every_scan:
            return from_update
        # Two starts: the previous scan's tracked pose moved by odometry (close, but may drift where the
        # geometry is degenerate) and gmapping's pose (no drift, but up to an interval of odometry error away).
        # Both are hill-climbed; the better-scoring match is kept.  When the wide search finds the first far
        # from where odometry put it, it starts from there instead (odometry that is far off).
        from_last = compose(self._scan_online[-1], move)
        end_b, back_b, _ = beams
        if cfg.wide.search and self._grid is not None:
            found = wide_match(self._grid, from_last, end_b, cfg, motion_std(move, self._noise),
                               math.hypot(move[0], move[1]), abs(float(move[2])))
            if found is not None and found[1]:  # far from the odometry's prediction
                self.n_wide_jumps += 1
                return None
            if found is not None:  # the scan's best pose on the coarse field: a better start than odometry's
                from_last = found[0]
        starts = np.stack([from_last, from_update])
        matched = match_scans_to_map(self.maps, best, starts, [(end_b, back_b)] * 2, cfg)
        scores, _ = score_poses(self.maps, best, matched, end_b, back_b, cfg)
        return matched[0] if scores[0] > 1.05 * scores[1] else matched[1]  # near-ties go to the drift-free start

    def _unlike_prior(self, move: F64, guess: MotionGuess) -> bool:
        """The odometry's step lies beyond the motion prior's reach (its penalty in
        :func:`mcnkit.slam.widesearch.unknown_motion_match` at the cap: about 3σ of what the robot has been doing)."""
        d = (move - guess.mean) / guess.sigma
        d[2] = float((move[2] - guess.mean[2] + np.pi) % (2 * np.pi) - np.pi) / guess.sigma[2]
        return 0.5 * float(d @ d) > self.config.updates.proposal_beams * math.log(1.0 / self.config.wide.jump_ratio)

    def _explains_better(self, pose: F64, other: F64, beams: tuple[F64, F64, F64]) -> bool:
        """``pose`` explains the scan clearly better than ``other`` on the best particle's map (the same margin as
        between the tracking's two starts: near-ties go to ``other``)."""
        end_b, back_b, _ = beams
        scores, _ = score_poses(self.maps, self.best_index, np.stack([pose, other]), end_b, back_b, self.config)
        return bool(scores[0] > 1.05 * scores[1])

    def _track_unknown_motion(self, beams: tuple[F64, F64, F64], odom: F64, guess: MotionGuess,
                              usual: bool = False) -> tuple[F64, F64]:
        """The best particle's pose at a scan whose motion no odometry gives, and the covariance (3, 3; robot frame)
        of that motion: searched around where the motion prior predicts it (``guess``; see
        ``motion.unknown_window_m``), then hill-climbed; its spread is the match's uncertainty combined with the
        prior's (:func:`mcnkit.slam.scanmotion.motion_covariance`).  ``usual``: the step is one of the robot's usual
        ones (the log holds no odometry for it), so the density of its recent steps weighs the poses
        (:func:`~mcnkit.slam.widesearch.unknown_motion_match`) and the returns where no scan has looked count as
        ``motion.unseen_explains`` (:meth:`_search_grid`); off where the scans contradicted the odometry, a slip or
        a jump, which the robot's usual steps do not foretell."""
        cfg = self.config
        prior_cov = np.diag(guess.sigma**2)
        if not cfg.matching.track_every_scan:
            return self._from_update(odom), prior_cov
        before = self._scan_online[-1]
        start = compose(before, guess.mean)
        end_b, back_b, _ = beams
        if self._grid is not None:
            reach = self.prior.reach(cfg.motion.unknown_window_m, cfg.motion.unknown_window_rad)
            grid = self._search_grid() if usual else self._grid  # a slip or jump: the map as it stands
            found = unknown_motion_match(grid, before, guess, reach, end_b, cfg, density=usual)
            if found is not None:
                start = found
        tracked = match_scans_to_map(self.maps, self.best_index, start[None, :], [(end_b, back_b)], cfg)[0]
        if self._grid is None:
            return tracked, prior_cov
        info = match_information(self._grid, end_b, tracked, cfg.updates.proposal_beams)
        # the particles spread by what the match leaves open, never wider than the motion model for that motion
        spread = np.minimum(guess.sigma, np.maximum(motion_std(relative(before, tracked), self._noise), self.prior.min_sigma))
        return tracked, motion_covariance(info, float(before[2]), spread)

    def _search_grid(self) -> LikelihoodGrid:
        """The wide-search grid of the unknown-motion search: :attr:`_grid`, with ``motion.unseen_explains`` the
        cells that none of the best particle's update scans has passed through or ended in explaining that much
        (:func:`mcnkit.slam.widesearch.seen_grid`).  The counts are kept by differences
        (:class:`~mcnkit.slam.lineage.LineageMap`) and the grid made once per filter update, when first needed."""
        assert self._grid is not None and self._lidar is not None
        cfg = self.config
        if cfg.motion.unseen_explains <= 0.0:
            return self._grid
        if self._grid_seen is None:
            if self._seen is None:
                max_range, usable = self.beam_limits()
                self._seen = LineageMap(cfg.wide.resolution_m, self._lidar.angles_rad,
                                        self._lidar.base_to_laser.as_array(), max_range_m=max_range,
                                        usable_m=usable, occ_thresh=cfg.map.occ_thresh)
            self._seen.sync(self.update_poses(self.best_index), self._update_ranges)
            self._grid_seen = seen_grid(self._grid, self._seen, cfg.motion.unseen_explains)
        return self._grid_seen

    def _update(self, frame: Frame, first: bool, beams: tuple[F64, F64, F64], tracked: F64) -> tuple[bool, F64 | None]:
        cfg = self.config
        end_b, back_b, hits_b = beams
        scores = None
        grid_before = self._grid  # the best particle's map before this update (None without the wide search)
        if not first:
            if cfg.motion.from_tracking and cfg.matching.track_every_scan:
                delta = relative(self._update_tracked[-1], tracked)
            else:
                delta = relative(self._update_odom[-1], self._last_odom)
            best = self.best_index
            nominal = compose(self._history[self.n_updates - 1], delta)  # (N, 3) noise-free predictions
            sigma = motion_std(delta, self._noise)
            found = None
            if cfg.wide.search and self._grid is not None:
                found = wide_match(self._grid, nominal[best], end_b, cfg, sigma, self._linear_m, self._angular_rad)
            if cfg.updates.proposal == "improved":
                # every particle starts from its own prediction moved like the best one's onto the mode
                start = nominal if found is None else compose(found[0], relative(nominal[best], nominal))
                match = match_particles(self.maps, start, end_b, back_b, cfg)
                cov = (proposal_covariance(self._grid, end_b, match.poses[best], sigma, cfg.updates.proposal_beams)
                       if self._grid is not None else np.diag(sigma**2))
                draw = self.rng.multivariate_normal(np.zeros(3), cov, size=cfg.n_particles, method="cholesky")
                self.poses = match.poses + draw
                self.poses[:, 2] = (self.poses[:, 2] + np.pi) % (2 * np.pi) - np.pi
                self.n_wide_jumps += int(found is not None and found[1])
            else:
                if found is not None and (found[1] or cfg.wide.recentre):
                    # the cloud moves so that the best particle's prediction lands on the mode
                    self.poses = compose(found[0], relative(nominal[best], self.poses))
                    self.n_wide_jumps += int(found[1])
                match = match_particles(self.maps, self.poses, end_b, back_b, cfg)
                self.poses = match.poses
            extra = match.log_likelihoods
            if self.extra_log_likelihood is not None:
                extra = extra + np.asarray(self.extra_log_likelihood(self.poses, end_b), np.float64)
            self.log_weights += extra
            self.log_weight_sums += extra
            scores = match.scores
        weights = normalize_log_weights(self.log_weights, cfg.gain)
        self.neff = effective_sample_size(weights)
        k = self.n_updates
        if k == len(self._history):
            self._history = np.concatenate([self._history, np.zeros_like(self._history)])
        self._history[k] = self.poses
        resampled = False
        if not first and self.neff < cfg.updates.resample_threshold * cfg.n_particles:
            idx = low_variance_resample(weights, float(self.rng.random()))
            self.poses = self.poses[idx]
            self.log_weights = np.zeros(cfg.n_particles)
            self.log_weight_sums = self.log_weight_sums[idx]
            self._history[: k + 1] = self._history[: k + 1, idx]
            self.maps.resample(idx)
            self.n_resamples += 1
            resampled = True
        hits_w = compose(self.poses[:, None, :], np.concatenate([hits_b, np.zeros((len(hits_b), 1))], axis=1))
        self.maps.integrate(hits_w[..., 0], hits_w[..., 1])  # (N, M) end points of every particle
        self._update_odom.append(self._last_odom.copy())
        self._update_ranges.append(np.asarray(frame.scan.ranges_m, dtype=np.float32).copy())
        self._update_hits.append(hits_b)
        self._linear_m = 0.0
        self._angular_rad = 0.0
        self.n_updates += 1
        corrected = self.loops.add(hits_b, self._history[: self.n_updates, self.best_index], grid_before)
        if corrected is not None:
            self._reanchor(corrected)
        best = self.best_index
        self._update_tracked.append(self.poses[best].copy())
        if cfg.wide.search:
            self._grid = tracking_grid(self.maps, best, self.poses[best], cfg)
            self._grid_seen = None
        return resampled, scores

    def _reanchor(self, corrected: F64) -> None:
        """Puts every particle on the solved trajectory (K, 3): the ancestry of all becomes the solution, each
        particle keeps its offset from the best at the newest update, and the maps are rebuilt on it (unless no
        update moved by more than a quarter cell and 0.1°: then the maps stand as they are)."""
        k = self.n_updates
        best = self.best_index
        change = corrected - self._history[:k, best]
        moved = (np.hypot(change[:, 0], change[:, 1]).max() > 0.25 * self.config.resolution_m
                 or np.abs((change[:, 2] + np.pi) % (2 * np.pi) - np.pi).max() > math.radians(0.1))
        offsets = relative(self._history[k - 1, best], self._history[k - 1])  # (N, 3)
        self._history[: k - 1] = corrected[: k - 1, None, :]
        self.poses = compose(corrected[k - 1], offsets)
        self._history[k - 1] = self.poses
        if not moved:
            return
        counts = [len(h) for h in self._update_hits]
        node = np.repeat(np.arange(k), counts)
        hits = np.concatenate(self._update_hits) if counts else np.zeros((0, 2))
        c, s = np.cos(corrected[node, 2]), np.sin(corrected[node, 2])
        x = corrected[node, 0] + c * hits[:, 0] - s * hits[:, 1]
        y = corrected[node, 1] + s * hits[:, 0] + c * hits[:, 1]
        self.maps.rebuild_shared(x, y)
        self.n_loop_corrections += 1

    def update_poses(self, particle: int | None = None) -> F64:
        """Corrected poses (K, 3) at the K filter updates along a particle's ancestry (default: the best)."""
        p = self.best_index if particle is None else particle
        return self._history[: self.n_updates, p].copy()

    def trajectory(self, particle: int | None = None, mode: str = "tracked") -> Trajectory:
        """Pose at every scan so far along a particle's ancestry (default: the best particle).

        * ``"tracked"`` (default): the particle's corrected pose at each filter update (its ancestry, as in
          ``"gmapping"``) and, in between, that pose moved by the scan-to-map tracking done online
          (``SlamConfig.track_every_scan``) instead of by raw odometry;
        * ``"online"``: what the filter reported at each scan, as it ran: the corrected pose at updates and, in
          between, the best particle's pose tracked scan by scan against its map (``SlamConfig.track_every_scan``;
          gmapping's convention when that is off).  Causal; ``particle`` does not apply;
        * ``"gmapping"`` (gmapping's convention): the last corrected update pose plus the odometry change since;
        * ``"smoothed"`` (offline): between two updates, blends that forward estimate with the next corrected
          pose minus the odometry still to come, in proportion to the motion (metres + radians) already made
          in the interval, so each correction is spread over its interval instead of jumping;
        * ``"matched"`` (offline): the smoothed pose of every scan hill-climbed against the particle's final
          map (the update scans included), as gmapping matches at updates, without touching weights or maps;
        * ``"refined"`` (offline): the tracked poses with every scan moved onto the map of all the other scans,
          later ones included (:func:`mcnkit.slam.refine.refine_poses`), the filter updates first solved again as
          one graph over the whole log when ``OfflineConfig.whole_graph`` is on (:mod:`mcnkit.slam.wholegraph`);
          what ``mcnkit slam`` writes as ``trajectory.tum``.
        """
        modes = ("tracked", "online", "gmapping", "smoothed", "matched", "refined")
        if mode not in modes:
            raise ValueError(f"mode must be one of {modes}, got {mode!r}")
        if mode == "online":
            if particle is not None:
                raise ValueError("the online trajectory is the best particle's as it was at each scan; pass no particle")
            return Trajectory(np.asarray(self._scan_stamps, dtype=np.int64), np.asarray(self._scan_online))
        upd = self.update_poses(particle)
        k = np.asarray(self._scan_update, dtype=np.int64)
        if mode in ("tracked", "refined"):
            stamps = np.asarray(self._scan_stamps, dtype=np.int64)
            tracked = compose(upd[k], np.asarray(self._scan_tracked))
            return Trajectory(stamps, self._refine(tracked) if mode == "refined" else tracked)
        odom = np.asarray(self._scan_odom)
        upd_odom = np.asarray(self._update_odom)
        poses = compose(upd[k], relative(upd_odom[k], odom))
        if mode != "gmapping" and len(upd) > 1:
            steps = np.zeros(len(odom))
            d = relative(odom[:-1], odom[1:])
            steps[1:] = np.hypot(d[:, 0], d[:, 1]) + np.abs(d[:, 2])
            progress = np.cumsum(steps)  # motion so far along the log
            first_scan = np.flatnonzero(np.r_[True, k[1:] != k[:-1]])  # scan index of each update
            inner = k < len(upd) - 1  # scans with a next update
            nxt = np.minimum(k + 1, len(upd) - 1)
            span = progress[first_scan[nxt]] - progress[first_scan[k]]
            alpha = np.where(span > 0, (progress - progress[first_scan[k]]) / np.maximum(span, 1e-12), 0.0)
            backward = compose(upd[nxt], relative(upd_odom[nxt], odom))
            diff = backward - poses
            diff[:, 2] = (diff[:, 2] + np.pi) % (2 * np.pi) - np.pi
            poses = np.where(inner[:, None], poses + alpha[:, None] * diff, poses)
            poses[:, 2] = (poses[:, 2] + np.pi) % (2 * np.pi) - np.pi
        if mode == "matched" and self._lidar is not None:
            poses = self._match_scans(self.best_index if particle is None else particle, poses)
        return Trajectory(np.asarray(self._scan_stamps, dtype=np.int64), poses)

    def _refine(self, poses: F64) -> F64:
        lidar = self._lidar
        if lidar is None:
            return poses
        max_range, usable = self._ranges(lidar)
        if self.config.offline.whole_graph:
            poses = self._whole_graph(poses, lidar, min(max_range, usable))
        laser = lidar.base_to_laser.as_array()
        returns = (beam_points(r, lidar.angles_rad, laser, max_range, min(usable, REFINE_RANGE_M), 0.0)[0]
                   for r in self._scan_ranges)
        return refine_poses(poses, returns, self.config.resolution_m)

    def _whole_graph(self, poses: F64, lidar: LidarSpec, max_range_m: float) -> F64:
        """``poses`` (one per scan) with the filter updates re-solved as one graph over the whole log
        (:func:`mcnkit.slam.wholegraph.whole_log_graph`) and every other scan kept at its offset from the update
        before it."""
        nodes = self.update_scans()
        cfg = self.config.offline
        links = odometry_links(nodes, np.asarray(self._scan_odom_used, bool))
        scans = WholeGraphScans([self._scan_ranges[k] for k in nodes], lidar.angles_rad,
                                lidar.base_to_laser.as_array(), min(max_range_m, cfg.max_range_m))
        solved, self.whole_graph_stats = whole_log_graph(poses[nodes], scans, np.asarray(self._scan_odom)[nodes],
                                                         links, cfg)
        update_of = np.asarray(self._scan_update, np.int64)
        owner = nodes[update_of]  # each scan's update, as a scan index
        return compose(solved[update_of], relative(poses[owner], poses))

    def _match_scans(self, particle: int, poses: F64) -> F64:
        lidar = self._lidar
        assert lidar is not None
        max_range, usable = self._ranges(lidar)
        back_m = math.sqrt(2.0) * self.config.resolution_m
        laser = lidar.base_to_laser.as_array()
        out = poses.copy()
        chunk = 50  # beams of 50 scans at a time: memory stays flat on long logs
        for start in range(0, len(out), chunk):
            scans = [
                beam_points(r, lidar.angles_rad, laser, max_range, usable, back_m, self.config.matching.lskip)
                for r in self._scan_ranges[start : start + chunk]
            ]
            out[start : start + chunk] = match_scans_to_map(
                self.maps, particle, out[start : start + chunk], scans, self.config, chunk
            )
        return out

    def best_map(self, particle: int | None = None) -> OccupancyGrid:
        """The output map: update scans ray-cast from a particle's corrected poses (default: the best)."""
        if self._lidar is None or not self.n_updates:
            raise RuntimeError("no scan processed yet")
        lidar = self._lidar
        max_range, usable = self.beam_limits()
        laser = compose(self.update_poses(particle), lidar.base_to_laser.as_array())
        spec, hits, passes = ray_cast_counts(
            laser, np.stack(self._update_ranges), lidar.angles_rad, max_range, usable, self.config.resolution_m
        )
        return counts_to_grid(spec, hits, passes, self.config.map.occ_thresh)

    def update_scans(self) -> NDArray[np.int64]:
        """The index (K,) of the scan at which each filter update happened (into :meth:`trajectory`'s poses)."""
        k = np.asarray(self._scan_update, dtype=np.int64)
        return np.flatnonzero(np.r_[True, k[1:] != k[:-1]]) if len(k) else np.zeros(0, np.int64)

    def best_map_strips(self, particle: int | None = None, strip_cells: int = 512, *,
                        poses: F64 | None = None) -> tuple[GridSpec, Iterator[
            tuple[int, NDArray[np.uint16], NDArray[np.uint16]]]]:
        """:meth:`best_map` as hit / pass count strips from the top down (bounded memory on large maps; see
        :func:`mcnkit.slam.raycast.ray_cast_strips`).  ``poses``: the base poses (K, 3) to cast the update scans
        from instead of the particle's corrected ones (e.g. the refined trajectory at :meth:`update_scans`)."""
        if self._lidar is None or not self.n_updates:
            raise RuntimeError("no scan processed yet")
        lidar = self._lidar
        max_range, usable = self.beam_limits()
        base = self.update_poses(particle) if poses is None else np.asarray(poses, np.float64)
        if base.shape != (self.n_updates, 3):
            raise ValueError(f"poses has shape {base.shape}, the map needs one pose per update: ({self.n_updates}, 3)")
        laser = compose(base, lidar.base_to_laser.as_array())
        return ray_cast_strips(laser, np.stack(self._update_ranges), lidar.angles_rad, max_range, usable,
                               self.config.resolution_m, strip_cells)

    def best_ternary(self, particle: int | None = None) -> TernaryMap:
        """:meth:`best_map` in the paper's ternary encoding (occupied above ``occ_thresh``)."""
        grid = self.best_map(particle)
        return TernaryMap(log_odds_to_ternary(grid.log_odds), grid.spec)
