"""``mcnkit eval``: scores refuse what they cannot match (exit 2 with the reason); a log's ground truth as TUM."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from mcnkit.app.main import main
from mcnkit.metrics import (
    EvaluationError,
    Relations,
    absolute_trajectory_error,
    read_tum,
    relations_error,
    write_tum,
)
from mcnkit.types import Trajectory

S = 1_000_000_000


def _traj(n: int, start_ns: int = 0, step_ns: int = S // 5) -> Trajectory:
    k = np.arange(n)
    poses = np.stack([0.1 * k, np.sin(0.05 * k), 0.01 * k], axis=1)
    return Trajectory(start_ns + k.astype(np.int64) * step_ns, poses)


def _err(capsys: pytest.CaptureFixture[str]) -> str:
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def test_ate_refuses_three_of_910_matched(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    ref = _traj(910)
    write_tum(tmp_path / "ref.tum", ref)
    write_tum(tmp_path / "est.tum", Trajectory(ref.stamps_ns[:3], ref.poses[:3]))
    assert main(["eval", "ate", str(tmp_path / "est.tum"), str(tmp_path / "ref.tum")]) == 2
    err = _err(capsys)
    assert err.startswith(f"mcnkit eval ate: {tmp_path / 'est.tum'}: only 3 of 910 reference poses")
    # asked for explicitly, a partial trajectory is scored over what it covers
    assert main(["eval", "ate", str(tmp_path / "est.tum"), str(tmp_path / "ref.tum"), "--min-fraction", "0"]) == 0
    assert "over 3 of 910 reference poses" in capsys.readouterr().out


def test_ate_refuses_equal_stamps_unless_matched_by_order(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    ref = _traj(50)
    same = Trajectory(np.full(50, 7 * S, np.int64), ref.poses)
    write_tum(tmp_path / "ref.tum", same)
    write_tum(tmp_path / "est.tum", same)
    assert main(["eval", "ate", str(tmp_path / "est.tum"), str(tmp_path / "ref.tum")]) == 2
    err = _err(capsys)
    assert "stamps repeat (50 poses, 1 distinct stamp)" in err and "--match order" in err
    assert main(["eval", "ate", str(tmp_path / "est.tum"), str(tmp_path / "ref.tum"), "--match", "order",
                 "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["ate"]["rmse_m"] < 1e-9 and result["ate"]["n_matched"] == 50 and result["match"] == "order"
    write_tum(tmp_path / "short.tum", Trajectory(same.stamps_ns[:40], same.poses[:40]))
    assert main(["eval", "ate", str(tmp_path / "short.tum"), str(tmp_path / "ref.tum"), "--match", "order"]) == 2
    assert "40 estimate and 50 reference poses" in _err(capsys)


def test_ate_with_scale_prints_the_factor_that_explains_a_resized_trajectory(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    ref = _traj(60)
    bigger = ref.poses.copy()
    bigger[:, :2] *= 1.005  # wheels 0.5 % long
    write_tum(tmp_path / "ref.tum", ref)
    write_tum(tmp_path / "est.tum", Trajectory(ref.stamps_ns, bigger))
    args = ["eval", "ate", str(tmp_path / "est.tum"), str(tmp_path / "ref.tum")]
    assert main([*args, "--json"]) == 0
    rigid = json.loads(capsys.readouterr().out)["ate"]
    assert rigid["rmse_m"] > 0.005 and rigid["scale"] == 1.0
    assert main([*args, "--scale"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("ATE rmse 0.0000 m") and "after a similarity alignment (scale 0.99502)" in out


def test_relations_refuse_zero_matches(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_tum(tmp_path / "est.tum", _traj(100))
    (tmp_path / "r.relations").write_text("5000.0 5001.0 0.5 0 0 0 0 0\n6000.0 6001.0 0.5 0 0 0 0 0\n")
    assert main(["eval", "relations", str(tmp_path / "est.tum"), str(tmp_path / "r.relations")]) == 2
    assert "only 0 of 2 relations" in _err(capsys)
    (tmp_path / "r.relations").write_text("0.0 1.0 0.5 0 0 0 0 0\n")
    assert main(["eval", "relations", str(tmp_path / "est.tum"), str(tmp_path / "r.relations")]) == 0
    assert "over 1 relations" in capsys.readouterr().out


def test_unreadable_and_empty_inputs_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_tum(tmp_path / "ref.tum", _traj(10))
    (tmp_path / "empty.tum").write_text("# nothing\n")
    (tmp_path / "nan.tum").write_text("0.0 nan 0 0 0 0 0 1\n")
    (tmp_path / "words.tum").write_text("zero one two three four five six seven\n")
    for bad, why in (("empty.tum", "no poses"), ("nan.tum", "non-finite"), ("words.tum", "not a trajectory file"),
                     ("missing.tum", "cannot read")):
        assert main(["eval", "ate", str(tmp_path / bad), str(tmp_path / "ref.tum")]) == 2
        err = _err(capsys)
        assert err.startswith(f"mcnkit eval ate: {tmp_path / bad}: ") and why in err, err


def test_a_log_given_where_a_trajectory_goes_is_named_with_the_commands_order(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Arguments in the wrong order get one line that says which file is the log and what the command takes."""
    from mcnkit.io import LogContent, write_log
    from tests.conftest import make_frames

    bag = write_log(tmp_path / "run.bag", LogContent(make_frames(20)))
    folder = write_log(tmp_path / "ros2", LogContent(make_frames(20)), "ros2-mcap")
    write_tum(tmp_path / "est.tum", _traj(20, 1_000_000_000, 100_000_000))
    (tmp_path / "out").mkdir()
    write_tum(tmp_path / "out/trajectory.tum", _traj(20))
    cases = (
        (["ate", str(bag), str(tmp_path / "est.tum")], f"{bag}: a robot log, not a trajectory file "
         "('mcnkit eval ate' takes TRAJ, then REFERENCE (a TUM file or a log))"),
        (["ate", str(folder), str(bag)], f"{folder}: a robot log, not a trajectory file"),
        (["relations", str(bag), str(tmp_path / "est.tum")], "('mcnkit eval relations' takes TRAJ, then RELATIONS)"),
        (["consistency", str(tmp_path / "est.tum"), str(bag)], f"{bag}: a robot log, not a trajectory file "
         "('mcnkit eval consistency' takes LOG, then TRAJ...)"),
        (["consistency", str(tmp_path / "est.tum"), str(tmp_path / "est.tum")],
         f"{tmp_path / 'est.tum'}: a TUM trajectory, not a robot log ('mcnkit eval consistency' takes LOG"),
        (["ate", str(tmp_path / "out"), str(bag)], f"{tmp_path / 'out'}: a folder, not a trajectory file (its "
         f"trajectory: {tmp_path / 'out/trajectory.tum'})"),
    )
    for argv, said in cases:
        assert main(["eval", *argv, "--no-progress"] if argv[0] == "consistency" else ["eval", *argv]) == 2
        err = _err(capsys)
        assert said in err, (argv, err)


def test_library_refuses_too_and_sorts_unsorted_stamps() -> None:
    ref = _traj(20)
    with pytest.raises(EvaluationError, match="only 0 of 1 relations"):
        relations_error(ref, Relations(np.array([99 * S]), np.array([100 * S]), np.zeros((1, 3))))
    shuffled = np.random.default_rng(0).permutation(20)
    est = Trajectory(ref.stamps_ns[shuffled], ref.poses[shuffled])
    assert absolute_trajectory_error(est, ref).rmse_m == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(EvaluationError, match="at least 10 needed"):
        absolute_trajectory_error(Trajectory(ref.stamps_ns[:5], ref.poses[:5]), ref, min_fraction=0.5)


def test_groundtruth_of_a_corrected_carmen_log(tmp_path: Path, shared_data: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    log = shared_data / "reallab/radish/aces-corrected.log.gz"
    out = tmp_path / "aces.tum"
    assert main(["eval", "groundtruth", str(log), str(out)]) == 0
    truth = read_tum(out)
    assert len(truth) == 440
    from mcnkit.io import open_log

    with open_log(log) as reader:
        gt = reader.ground_truth()
    assert gt is not None
    assert (truth.stamps_ns == gt.stamps_ns).all() and np.allclose(truth.poses, gt.poses, atol=1e-6)
    capsys.readouterr()
    assert main(["eval", "groundtruth", str(log), str(out)]) == 2
    assert _err(capsys) == f"mcnkit eval groundtruth: {out}: exists (use --overwrite to replace it)"
    assert main(["eval", "groundtruth", str(log), str(out), "--overwrite"]) == 0
    assert main(["eval", "ate", str(out), str(out)]) == 0
    capsys.readouterr()
    copy = tmp_path / "copy.log.gz"
    copy.write_bytes(log.read_bytes())
    assert main(["eval", "groundtruth", str(copy), str(copy), "--overwrite"]) == 2
    assert "is the input log" in _err(capsys)
    assert copy.read_bytes() == log.read_bytes()
    assert main(["eval", "groundtruth", str(shared_data / "reallab/mit-csail/mit-csail.clf"), str(tmp_path / "m.tum")]) == 2
    assert "carries no ground-truth trajectory" in _err(capsys)
    assert not (tmp_path / "m.tum").exists()
    assert not list(tmp_path.glob(".*partial"))


@pytest.mark.slow
def test_ate_reads_the_reference_straight_from_a_log_that_carries_one(tmp_path: Path, shared_data: Path,
                                                                       capsys: pytest.CaptureFixture[str]) -> None:
    log = shared_data / "reallab/radish/aces-corrected.log.gz"
    truth = tmp_path / "aces.tum"
    assert main(["eval", "groundtruth", str(log), str(truth)]) == 0
    run = tmp_path / "run.tum"
    ref = read_tum(truth)
    stretched = ref.poses * [1.05, 1.0, 1.0]  # 5 % longer along x: no rigid motion undoes it
    write_tum(run, Trajectory(ref.stamps_ns, stretched))
    capsys.readouterr()
    assert main(["eval", "ate", str(run), str(truth), "--json"]) == 0
    from_tum = json.loads(capsys.readouterr().out)
    assert main(["eval", "ate", str(run), str(log), "--json"]) == 0
    from_log = json.loads(capsys.readouterr().out)
    assert from_log["ate"] == pytest.approx(from_tum["ate"], abs=1e-5) and from_tum["ate"]["rmse_m"] > 0.1
    # a log without ground truth, and a file that is neither a trajectory nor a log, are one line each
    assert main(["eval", "ate", str(run), str(shared_data / "reallab/mit-csail/mit-csail.clf")]) == 2
    assert "mit-csail.clf: this log carries no ground-truth trajectory" in _err(capsys)
    junk = tmp_path / "map.png"
    junk.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(64))
    assert main(["eval", "ate", str(run), str(junk)]) == 2
    assert _err(capsys).startswith(f"mcnkit eval ate: {junk}: not a reference trajectory file")


def test_consistency_needs_no_reference_and_flags_a_bent_trajectory(tmp_path: Path, shared_data: Path,
                                                                    capsys: pytest.CaptureFixture[str]) -> None:
    """``mcnkit eval consistency``: a log's corrected poses bent by 0.5° of heading halfway round agree with the
    scans between consecutive scans almost as well as before, but no longer where the robot comes back."""
    from mcnkit.geometry import compose, relative

    log = shared_data / "reallab/radish/aces-corrected.log.gz"
    assert main(["eval", "groundtruth", str(log), str(tmp_path / "truth.tum")]) == 0
    truth = read_tum(tmp_path / "truth.tum")
    steps = relative(truth.poses[:-1], truth.poses[1:])
    steps[len(steps) // 2, 2] += np.radians(0.5)
    bent = [truth.poses[0]]
    for step in steps:
        bent.append(compose(bent[-1], step))
    write_tum(tmp_path / "bent.tum", Trajectory(truth.stamps_ns, np.array(bent)))
    capsys.readouterr()
    assert main(["eval", "consistency", str(log), str(tmp_path / "truth.tum"), str(tmp_path / "bent.tum"),
                 "--json", "--no-progress", "--plot", str(tmp_path / "where.png")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["plot"] == str(tmp_path / "where.png")
    assert (tmp_path / "where.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and not list(tmp_path.glob(".*partial*"))
    assert out["scans"] == 440 and out["sequential_relations"] > 300 and out["revisits_relations"] > 20
    truth_row, bent_row = (out["trajectories"][str(tmp_path / name)] for name in ("truth.tum", "bent.tum"))
    assert bent_row["sequential"]["rotation_mean_deg"] < truth_row["sequential"]["rotation_mean_deg"] + 0.01
    assert bent_row["revisits"]["translation_mean_m"] > truth_row["revisits"]["translation_mean_m"] + 0.05
    # a trajectory that is not one pose per scan of the log is refused in one line
    write_tum(tmp_path / "short.tum", Trajectory(truth.stamps_ns[:100], truth.poses[:100]))
    assert main(["eval", "consistency", str(log), str(tmp_path / "short.tum"), "--no-progress"]) == 2
    assert _err(capsys).startswith(f"mcnkit eval consistency: {tmp_path / 'short.tum'}: 340 of the log's 440 scans "
                                   "have no pose")
    assert main(["eval", "consistency", str(log), str(tmp_path / "truth.tum"), "--plot", str(tmp_path / "x.pdf")]) == 2
    assert "--plot writes a PNG file" in _err(capsys)
    picture = (tmp_path / "where.png").read_bytes()
    assert main(["eval", "consistency", str(log), str(tmp_path / "truth.tum"), "--plot", str(tmp_path / "where.png")]) == 2
    assert "exists already (pass --overwrite to replace it)" in _err(capsys)
    assert (tmp_path / "where.png").read_bytes() == picture
