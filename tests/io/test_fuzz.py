"""Property: whatever bytes a log holds, reading it either works (maybe with warnings) or raises LogError.

Small logs in every format are corrupted by flipping bytes and cutting them short; the reader is then asked
for everything a user can ask (topics, time range, scanner, frames, ground truth, every message).
"""

from __future__ import annotations

import shutil
import warnings
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mcnkit.io import LogContent, LogError, open_log, write_log
from tests.conftest import make_frames

_FORMATS = {"ros1": "log.bag", "mcap": "log.mcap", "mcap-ros1": "ros1.mcap", "ros2-sqlite3": "sq", "ros2-mcap": "mc"}
_CLEAN: dict[str, Path] = {}


def _clean_log(fmt: str, root: Path) -> Path:
    if fmt not in _CLEAN:
        _CLEAN[fmt] = write_log(root / _FORMATS[fmt], LogContent(make_frames(n=12, beams=6)), fmt)
    return _CLEAN[fmt]


def _data_file(path: Path) -> Path:
    return next(p for p in sorted(path.iterdir()) if p.suffix in (".db3", ".mcap")) if path.is_dir() else path


def _read_everything(path: Path) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with open_log(path) as log:
            log.time_range_ns()
            for topic in log.topics:
                for _ in log.messages(topic.name):
                    pass
            if log.scan_topic and log.odom_source:
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
