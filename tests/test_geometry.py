"""SE(2) algebra on pose arrays, checked on hand-computed cases."""

import numpy as np

from mcnkit.geometry import (
    compose,
    interpolate_poses,
    inverse,
    quaternion_to_yaw,
    relative,
    transform_points,
    wrap_angle,
    yaw_to_quaternion,
)


def test_compose_rotates_then_translates():
    out = compose(np.array([1.0, 2.0, np.pi / 2]), np.array([1.0, 0.0, np.pi / 4]))
    assert np.allclose(out, [1.0, 3.0, 3 * np.pi / 4])


def test_inverse_and_relative_undo_compose():
    rng = np.random.default_rng(0)
    a = rng.normal(size=(50, 3))
    b = rng.normal(size=(50, 3))
    assert np.allclose(compose(a, inverse(a)), 0.0, atol=1e-12)
    assert np.allclose(compose(a, relative(a, b))[:, :2], b[:, :2])
    assert np.allclose(wrap_angle(compose(a, relative(a, b))[:, 2] - b[:, 2]), 0.0, atol=1e-12)


def test_wrap_angle_range():
    assert np.allclose(wrap_angle(np.array([np.pi, -np.pi, 3 * np.pi / 2, 7.0])), [-np.pi, -np.pi, -np.pi / 2, 7.0 - 2 * np.pi])


def test_transform_points_of_a_turned_robot():
    pts = transform_points(np.array([1.0, 0.0, np.pi / 2]), np.array([[1.0, 0.0], [0.0, 2.0]]))
    assert np.allclose(pts, [[1.0, 1.0], [-1.0, 0.0]])


def test_interpolation_takes_the_short_way_round_and_clamps():
    stamps = np.array([0, 10], dtype=np.int64)
    poses = np.array([[0.0, 0.0, np.pi - 0.1], [1.0, 2.0, -np.pi + 0.1]])
    out = interpolate_poses(stamps, poses, np.array([-5, 5, 20], dtype=np.int64))
    assert np.allclose(out[0], poses[0]) and np.allclose(out[2], poses[1])
    assert np.allclose(out[1, :2], [0.5, 1.0]) and np.isclose(abs(out[1, 2]), np.pi)


def test_quaternion_round_trip():
    yaw = np.linspace(-3.1, 3.1, 13)
    assert np.allclose(quaternion_to_yaw(yaw_to_quaternion(yaw)), yaw)
