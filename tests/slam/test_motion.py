"""gmapping's odometry motion model."""

import numpy as np
import pytest

from mcnkit.slam.motion import MotionNoise, NoiseScale, motion_std, sample_motion


def test_noise_free_motion_is_the_odometry_increment_in_the_particle_frame() -> None:
    poses = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2]])
    odom_prev, odom_new = np.array([5.0, 5.0, np.pi]), np.array([4.0, 5.0, np.pi])  # 1 m forward
    out = sample_motion(poses, odom_prev, odom_new, MotionNoise(0, 0, 0, 0), np.random.default_rng(0))
    np.testing.assert_allclose(out, [[1.0, 0.0, 0.0], [1.0, 2.0, np.pi / 2]], atol=1e-12)


def test_motion_std_matches_gmapping_formula() -> None:
    # delta = (1 m, 0.5 m, 0.2 rad): sx = 0.1·1 + 0.1·0.2 + 0.03·0.5, sy = 0.1·0.5 + 0.1·0.2 + 0.03·1,
    # st = 0.2·0.2 + 0.2·√1.25
    std = motion_std(np.array([1.0, 0.5, 0.2]), MotionNoise())
    assert std.tolist() == pytest.approx([0.135, 0.1, 0.04 + 0.2 * np.sqrt(1.25)])


def test_sampled_mean_and_variance() -> None:
    rng = np.random.default_rng(42)
    poses = np.zeros((20000, 3))
    out = sample_motion(poses, np.zeros(3), np.array([1.0, 0.0, 0.0]), MotionNoise(), rng)
    # from the origin the increment is the pose: mean (1, 0, 0), std (0.1, 0.03, 0.2)
    assert out.mean(axis=0).tolist() == pytest.approx([1.0, 0.0, 0.0], abs=0.01)
    assert out.std(axis=0).tolist() == pytest.approx([0.1, 0.03, 0.2], rel=0.03)


def _residuals(scale: float, n: int, rng: np.random.Generator) -> list[tuple[np.ndarray, np.ndarray]]:
    """``n`` 1 m / 0.3 rad odometry steps and scan-matched ones that differ by ``scale`` × the model's noise."""
    out = []
    for _ in range(n):
        odom = np.array([1.0, 0.0, 0.3])
        std = motion_std(odom, MotionNoise())
        out.append((odom, odom + scale * std * rng.standard_normal(3)))
    return out


def test_noise_scale_measures_how_much_of_the_model_the_odometry_needs() -> None:
    rng = np.random.default_rng(0)
    for true_scale, lo, hi in [(0.1, 0.08, 0.12), (0.3, 0.25, 0.35)]:
        est = NoiseScale(window=400)
        for odom, matched in _residuals(true_scale, 400, rng):
            est.add(odom, matched, MotionNoise())
        xy, rad = est.scales()
        assert lo < xy < hi and lo < rad < hi
        scaled = est.noise(MotionNoise())
        assert np.isclose(scaled.srt, 0.2 * rad) and np.isclose(scaled.srr, 0.1 * xy)


def test_noise_scale_never_raises_the_model_never_drops_below_its_floor_and_waits_for_samples() -> None:
    rng = np.random.default_rng(1)
    worse, perfect, early = NoiseScale(), NoiseScale(min_scale=0.05), NoiseScale(min_samples=20)
    for odom, matched in _residuals(3.0, 100, rng):
        worse.add(odom, matched, MotionNoise())
        perfect.add(odom, odom, MotionNoise())
    for odom, matched in _residuals(0.1, 19, rng):
        early.add(odom, matched, MotionNoise())
    assert worse.scales() == (1.0, 1.0)  # odometry worse than gmapping's model: the model as configured
    assert perfect.scales() == (0.05, 0.05)
    assert early.scales() == (1.0, 1.0)  # 19 steps are too few to say


def test_a_step_whose_odometry_and_scan_matching_disagree_keeps_noise_that_spans_the_disagreement() -> None:
    # Scan matching errs grossly now and then (outdoors, in a featureless stretch): the particles must still reach
    # what the odometry says for that step, so its noise is at least the disagreement, whatever the log's usual.
    rng = np.random.default_rng(2)
    scale = NoiseScale()
    for odom, matched in _residuals(0.1, 100, rng):
        last = scale.add(odom, matched, MotionNoise())
    usual = scale.noise(MotionNoise(), step=last)
    assert usual.srt < 0.05  # a good log: a fraction of gmapping's 0.2
    odom = np.array([1.0, 0.0, 0.0])
    std = motion_std(odom, MotionNoise())
    step = scale.add(odom, odom + np.array([0.0, 0.0, 0.5 * std[2]]), MotionNoise())  # half a model σ off in heading
    assert np.isclose(scale.noise(MotionNoise(), step=step).srt, 0.2 * 0.5)
    assert scale.noise(MotionNoise()).srt < 0.05  # without the floor, the usual scale
    step = scale.add(odom, odom + np.array([0.0, 0.0, 5.0 * std[2]]), MotionNoise())  # far off: never above the model
    assert np.isclose(scale.noise(MotionNoise(), step=step).srt, 0.2)
