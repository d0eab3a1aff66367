"""MCN-SLAM: grid FastSLAM that, at its filter updates, samples completions of the unseen part of the map.

:class:`McnSlam` wraps :class:`~mcnkit.slam.FastSlam`.  After each filter update it takes the ``R`` best
particles (highest log-likelihood over their ancestry), reads each one's map m_t from a
:class:`~mcnkit.slam.lineage.LineageMap` (kept up to date by differences, exactly the ray-cast map of that
particle's corrected poses), pools it onto a coarse window and draws ``K`` completions per particle with the
network, all ``R·K`` of them in **one** forward pass (dropout on: real samples).  The window is

* ``"map"`` (the paper): the whole map seen so far, padded square and shrunk to ``size × size`` cells (a thin
  wall survives: occupied > free > unknown in every window cell);
* ``"robot"``: a ``window_m`` square centred on the robot, for buildings too large for one 64 × 64 image.

Every completion comes back placed in metres (:class:`~mcnkit.types.GridSpec` of its window), with the mean of
the K samples and a per-cell uncertainty.  When the ground truth is known, the step is scored against it
(free space as the positive class, and mIoU on the cells unknown in m_t).

Beyond the paper, ``completion_weight > 0`` adds to every particle's log-weight at a filter update how well
the new scan's end points that fall in cells *unknown* in the particle's m_t agree with that particle's
completed map (``Σ log(ε + (1 − 2ε) · p_occupied)`` over those beams, times the weight).  It needs a map and a
completion for every particle, so it costs N lineages and an N-sized forward pass per update.
``benchmarks/bench_mcn_weighting.py`` measures whether it helps.

Example:
    >>> mcn = McnSlam(SlamConfig(), load_model("unet"), McnConfig(samples=4), np.random.default_rng(0))  # doctest: +SKIP
    >>> for frame in log.frames():                                                                        # doctest: +SKIP
    ...     result = mcn.step(frame)
    ...     if result.completion is not None:
    ...         result.completion.samples.shape        # (R, K, 64, 64)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch
from numpy.typing import NDArray

from mcnkit.completion.nets import CompletionNet
from mcnkit.completion.registry import MODELS, CheckpointError, default_weights_dir
from mcnkit.completion.sample import inference_net, label_entropy, sample_completions
from mcnkit.completion.scores import miou_unknown, score_maps
from mcnkit.geometry import compose
from mcnkit.grid import map_window, network_to_ternary, pool_to_window, ternary_to_network
from mcnkit.mcn_config import McnConfig
from mcnkit.slam.config import SlamConfig
from mcnkit.slam.fastslam import FastSlam, SlamStep
from mcnkit.slam.lineage import LineageMap
from mcnkit.types import OCCUPIED, UNKNOWN, Frame, GridSpec, TernaryMap

__all__ = ["MODELS", "Completion", "McnConfig", "McnSlam", "StepResult", "load_model", "map_window", "robot_window"]

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]
I64 = NDArray[np.int64]


def load_model(name_or_path: str | Path, device: str | torch.device = "cpu") -> CompletionNet:
    """A completion generator in eval mode: a short name of :data:`MODELS` or a checkpoint path."""
    from mcnkit.completion.checkpoint import checkpoint_paths, load_generator

    key = str(name_or_path)
    path = default_weights_dir() / MODELS[key] if key in MODELS else Path(key)
    if key not in MODELS and not any(p.exists() for p in checkpoint_paths(path)):
        raise CheckpointError(f"{key}: neither a shipped model ({', '.join(MODELS)}) nor a checkpoint "
                              "(NAME.safetensors + NAME.json)")
    net, _info = load_generator(path)
    return net.to(device).eval()


def robot_window(xy_m: F64, size: int, window_m: float) -> GridSpec:
    """A ``window_m`` square centred on ``xy_m`` on ``size``² cells."""
    return GridSpec(window_m / size, float(xy_m[0]) - window_m / 2, float(xy_m[1]) - window_m / 2, size, size)


@dataclass(frozen=True)
class Completion:
    """K sampled completions of the maps of the R best particles, each on its own window (placed in metres)."""

    particles: I64
    """Particle indices (R,), best first."""
    windows: tuple[GridSpec, ...]
    """Per rank, the coarse grid the network saw, placed in metres."""
    partial: F32
    """m_t of each particle on its window (R, S, S), ternary."""
    samples: F32
    """Sampled completions (R, K, S, S), ternary; cells seen in m_t keep their observed label."""
    mean: F32
    """Ternary map of the mean network output over the K samples (R, S, S)."""
    uncertainty: F32
    """Entropy of the K sampled labels per cell / log 3 (R, S, S), in [0, 1]."""

    def partial_map(self, rank: int = 0) -> TernaryMap:
        """m_t of a rank as a placed map."""
        return TernaryMap(self.partial[rank], self.windows[rank])

    def sample_map(self, rank: int = 0, k: int = 0) -> TernaryMap:
        """Sample ``k`` of a rank as a placed map."""
        return TernaryMap(self.samples[rank, k], self.windows[rank])

    def mean_map(self, rank: int = 0) -> TernaryMap:
        """The mean completion of a rank as a placed map."""
        return TernaryMap(self.mean[rank], self.windows[rank])

    @property
    def diversity(self) -> F32:
        """Per rank, the mean share of cells on which two samples differ (R,)."""
        from mcnkit.completion.sample import diversity

        return diversity(self.samples)


@dataclass(frozen=True)
class StepResult:
    """Everything one :meth:`McnSlam.step` produced; ``completion`` is None between completions."""

    slam: SlamStep
    completion: Completion | None = None
    best_map: TernaryMap | None = None
    """The best particle's m_t (cropped to what was seen; pooled when larger than ``full_map_max_cells``), when
    this step carries it."""
    scores: dict[str, float] = field(default_factory=dict)
    """Against the ground truth when known, for the best particle on its window: ``f_slam`` (F of m_t, free
    positive), ``f_completed`` (F of the mean completion), ``miou_unknown`` (mIoU of the mean completion on the
    cells unknown in m_t), ``miou_unknown_samples`` (mean over the samples)."""


def _copy_observed(output_ternary: F32, partial: F32) -> F32:
    """Completion with the observed cells of m_t put back (the network only fills the unknown)."""
    return np.where(partial == UNKNOWN, output_ternary, partial).astype(np.float32)


class McnSlam:
    """Grid FastSLAM + map completion network, one frame at a time (see the module docstring)."""

    def __init__(self, slam_config: SlamConfig, model: CompletionNet, config: McnConfig | None = None,
                 rng: np.random.Generator | None = None, *, generator: torch.Generator | None = None,
                 ground_truth: TernaryMap | None = None, device: str | torch.device = "cpu") -> None:
        self.config = config = config or McnConfig()
        self.slam = FastSlam(slam_config, rng if rng is not None else np.random.default_rng(0))
        self.model = model.eval()
        self.generator = generator if generator is not None else torch.Generator().manual_seed(0)
        self.ground_truth = ground_truth
        self.device = torch.device(device)
        n_lineages = slam_config.n_particles if config.completion_weight > 0 else min(config.ranks,
                                                                                        slam_config.n_particles)
        self._n_lineages = n_lineages
        self.lineages: list[LineageMap] = []
        self._slot_of: dict[int, int] = {}  # particle -> lineage slot at the last completion
        self.n_completions = 0
        self._weighting: tuple[F32, F32, tuple[GridSpec, ...]] | None = None  # p_occ, partial, windows per particle
        if config.completion_weight > 0:
            self.slam.extra_log_likelihood = self._completion_log_likelihood

    # -- public ---------------------------------------------------------------------------------------------

    def step(self, frame: Frame) -> StepResult:
        """Processes one frame; completes the maps when this frame triggered a (every-th) filter update."""
        s = self.slam.step(frame)
        if not s.updated:
            return StepResult(s)
        if not self.lineages:
            self._make_lineages()
        cfg = self.config
        due = (self.slam.n_updates - 1) % cfg.every == 0
        if cfg.completion_weight > 0:
            self._sync(np.arange(self.slam.config.n_particles))
            self._prepare_weighting()
        if not due:
            return StepResult(s)
        ranks = self.slam.ranking()[: cfg.ranks]
        slots = self._sync(ranks)
        completion = self._complete(ranks, slots)
        self.n_completions += 1
        best_map = None
        if cfg.full_map_every and (self.n_completions - 1) % cfg.full_map_every == 0:
            best_map = self.lineages[slots[0]].ternary(max_cells=cfg.full_map_max_cells)
        return StepResult(s, completion, best_map, self._score(completion))

    def best_ternary(self) -> TernaryMap:
        """The best particle's full-resolution map now (ray-cast from its corrected poses)."""
        return self.slam.best_ternary()

    # -- internals --------------------------------------------------------------------------------------------

    def _make_lineages(self) -> None:
        lidar = self.slam.lidar
        assert lidar is not None
        max_range, usable = self.slam.beam_limits()
        sc = self.slam.config
        self.lineages = [LineageMap(sc.resolution_m, lidar.angles_rad, lidar.base_to_laser.as_array(),
                                    max_range_m=max_range, usable_m=usable, occ_thresh=sc.map.occ_thresh)
                         for _ in range(self._n_lineages)]

    def _sync(self, particles: I64) -> list[int]:
        """Brings a lineage map to each particle's poses, choosing for each the slot that needs the fewest casts
        (all N slots map one-to-one when every particle has its own)."""
        ranges = self.slam.update_ranges
        if len(self.lineages) == self.slam.config.n_particles:
            slots = [int(p) for p in particles]
        else:
            free = list(range(len(self.lineages)))
            slots = []
            for p in particles:
                poses = self.slam.update_poses(int(p))
                costs = [self.lineages[j].sync_cost(poses) for j in free]
                slots.append(free.pop(int(np.argmin(costs))))
        for p, j in zip(particles, slots, strict=True):
            self.lineages[j].sync(self.slam.update_poses(int(p)), ranges)
        return slots

    def _window(self, lineage: LineageMap, pose: F64) -> GridSpec:
        cfg, res = self.config, self.slam.config.resolution_m
        if cfg.window == "robot":
            return robot_window(pose[:2], cfg.size, cfg.window_m)
        return map_window(lineage.seen_bounds_m(), cfg.size, cfg.margin_m, res)

    def _network_input(self, particles: I64, slots: list[int]) -> tuple[tuple[GridSpec, ...], F32]:
        """Each particle's window (a robot window centres on that particle) and its m_t pooled onto it."""
        poses = self.slam.poses
        windows = tuple(self._window(self.lineages[j], poses[p]) for p, j in zip(particles, slots, strict=True))
        partial = np.stack([self.lineages[j].pooled(w) for j, w in zip(slots, windows, strict=True)])
        return windows, partial.astype(np.float32)

    def _complete(self, ranks: I64, slots: list[int]) -> Completion:
        cfg = self.config
        windows, partial = self._network_input(ranks, slots)
        s = sample_completions(self.model, partial, cfg.samples, self.generator, self.device)
        samples = _copy_observed(s.samples, partial[:, None])
        mean = _copy_observed(s.mean, partial)
        return Completion(np.asarray(ranks, np.int64), windows, partial, samples, mean, label_entropy(samples))

    def _score(self, c: Completion) -> dict[str, float]:
        if self.ground_truth is None:
            return {}
        truth = pool_to_window(self.ground_truth, c.windows[0], outside=OCCUPIED)
        partial = c.partial[0]
        f_slam = score_maps(partial, truth, partial).f_measure
        f_done = score_maps(c.mean[0], truth, partial)
        per_sample, _ = miou_unknown(c.samples[0], np.broadcast_to(truth, c.samples[0].shape),
                                     np.broadcast_to(partial, c.samples[0].shape))
        return {"f_slam": f_slam, "f_completed": f_done.f_measure, "miou_unknown": f_done.miou_unknown,
                "miou_unknown_samples": float(np.nanmean(per_sample)) if np.isfinite(per_sample).any() else math.nan}

    def _prepare_weighting(self) -> None:
        """Deterministic completion of every particle's map, kept for the next update's weights."""
        particles = np.arange(self.slam.config.n_particles)
        windows, partial = self._network_input(particles, [int(p) for p in particles])
        with torch.inference_mode():
            x = torch.from_numpy(ternary_to_network(partial)).to(self.device)
            out = inference_net(self.model)(x).cpu().numpy()
        p_occ = np.clip(out[:, 0], 0.0, 1.0)
        known = network_to_ternary(out) != UNKNOWN
        self._weighting = (np.where(known, p_occ, 0.5).astype(np.float32), partial, windows)

    def _completion_log_likelihood(self, poses: F64, end_b: F64) -> F64:
        """Extra log-likelihood per particle: scan end points in cells unknown in its m_t, scored by its
        completion (the completion from the previous update; particle indices are stable in between)."""
        out = np.zeros(len(poses))
        if self._weighting is None or len(end_b) == 0:
            return out
        p_occ, partial, windows = self._weighting
        eps = self.config.hit_epsilon
        ends = np.concatenate([end_b, np.zeros((len(end_b), 1))], axis=1)
        for i, pose in enumerate(poses):
            xy = compose(pose, ends)[:, :2]
            w = windows[i]
            rc = w.world_to_cell(xy)
            inside = w.contains(rc)
            r, c = rc[inside, 0], rc[inside, 1]
            unknown = partial[i, r, c] == UNKNOWN
            p = p_occ[i, r[unknown], c[unknown]].astype(np.float64)
            out[i] = float(np.log(eps + (1 - 2 * eps) * p).sum())
        return self.config.completion_weight * out
