"""Relations measured by the scans themselves: they recover the true motion, favour no candidate trajectory, skip
what a scan cannot pin down, and rank a bent trajectory below the true one."""

import numpy as np

from mcnkit.metrics import relations_error
from mcnkit.slam.scanrelations import revisit_pairs, scan_relations, sequential_pairs
from mcnkit.types import Trajectory

S = 1_000_000_000


def _room_returns(poses: np.ndarray, half_x_m: float = 3.0, half_y_m: float = 2.0, walls: str = "xy") -> list:
    """Base-frame returns (360 beams up to 40 m, noise-free) of the inside of a rectangular room centred on the origin;
    ``walls="y"`` keeps only the two walls at y = ±half_y_m (an endless corridor along x)."""
    angles = np.radians(np.arange(360) - 180.0)
    out = []
    for x, y, yaw in poses:
        c, s = np.cos(yaw + angles), np.sin(yaw + angles)
        with np.errstate(divide="ignore"):
            tx = np.abs(np.where(c > 0, (half_x_m - x) / c, (-half_x_m - x) / c)) if "x" in walls else np.inf
            ty = np.abs(np.where(s > 0, (half_y_m - y) / s, (-half_y_m - y) / s))
        r = np.minimum(tx, ty)
        use = r < 40.0
        out.append(np.column_stack([r[use] * np.cos(angles[use]), r[use] * np.sin(angles[use])]))
    return out


def _walk(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-1.5, 1.5, n), rng.uniform(-1.0, 1.0, n), rng.uniform(-0.5, 0.5, n)])


def test_scan_relations_recover_the_motion_between_the_scans_to_the_field_cells() -> None:
    truth = _walk(12, 0)
    pairs = sequential_pairs(len(truth))
    # the search starts from a trajectory up to 0.15 m and 2° off: the scans, not the start, decide the relation
    off = truth + np.random.default_rng(1).uniform(-1, 1, truth.shape) * [0.15, 0.15, np.radians(2.0)]
    rel = scan_relations(_room_returns(truth), np.arange(len(truth)) * S, pairs, [off])
    assert len(rel) == len(pairs)
    err = relations_error(Trajectory(np.arange(len(truth)) * S, truth), rel)
    assert err.translation_mean_m < 0.03 and err.rotation_mean_deg < 0.3
    # ... and the trajectory that seeded the search scores as far off as it is
    assert relations_error(Trajectory(np.arange(len(truth)) * S, off), rel).translation_mean_m > 0.08


def test_scan_relations_favour_no_candidate_and_rank_a_bent_trajectory_below_the_true_one() -> None:
    truth = _walk(16, 2)
    stamps = np.arange(len(truth)) * S
    bent = truth + np.column_stack([np.zeros((len(truth), 2)), np.radians(0.8) * np.arange(len(truth))])
    pairs = sequential_pairs(len(truth), steps=(1, 2, 5))
    returns = _room_returns(truth)
    one = scan_relations(returns, stamps, pairs, [truth, bent])
    other = scan_relations(returns, stamps, pairs, [bent, truth])
    np.testing.assert_array_equal(one.delta, other.delta)
    true_err = relations_error(Trajectory(stamps, truth), one)
    bent_err = relations_error(Trajectory(stamps, bent), one)
    assert bent_err.rotation_mean_deg > 1.0 > 0.3 > true_err.rotation_mean_deg


def test_a_corridor_pins_nothing_along_its_axis_and_gives_no_relation() -> None:
    poses = np.column_stack([np.linspace(0.0, 2.0, 6), np.zeros(6), np.zeros(6)])
    rel = scan_relations(_room_returns(poses, walls="y"), np.arange(6) * S, sequential_pairs(6), [poses])
    assert len(rel) == 0
    # the same poses in a closed room do give every relation
    assert len(scan_relations(_room_returns(poses), np.arange(6) * S, sequential_pairs(6), [poses])) == 9


def test_revisit_pairs_join_two_passes_through_one_place_once_per_block() -> None:
    # two laps of a 10 m square, 40 poses a lap (1 m apart), facing along the path
    t = np.arange(80) % 40 / 40.0 * 4.0
    side = np.floor(t).astype(int)
    frac = t - side
    corners = np.array([[0, 0], [10, 0], [10, 10], [0, 10], [0, 0]], float)
    xy = corners[side] + frac[:, None] * (corners[side + 1] - corners[side])
    yaw = np.radians(90.0) * side
    pairs = revisit_pairs(np.column_stack([xy, yaw]), min_gap_scans=20, max_distance_m=0.5, bin_scans=1)
    # every pose of lap one meets its twin in lap two (40 scans later), and nothing else is near enough
    np.testing.assert_array_equal(pairs, np.column_stack([np.arange(40), np.arange(40) + 40]))
    coarse = revisit_pairs(np.column_stack([xy, yaw]), min_gap_scans=20, max_distance_m=0.5, bin_scans=4)
    assert len(coarse) == 10 and np.all(coarse[:, 1] - coarse[:, 0] == 40)


def test_the_module_example_runs() -> None:
    import doctest

    import mcnkit.slam.scanrelations as module

    result = doctest.testmod(module)
    assert result.attempted >= 4 and result.failed == 0
