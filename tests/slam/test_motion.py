"""gmapping's odometry motion model."""

import numpy as np
import pytest

from mcnkit.slam.motion import MotionNoise, motion_std, sample_motion


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
