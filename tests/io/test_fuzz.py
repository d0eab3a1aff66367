"""Property: whatever bytes a log holds, reading it either works (maybe with warnings) or raises LogError.

Small logs in every format are corrupted by flipping bytes and cutting them short; the reader is then asked
for everything a user can ask (topics, time range, scanner, frames, ground truth, every message).
"""

from __future__ import annotations

import contextlib
import gzip
import io
import random
import shutil
import warnings
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mcnkit.io import LogContent, LogError, LogWarning, open_log, write_log
from mcnkit.types import Frame
from tests.conftest import make_frames

_FORMATS = {"ros1": "log.bag", "mcap": "log.mcap", "mcap-ros1": "ros1.mcap", "ros2-sqlite3": "sq", "ros2-mcap": "mc",
            "ros2-sqlite3-file": "sqz", "ros2-mcap-message": "mcm"}
_COMPRESSED = {"ros2-sqlite3-file": ("ros2-sqlite3", "file"), "ros2-mcap-message": ("ros2-mcap", "message")}
_CLEAN: dict[str, Path] = {}


def _clean_log(fmt: str, root: Path) -> Path:
    if fmt not in _CLEAN:
        base, compression = _COMPRESSED.get(fmt, (fmt, None))
        _CLEAN[fmt] = write_log(root / _FORMATS[fmt], LogContent(make_frames(n=12, beams=6)), base,
                                compression=compression)
    return _CLEAN[fmt]


def _data_file(path: Path) -> Path:
    return next(p for p in sorted(path.iterdir()) if p.name.endswith((".db3", ".mcap", ".zstd"))) \
        if path.is_dir() else path


def _read_everything(path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with open_log(path) as log:
            log.time_range_ns()
            for topic in log.topics:
                for _ in log.messages(topic.name):
                    pass
            if log.scan_topic:
                assert log.lidar_spec.n_beams > 0
                for _ in log.frames():
                    pass
            log.ground_truth()


@pytest.fixture(scope="module")
def clean_root(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("clean")


@pytest.mark.slow
@pytest.mark.parametrize("fmt", list(_FORMATS))
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_corrupted_logs_raise_only_log_error(
    fmt: str, data: st.DataObject, clean_root: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    clean = _clean_log(fmt, clean_root)
    raw = bytearray(_data_file(clean).read_bytes())
    for _ in range(data.draw(st.integers(0, 8), label="flips")):
        i = data.draw(st.integers(0, len(raw) - 1), label="where")
        raw[i] = data.draw(st.integers(0, 255), label="byte")
    cut = data.draw(st.integers(1, len(raw)), label="cut")
    work = tmp_path_factory.mktemp("fuzz")
    if clean.is_dir():
        target = work / clean.name
        shutil.copytree(clean, target)
        _data_file(target).write_bytes(bytes(raw[:cut]))
    else:
        target = work / clean.name
        target.write_bytes(bytes(raw[:cut]))
    try:
        _read_everything(target)
    except LogError as err:
        assert str(err).startswith(str(target)) and "\n" not in str(err)


_REAL_FIXTURES = ["rosbag_analyzer_web/test_sample.bag", "rosbag_analyzer_web/test_sample.mcap",
                  "rosbag_analyzer_web/test_sample_no_rosout.bag", "rosbag_js/example-unsorted-chunks.bag"]


@pytest.mark.slow
@pytest.mark.parametrize("name", _REAL_FIXTURES)
@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_corrupted_bags_written_by_ros_tools_raise_only_log_error(
    name: str, data: st.DataObject, shared_data: Path, tmp_path_factory: pytest.TempPathFactory
) -> None:
    raw = bytearray((shared_data / "fixtures" / name).read_bytes())
    for _ in range(data.draw(st.integers(0, 8), label="flips")):
        raw[data.draw(st.integers(0, len(raw) - 1), label="where")] = data.draw(st.integers(0, 255), label="byte")
    target = tmp_path_factory.mktemp("fuzz") / Path(name).name
    target.write_bytes(bytes(raw[: data.draw(st.integers(1, len(raw)), label="cut")]))
    try:
        _read_everything(target)
    except LogError as err:
        assert str(err).startswith(str(target)) and "\n" not in str(err)


# -- seeded byte-flip mutants of every format, as benchmarks/bench_fuzz.py runs them (smaller) ------------------------

_MUTANT_FORMATS = {"ros1": "log.bag", "mcap": "log.mcap", "ros2-sqlite3": "log_sqlite3", "carmen": "log.log"}


def _physically_possible(frames: list[Frame]) -> str | None:
    """Independent of mcnkit.io.plausible: a scanner reaching 0 to 1 km (any reading outside its interval is "no
    return", REP 117), finite odometry moving at most 10 m/s (+2 m) and 2π rad/s (+1 rad), stamps that do not go
    back."""
    prev = None
    for f in frames:
        spec = f.scan.spec
        if not 0 <= spec.range_min_m < spec.range_max_m <= 1000:
            return f"range interval {spec.range_min_m}..{spec.range_max_m}"
        o = f.odom.as_array()
        if not np.isfinite(o).all():
            return f"odometry {o}"
        if prev is not None:
            dt = (f.stamp_ns - prev.stamp_ns) / 1e9
            da = abs((o[2] - prev.odom.yaw_rad + np.pi) % (2 * np.pi) - np.pi)
            if dt < 0 or np.hypot(o[0] - prev.odom.x_m, o[1] - prev.odom.y_m) > 10 * dt + 2 or da > 2 * np.pi * dt + 1:
                return f"step from {prev.odom} to {f.odom} in {dt} s"
        prev = f
    return None


@pytest.fixture(scope="module")
def mutant_sources(tmp_path_factory: pytest.TempPathFactory, shared_data: Path) -> dict[str, tuple[Path, list[Frame]]]:
    root = tmp_path_factory.mktemp("sources")
    lines, scans = [], 0
    with gzip.open(shared_data / "reallab" / "intel" / "intel-corrected.log.gz", "rt", encoding="ascii") as f:
        for line in f:
            if line.startswith("FLASER"):
                if scans == 120:
                    break
                scans += 1
            lines.append(line)
    carmen = root / "log.log"
    carmen.write_text("".join(lines))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with open_log(carmen) as log:
            content = LogContent(list(log.frames()), ground_truth=log.ground_truth())
    out = {"carmen": (carmen, list(content.frames))}
    for fmt in ("ros1", "mcap", "ros2-sqlite3"):
        path = write_log(root / _MUTANT_FORMATS[fmt], content, fmt)
        with open_log(path) as log:
            out[fmt] = (path, list(log.frames()))
    return out


def _same(a: list[Frame], b: list[Frame]) -> bool:
    return len(a) == len(b) and all(
        x.stamp_ns == y.stamp_ns and x.scan.ranges_m.tobytes() == y.scan.ranges_m.tobytes() and x.odom == y.odom
        for x, y in zip(a, b, strict=True))


@pytest.mark.parametrize("fmt", list(_MUTANT_FORMATS))
def test_byte_flip_mutants_are_refused_warned_or_plausible(
    fmt: str, mutant_sources: dict[str, tuple[Path, list[Frame]]], tmp_path: Path
) -> None:
    """20 seeded mutants per format (1-16 flipped bytes): `mcnkit info` exits 0 or 2 without a traceback; the frame
    read either refuses the log with one line or passes on only physically possible frames; an MCAP mutant that
    reads without a warning reads exactly the clean frames (its CRCs catch the rest); SLAM runs on what is read."""
    from mcnkit.app.main import main
    from mcnkit.slam import FastSlam, SlamConfig

    clean, clean_frames = mutant_sources[fmt]
    rng = random.Random(17 + list(_MUTANT_FORMATS).index(fmt))
    outcomes: Counter[str] = Counter()
    for k in range(20):
        raw = bytearray(_data_file(clean).read_bytes())
        for _ in range(rng.randint(1, 16)):
            raw[rng.randrange(len(raw))] ^= rng.randint(1, 255)
        target = tmp_path / str(k) / clean.name
        target.parent.mkdir()
        if clean.is_dir():
            shutil.copytree(clean, target)
            _data_file(target).write_bytes(bytes(raw))
        else:
            target.write_bytes(bytes(raw))
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()) as err:
            assert main(["info", str(target)]) in (0, 2)
        assert "Traceback" not in err.getvalue()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            try:
                with open_log(target) as log:
                    frames = list(log.frames())
            except LogError as e:
                assert str(e).startswith(str(target.parent)) and "\n" not in str(e)
                outcomes["refused"] += 1
                continue
        assert _physically_possible(frames) is None, f"mutant {k}: {_physically_possible(frames)}"
        warned = [w for w in caught if issubclass(w.category, LogWarning)]
        if fmt == "mcap" and not warned:
            assert _same(frames, clean_frames), f"mutant {k}: an MCAP changed without a warning"
        outcomes["warned" if warned else "same" if _same(frames, clean_frames) else "changed"] += 1
        if k % 3 == 0 and frames:
            slam = FastSlam(SlamConfig(n_particles=3), np.random.default_rng(0))
            for f in frames[:15]:
                slam.step(f)
    assert sum(outcomes.values()) == 20
