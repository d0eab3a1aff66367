"""Relations error, ATE/RPE and TUM files on hand-computed trajectories."""

from pathlib import Path

import numpy as np
import pytest

from mcnkit.metrics import (
    Relations,
    absolute_trajectory_error,
    match_stamps,
    read_relations,
    read_tum,
    relations_error,
    relative_pose_error,
    write_tum,
)
from mcnkit.types import Trajectory

S = 1_000_000_000


def test_match_stamps_takes_the_nearest_within_tolerance() -> None:
    stamps = np.array([0, 10, 20]) * S // 100  # 0, 0.1, 0.2 s
    q = np.array([0, 12 * S // 1000, 104 * S // 1000, 3 * S])  # 0, 0.012, 0.104, 3 s
    assert match_stamps(stamps, q, tolerance_s=0.005).tolist() == [0, -1, 1, -1]


def test_relations_error_translation_and_rotation() -> None:
    traj = Trajectory(np.array([0, S, 2 * S]), np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, np.pi / 2]]))
    rel = Relations(
        np.array([0, S]),
        np.array([S, 2 * S]),
        np.array([[1.1, 0.0, 0.0], [0.0, 1.0, np.pi / 2 + np.radians(2.0)]]),  # 0.1 m too long; 2° off
    )
    err = relations_error(traj, rel)
    assert err.translation_m.tolist() == pytest.approx([0.1, 0.0], abs=1e-9)
    assert err.rotation_deg.tolist() == pytest.approx([0.0, 2.0])
    assert err.translation_mean_m == pytest.approx(0.05) and err.rotation_mean_deg == pytest.approx(1.0)
    assert err.n_skipped == 0


def test_relations_without_poses_are_skipped() -> None:
    traj = Trajectory(np.array([0, S]), np.zeros((2, 3)))
    rel = Relations(np.array([0, 0]), np.array([S, 5 * S]), np.zeros((2, 3)))
    assert relations_error(traj, rel).n_skipped == 1


def test_ate_is_zero_for_a_rigidly_moved_copy_and_rpe_sees_a_bump() -> None:
    ref = Trajectory(np.arange(4) * S, np.array([[0, 0, 0], [1, 0, 0], [1, 1, np.pi / 2], [0, 1, np.pi]], float))
    c, s = np.cos(0.7), np.sin(0.7)
    moved = ref.poses.copy()
    moved[:, :2] = ref.poses[:, :2] @ np.array([[c, -s], [s, c]]).T + [3.0, -2.0]
    moved[:, 2] += 0.7
    est = Trajectory(ref.stamps_ns, moved)
    assert absolute_trajectory_error(est, ref).rmse_m == pytest.approx(0.0, abs=1e-9)
    assert relative_pose_error(est, ref).translation_mean_m == pytest.approx(0.0, abs=1e-9)
    bumped = ref.poses.copy()
    bumped[3, 0] += 0.3
    rpe = relative_pose_error(Trajectory(ref.stamps_ns, bumped), ref)
    assert rpe.translation_m.tolist() == pytest.approx([0.0, 0.0, 0.3])


def test_ate_with_scale_finds_a_resized_copy_and_says_by_how_much() -> None:
    ref = Trajectory(np.arange(5) * S, np.array([[0, 0, 0], [4, 0, 0], [4, 3, 1.6], [0, 3, 3.1], [0, 1, 4.7]], float))
    c, s = np.cos(-0.4), np.sin(-0.4)
    resized = ref.poses.copy()
    resized[:, :2] = 1.02 * ref.poses[:, :2] @ np.array([[c, -s], [s, c]]).T + [10.0, 5.0]
    est = Trajectory(ref.stamps_ns, resized)
    rigid = absolute_trajectory_error(est, ref)
    assert rigid.rmse_m > 0.02 and rigid.scale == 1.0  # 2 % larger: the rigid fit cannot take it out
    similar = absolute_trajectory_error(est, ref, scale=True)
    assert similar.rmse_m == pytest.approx(0.0, abs=1e-9)
    assert similar.scale == pytest.approx(1 / 1.02)


def test_tum_round_trip_and_relations_file(tmp_path: Path) -> None:
    traj = Trajectory(np.array([1134864629895182000, 1134864630105179000]), np.array([[1.0, 2.0, 3.0], [-1, 0, -2.5]]))
    write_tum(tmp_path / "t.tum", traj)
    back = read_tum(tmp_path / "t.tum")
    assert back.stamps_ns.tolist() == traj.stamps_ns.tolist()
    np.testing.assert_allclose(back.poses, traj.poses, atol=1e-6)
    (tmp_path / "r.relations").write_text("1134864645.90321 1134864646.32420 0.31293 0.02935 0.0  0.0 0.0 0.24198\n")
    rel = read_relations(tmp_path / "r.relations")
    assert rel.t1_ns.tolist() == [1134864645903210000]
    np.testing.assert_allclose(rel.delta, [[0.31293, 0.02935, 0.24198]])


def _box_scans(poses: np.ndarray, half_m: float = 3.025) -> list:
    """Noise-free scans (360 beams) of the inside of a square room of side 2·half_m centred on the origin."""
    from mcnkit.types import LidarSpec, Scan

    spec = LidarSpec(-np.pi, np.radians(1.0), 360, 0.1, 30.0)
    scans = []
    for x, y, yaw in poses:
        a = yaw + spec.angles_rad
        c, s = np.cos(a), np.sin(a)
        with np.errstate(divide="ignore"):
            tx = np.where(c > 0, (half_m - x) / c, (-half_m - x) / c)
            ty = np.where(s > 0, (half_m - y) / s, (-half_m - y) / s)
        scans.append(Scan(np.minimum(np.abs(tx), np.abs(ty)).astype(np.float32), spec))
    return scans


def test_hit_cells_are_fewest_at_the_poses_the_scans_were_taken_from() -> None:
    from mcnkit.metrics import hit_cells

    rng = np.random.default_rng(0)
    truth = np.column_stack([rng.uniform(-2, 2, 40), rng.uniform(-2, 2, 40), rng.uniform(-np.pi, np.pi, 40)])
    scans = _box_scans(truth)
    exact = hit_cells(scans, truth)
    # a bent trajectory (0.5° more heading per scan) smears the walls over more cells; so does 5 cm of noise
    bent = truth + np.column_stack([np.zeros(40), np.zeros(40), np.radians(0.5) * np.arange(40)])
    noisy = truth + np.column_stack([rng.normal(0, 0.05, (40, 2)), np.zeros(40)])
    assert exact < 0.6 * hit_cells(scans, bent) and exact < 0.6 * hit_cells(scans, noisy)
    # the walls alone (x, y = ±3.025 m: mid-cell) hold 4 × 122 cells; the true trajectory hits no more than those
    assert exact <= 4 * 122
    with pytest.raises(Exception, match="one pose per scan"):
        hit_cells(scans, truth[:-1])
