"""``mcnkit eval``: score a trajectory, or write a log's ground truth as the TUM file the scores read (the three
sub-commands are described once, in the command's help text below).  Scores refuse what they cannot match (exit 2
with the reason, see :mod:`mcnkit.metrics`).
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from mcnkit.app.options import add_options

if TYPE_CHECKING:
    from mcnkit.metrics import Relations
    from mcnkit.types import Trajectory

__all__ = ["AteOptions", "ConsistencyOptions", "GroundTruthOptions", "RelationsOptions", "add_eval_parser", "run_eval_ate", "run_eval_consistency", "run_eval_groundtruth", "run_eval_relations",
           "write_ground_truth"]


_DESCRIPTION = """Score a trajectory, or write a log's ground truth as the TUM file the scores read:

  eval relations TRAJ RELATIONS   the Kümmerle et al. (2009) relations error
  eval ate TRAJ REFERENCE         ATE after rigid 2-D alignment, and RPE
  eval consistency LOG TRAJ...    no reference needed: how well trajectories of a log agree with its own scans
                                  (relations the scans measure, between consecutive scans and at revisits)
  eval groundtruth LOG OUT.tum    the reference trajectory a log carries (a Radish corrected CARMEN log's
                                  corrected poses, a ground-truth topic, a simulated log's true path)

A score refuses (exit 2, with the reason) what it cannot match: too few poses or relations matched, stamps
that repeat.  '--match order' pairs the k-th poses when the stamps carry no time but both trajectories hold
one pose per scan of the same log."""


@dataclass(frozen=True, kw_only=True)
class _Matching:
    """How a trajectory's poses are matched to the reference, and when a score is refused."""

    tolerance_s: float = 0.005
    """stamp matching tolerance in seconds"""
    min_fraction: float = 0.5
    """refuse (exit 2) when less than this share of the reference poses / relations match"""
    min_matched: int = 1
    """refuse (exit 2) when fewer than this many match"""
    json: bool = False
    """print JSON instead of text"""


@dataclass(frozen=True, kw_only=True)
class RelationsOptions(_Matching):
    """``mcnkit eval relations TRAJ RELATIONS``."""

    trajectory: Path
    """estimated trajectory, TUM format"""
    relations: Path
    """relations file: t1 t2 x y z roll pitch yaw per line"""


@dataclass(frozen=True, kw_only=True)
class AteOptions(_Matching):
    """``mcnkit eval ate TRAJ REFERENCE``."""

    min_matched: int = 3
    """refuse (exit 2) when fewer than this many match"""
    trajectory: Path
    """estimated trajectory, TUM format"""
    reference: Path
    """reference trajectory: a TUM file, or a log that carries one (a Radish corrected CARMEN log, a bag with a
    ground-truth topic, a simulated log)"""
    match: Literal["stamp", "order"] = "stamp"
    """stamp: each reference pose with the estimate pose of the nearest stamp (default); order: the k-th pose of
    each (the same number of poses, one per scan of the same log)"""
    scale: bool = False
    """align with one scale factor too (a similarity alignment) and print the factor: the ATE left is what a
    difference in size between the trajectories does not explain (uncalibrated wheels, a reference of another
    scale)"""


@dataclass(frozen=True, kw_only=True)
class ConsistencyOptions:
    """``mcnkit eval consistency LOG TRAJ...``."""

    log: Path
    """the log the trajectories were made from (CARMEN, .bag, rosbag2 folder, .mcap)"""
    trajectories: tuple[Path, ...]
    """trajectories, TUM format, one pose per scan of the log"""
    match: Literal["stamp", "order"] = "stamp"
    """stamp: each scan with the pose of its stamp (default); order: the k-th pose with the k-th scan"""
    tolerance_s: float = 0.005
    """stamp matching tolerance in seconds"""
    plot: Path | None = None
    """also draw where each trajectory disagrees with the scans into this PNG: its scans at its poses, the
    relations coloured by its error on them (dots: sequential, lines: revisits)"""
    overwrite: bool = False
    """replace the --plot file if it exists"""
    no_progress: bool = False
    """no progress bar"""
    json: bool = False
    """print one JSON object instead of text"""


@dataclass(frozen=True, kw_only=True)
class GroundTruthOptions:
    """``mcnkit eval groundtruth LOG OUT.tum``."""

    log: Path
    """a log (CARMEN, .bag, rosbag2 folder, .mcap)"""
    output: Path
    """the TUM file to write"""
    overwrite: bool = False
    """replace OUTPUT if it exists"""


def add_eval_parser(subparsers: Any) -> argparse.ArgumentParser:
    """Adds ``eval relations``, ``eval ate``, ``eval consistency`` and ``eval groundtruth``."""
    p: argparse.ArgumentParser = subparsers.add_parser(
        "eval", help="score a TUM trajectory (relations error, ATE/RPE), or write a log's ground truth as TUM",
        description=_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="eval_command", metavar="EVAL_COMMAND", required=True)
    r = sub.add_parser("relations", help="Kümmerle et al. 2009 relations error (translation m, rotation deg)",
                       description="The relations error of a trajectory: for each ground-truth relation (the robot's "
                       "motion between the scans stamped t1 and t2), how far the trajectory's motion between "
                       "its poses nearest those stamps is off, in translation and rotation.")
    add_options(r, RelationsOptions, positional=("trajectory", "relations"))
    r.set_defaults(func=run_eval_relations)
    a = sub.add_parser("ate", help="ATE (after rigid 2-D alignment) and RPE against a reference trajectory",
                       description="ATE: RMSE of the positions after the least-squares rigid 2-D alignment of the "
                       "estimate onto the reference (with --scale, the similarity alignment, which fits one scale "
                       "factor too); RPE: the error of the motion between consecutive matched "
                       "poses.  REFERENCE is a TUM file or a log that carries its ground truth (read as 'mcnkit eval "
                       "groundtruth LOG OUT.tum' writes it).")
    add_options(a, AteOptions, positional=("trajectory", "reference"))
    a.set_defaults(func=run_eval_ate)
    c = sub.add_parser("consistency", help="how well trajectories agree with the log's own scans (no reference needed)",
                       description="Score trajectories of one log on relations its own scans measure "
                       "(mcnkit.slam.scanrelations): pairs of scans matched onto each other by an exact search around "
                       "every given trajectory's relative pose, the best match kept, so no trajectory is favoured; "
                       "pairs that explain under 40 %% of the scan or leave a corridor's axis free are dropped.  "
                       "Sequential pairs (scans 1 and 2 apart) test the local shape; revisits (scans at least 40 "
                       "apart whose poses in the first trajectory lie within 2.5 m) test the global shape, which only "
                       "consistently closed loops get right.  Lower is better; compare trajectories of the same log "
                       "(e.g. two runs, or a run and the log's corrected poses from 'mcnkit eval groundtruth').  On "
                       "MIT CSAIL these relations miss the Kümmerle et al. ground truth by 0.026 m / 0.32 deg on "
                       "average (benchmarks/results/reference_consistency.md).")
    add_options(c, ConsistencyOptions, positional=("log", "trajectories"))
    c.set_defaults(func=run_eval_consistency)
    g = sub.add_parser("groundtruth", help="write the ground-truth trajectory a log carries as TUM",
                       description="Write the reference trajectory of any log mcnkit reads as TUM (one pose per "
                       "line, the log's stamps): a Radish corrected CARMEN log's corrected poses, a bag's "
                       "ground-truth topic, a simulated log's true path.")
    add_options(g, GroundTruthOptions, positional=("log", "output"))
    g.set_defaults(func=run_eval_groundtruth)
    return p


class _Refused(Exception):
    """One line for ``fail``: ``FILE: problem``."""


_ORDER = {
    "relations": "'mcnkit eval relations' takes TRAJ, then RELATIONS",
    "ate": "'mcnkit eval ate' takes TRAJ, then REFERENCE (a TUM file or a log)",
    "consistency": "'mcnkit eval consistency' takes LOG, then TRAJ...",
}


def _read(reader: Any, path: Path, what: str, command: str | None = None) -> Any:
    """``reader(path)``, or :class:`_Refused` with one line; where a robot log stands in the place of the file
    ``command`` wants, the line says so and gives the command's order of arguments."""
    from mcnkit.io import looks_like_log

    try:
        value = reader(path)
    except (OSError, ValueError) as err:
        if command is not None and looks_like_log(path):
            raise _Refused(f"{path}: a robot log, not a {what} file ({_ORDER[command]})") from err
        if path.is_dir() and (path / "trajectory.tum").is_file():  # an `mcnkit slam --out` folder
            raise _Refused(f"{path}: a folder, not a {what} file (its trajectory: {path / 'trajectory.tum'})") from err
        if isinstance(err, OSError):
            raise _Refused(f"{path}: cannot read the {what}: {err.strerror or err}") from err
        text = str(err).splitlines()[0] if str(err).strip() else type(err).__name__
        raise _Refused(text if text.startswith(str(path)) else f"{path}: not a {what} file ({text})") from err
    if len(value) == 0:
        raise _Refused(f"{path}: no {'relations' if what == 'relations' else 'poses'} in this {what} file")
    return value


def _reads_as(reader: Any, path: Path) -> bool:
    """Whether ``reader`` reads ``path`` without an error."""
    try:
        reader(path)
    except (OSError, ValueError):
        return False
    return True


def _reference(path: Path) -> Trajectory:
    """The reference trajectory at ``path``: a TUM file, or the ground truth of a log (a rosbag2 folder, a bag, an
    MCAP or CARMEN file), or :class:`_Refused`."""
    import warnings

    from mcnkit.io import LogError, open_log
    from mcnkit.metrics import read_tum

    if not path.is_dir():
        try:
            return _read(read_tum, path, "reference trajectory")
        except _Refused as not_tum:
            tum_problem = not_tum
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the log's notes on its scans and odometry: only its ground truth is read
            with open_log(path) as log:
                truth = log.ground_truth()
    except LogError as err:
        if not path.is_dir():
            raise tum_problem from err  # neither a TUM file nor a log: the TUM reader's reason
        raise _Refused(str(err).splitlines()[0]) from err
    if truth is None or len(truth) == 0:
        raise _Refused(f"{path}: this log carries no ground-truth trajectory (a Radish corrected CARMEN log, a "
                       "ground-truth topic or a simulated log does)")
    return truth


def _command(args: argparse.Namespace) -> str:
    return f"eval {args.eval_command}"


def run_eval_relations(args: argparse.Namespace) -> int:
    """Prints the relations error of a TUM trajectory (exit 2 when too few relations match)."""
    from mcnkit.app.exits import fail
    from mcnkit.metrics import EvaluationError, read_relations, read_tum, relations_error

    try:
        traj: Trajectory = _read(read_tum, args.trajectory, "trajectory", "relations")
        rel: Relations = _read(read_relations, args.relations, "relations")
        err = relations_error(traj, rel, args.tolerance_s, min_matched=args.min_matched,
                              min_fraction=args.min_fraction)
    except _Refused as exc:
        return fail(_command(args), exc)
    except EvaluationError as exc:
        return fail(_command(args), f"{args.trajectory}: {exc}")
    if args.json:
        print(json.dumps(err.as_dict()))
    else:
        print(
            f"translation {err.translation_mean_m:.4f} ± {err.translation_std_m:.4f} m, "
            f"rotation {err.rotation_mean_deg:.3f} ± {err.rotation_std_deg:.3f} deg "
            f"over {len(err.translation_m)} relations ({err.n_skipped} without a pose within {args.tolerance_s} s)"
        )
    return 0


def run_eval_ate(args: argparse.Namespace) -> int:
    """Prints ATE and RPE of a TUM trajectory against a reference (a TUM trajectory, or a log's ground truth; exit 2
    when too few poses match, or their stamps cannot be matched)."""
    from mcnkit.app.exits import fail
    from mcnkit.metrics import EvaluationError, absolute_trajectory_error, read_tum, relative_pose_error

    options = {"match": args.match, "min_matched": args.min_matched, "min_fraction": args.min_fraction}
    try:
        traj: Trajectory = _read(read_tum, args.trajectory, "trajectory", "ate")
        ref: Trajectory = _reference(args.reference)
        ate = absolute_trajectory_error(traj, ref, args.tolerance_s, scale=args.scale, **options)
        rpe = relative_pose_error(traj, ref, args.tolerance_s, **options)
    except _Refused as exc:
        return fail(_command(args), exc)
    except EvaluationError as exc:
        return fail(_command(args), f"{args.trajectory}: {exc}")
    if args.json:
        print(json.dumps({"ate": ate.as_dict(), "rpe": rpe.as_dict(), "n_reference": len(ref), "match": args.match}))
    else:
        scaled = f" after a similarity alignment (scale {ate.scale:.5f})" if args.scale else ""
        print(
            f"ATE rmse {ate.rmse_m:.4f} m (mean {ate.mean_m:.4f}, max {ate.max_m:.4f}){scaled} over {ate.n_matched} of "
            f"{len(ref)} reference poses (matched by {args.match}); "
            f"RPE {rpe.translation_mean_m:.4f} ± {rpe.translation_std_m:.4f} m, "
            f"{rpe.rotation_mean_deg:.3f} ± {rpe.rotation_std_deg:.3f} deg"
        )
    return 0


def _poses_per_scan(traj: Trajectory, stamps_ns: Any, path: Path, match: str, tolerance_s: float) -> Any:
    """The trajectory's pose (N, 3) for each of the log's N scans, or :class:`_Refused`."""
    import numpy as np

    from mcnkit.metrics import match_stamps

    if match == "order":
        if len(traj) != len(stamps_ns):
            raise _Refused(f"{path}: {len(traj)} poses but the log has {len(stamps_ns)} scans ('--match order' pairs "
                           "the k-th pose with the k-th scan)")
        return traj.poses
    order = np.argsort(traj.stamps_ns, kind="stable")
    if np.any(np.diff(traj.stamps_ns[order]) == 0):
        raise _Refused(f"{path}: stamps repeat; use '--match order' if it holds one pose per scan of the log")
    k = match_stamps(traj.stamps_ns[order], stamps_ns, tolerance_s)
    if np.any(k < 0):
        raise _Refused(f"{path}: {int(np.count_nonzero(k < 0))} of the log's {len(stamps_ns)} scans have no pose within "
                       f"{tolerance_s} s: not a trajectory of this log, or one that skips scans")
    return traj.poses[order[k]]


def run_eval_consistency(args: argparse.Namespace) -> int:
    """Prints, for each trajectory, its error on the relations the log's scans measure (see the command's help)."""
    import warnings

    import numpy as np

    from mcnkit.app.exits import fail
    from mcnkit.io import LogError, open_log
    from mcnkit.metrics import read_tum
    from mcnkit.slam.scanrelations import consistency, scan_returns

    if args.plot is not None:
        from mcnkit.app.outputs import Output, OutputError, check_outputs

        if args.plot.suffix.lower() != ".png":
            return fail(_command(args), f"{args.plot}: --plot writes a PNG file (a name ending in .png)")
        try:
            check_outputs([args.log, *args.trajectories], [Output(args.plot)], overwrite=args.overwrite)
        except OutputError as exc:
            return fail(_command(args), exc)
    try:
        trajectories = [_read(read_tum, path, "trajectory", "consistency") for path in args.trajectories]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the reader's notes on stamps and odometry: `mcnkit info` prints them
            with open_log(args.log) as reader:
                frames = list(reader.frames())
    except _Refused as exc:
        return fail(_command(args), exc)
    except LogError:
        if args.log.is_file() and _reads_as(read_tum, args.log):
            return fail(_command(args), f"{args.log}: a TUM trajectory, not a robot log ({_ORDER['consistency']})")
        raise
    if len(frames) < 3:
        return fail(_command(args), f"{args.log}: {len(frames)} scans: too few to measure relations")
    stamps = np.array([frame.stamp_ns for frame in frames], np.int64)
    try:
        poses = [_poses_per_scan(t, stamps, p, args.match, args.tolerance_s)
                 for t, p in zip(trajectories, args.trajectories, strict=True)]
    except _Refused as exc:
        return fail(_command(args), exc)
    returns = scan_returns([frame.scan for frame in frames])
    progress = None
    if not args.no_progress:
        from tqdm import tqdm

        def progress(rows: Any, kind: str) -> Any:
            return tqdm(rows, desc=f"{kind} pairs", unit="pair", leave=False)
    results = consistency(returns, poses, progress=progress)
    out: dict[str, Any] = {"log": str(args.log), "scans": len(frames), "trajectories": {}}
    for kind, res in results.items():
        out[f"{kind}_pairs"], out[f"{kind}_relations"] = res.pairs, len(res.relations)
        for path, err in zip(args.trajectories, res.errors, strict=True):
            out["trajectories"].setdefault(str(path), {})[kind] = {
                "translation_mean_m": err.translation_mean_m if err else None,
                "rotation_mean_deg": err.rotation_mean_deg if err else None}
    if args.plot is not None:
        _write_plot(args, poses, returns, results)
        out["plot"] = str(args.plot)
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"{args.log}: {len(frames)} scans; relations measured by the scans: {out['sequential_relations']} sequential "
          f"(of {out['sequential_pairs']} pairs), {out['revisits_relations']} at revisits (of {out['revisits_pairs']}); "
          "mean error, lower = agrees better")
    for path, row in out["trajectories"].items():
        text = [f"{kind} {row[kind]['translation_mean_m']:.4f} m {row[kind]['rotation_mean_deg']:.3f} deg"
                if row[kind]["translation_mean_m"] is not None else f"{kind} -" for kind in ("sequential", "revisits")]
        print(f"  {path}: " + ", ".join(text))
    return 0


def _write_plot(args: argparse.Namespace, poses: list[Any], returns: list[Any], results: dict[str, Any]) -> None:
    """``--plot``: the consistency figure, written under a temporary name and renamed."""
    import numpy as np

    from mcnkit.viz.plots import consistency_figure

    pairs = {kind: np.column_stack([res.relations.t1_ns, res.relations.t2_ns]) for kind, res in results.items()}
    errors = {kind: [err.translation_m if err else np.zeros(0) for err in res.errors] for kind, res in results.items()}

    names = [path.name if len({p.name for p in args.trajectories}) == len(args.trajectories) else str(path)
             for path in args.trajectories]
    fig = consistency_figure(names, poses, returns, pairs, errors)
    args.plot.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{args.plot.name}.", suffix=".partial.png", dir=args.plot.parent)
    os.close(fd)
    try:
        fig.savefig(tmp, dpi=90)
        os.replace(tmp, args.plot)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def write_ground_truth(log_path: Path, output: Path, *, overwrite: bool = False) -> int:
    """Writes the ground-truth trajectory of the log at ``log_path`` as TUM into ``output`` (temporary name, then
    renamed); returns the number of poses.  :class:`~mcnkit.io.LogError` when the log has none, ``output`` is the
    log, or ``output`` exists and ``overwrite`` is not set."""
    from mcnkit.io import LogError, open_log
    from mcnkit.metrics import write_tum

    output = Path(output)
    if output.exists() and Path(log_path).exists() and os.path.samefile(output, log_path):
        raise LogError(output, "is the input log: choose another output file")
    if output.is_dir():
        raise LogError(output, "is a folder: give a file name for the TUM trajectory")
    if output.exists() and not overwrite:
        raise LogError(output, "exists (use --overwrite to replace it)")
    with open_log(log_path) as log:
        truth = log.ground_truth()
    if truth is None or len(truth) == 0:
        raise LogError(log_path, "this log carries no ground-truth trajectory (a Radish corrected CARMEN log, a "
                                 "ground-truth topic or a simulated log does)")
    output.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{output.name}.", suffix=".partial", dir=output.parent)
    os.close(fd)
    try:
        write_tum(Path(tmp), truth)
        os.replace(tmp, output)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)
    return len(truth)


def run_eval_groundtruth(args: argparse.Namespace) -> int:
    """``mcnkit eval groundtruth LOG OUT.tum``."""
    n = write_ground_truth(args.log, args.output, overwrite=args.overwrite)
    print(f"wrote {args.output}: {n} ground-truth poses of {args.log}")
    return 0
