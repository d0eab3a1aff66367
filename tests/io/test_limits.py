"""Limits that say no: what no reader should hold, or never stops reading, is refused with one line (exit 2)."""

from __future__ import annotations

import contextlib
import gzip
import io
import os
import time
from pathlib import Path

import numpy as np
import pytest

from mcnkit.io import LogContent, LogError, open_log, write_log
from mcnkit.io.errors import one_line
from mcnkit.io.limits import MAX_LINE_BYTES, MAX_MESSAGE_BYTES
from mcnkit.types import Frame, LidarSpec, Scan
from tests.conftest import make_frames


def _info(path: Path) -> tuple[int, str]:
    from mcnkit.app.main import main

    err = io.StringIO()
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(err):
        code = main(["info", str(path)])
    return code, err.getvalue()


def _refused_in_one_line(path: Path, match: str) -> None:
    t0 = time.perf_counter()
    with pytest.raises(LogError, match=match) as caught:
        open_log(path)
    assert "\n" not in str(caught.value) and time.perf_counter() - t0 < 10
    code, err = _info(path)
    assert code == 2 and len(err.strip().splitlines()) == 1 and err.startswith("mcnkit info: ")


@pytest.mark.parametrize("name", ["run.log", "run.log.gz", "run.bag", "run.mcap", "run.clf"])
def test_a_link_to_dev_zero_is_not_a_regular_file(tmp_path: Path, name: str) -> None:
    (tmp_path / name).symlink_to("/dev/zero")
    _refused_in_one_line(tmp_path / name, r"not a regular file: a character device \(links to /dev/zero\)")


@pytest.mark.parametrize("layout", ["metadata", "no metadata"])
def test_a_rosbag2_folder_whose_mcap_links_to_dev_zero(tmp_path: Path, layout: str) -> None:
    bag = write_log(tmp_path / "bag", LogContent(make_frames()), "ros2-mcap")
    mcap = next(bag.glob("*.mcap"))
    mcap.unlink()
    mcap.symlink_to("/dev/zero")
    if layout == "no metadata":
        (bag / "metadata.yaml").unlink()
    _refused_in_one_line(bag, "not a regular file: a character device")


def test_a_metadata_file_that_links_to_dev_zero(tmp_path: Path) -> None:
    bag = write_log(tmp_path / "bag", LogContent(make_frames()), "ros2-sqlite3")
    (bag / "metadata.yaml").unlink()
    (bag / "metadata.yaml").symlink_to("/dev/zero")
    _refused_in_one_line(bag, "metadata.yaml: not a regular file")


def test_a_fifo_is_refused_without_blocking(tmp_path: Path) -> None:
    os.mkfifo(tmp_path / "run.bag")
    _refused_in_one_line(tmp_path / "run.bag", "not a regular file: a FIFO")


@pytest.mark.parametrize("first", ["FLASER 181 ", "AAAA", ""])
def test_a_gzip_log_of_one_line_without_a_newline(tmp_path: Path, first: str) -> None:
    path = tmp_path / "one-line.log.gz"
    with gzip.open(path, "wb") as f:
        f.write(first.encode() + b"1.0 " * (3 * MAX_LINE_BYTES // 4))
    # refused at the line's limit, or, as this line compresses 1000 times, at the ratio's
    _refused_in_one_line(path, "(line 1 is longer than|decompresses to more than 200 times)")


def test_a_long_line_of_a_text_log_is_refused_after_the_limit(tmp_path: Path) -> None:
    path = tmp_path / "run.clf"
    line = "FLASER 3 1.0 1.0 1.0 0 0 0 0 0 0 1.0 host 1.0\n"
    path.write_text(line * 5 + "GPSNMEA " + "x" * (MAX_LINE_BYTES + 10) + "\n" + line)
    _refused_in_one_line(path, r"line 6 is longer than")


def test_a_compression_bomb_is_stopped_by_its_ratio(tmp_path: Path) -> None:
    path = tmp_path / "bomb.mcap.gz"
    record = b"\x10" + (0).to_bytes(8, "little")  # an MCAP record of an unknown opcode, empty: valid, and skipped
    with gzip.open(path, "wb") as f:
        f.write(b"\x89MCAP0\r\n")
        for _ in range(64):
            f.write(record * (1 << 17))  # 72 MiB in all, compressing about 1000 times
    _refused_in_one_line(path, "decompresses to more than 200 times its size")


def _one_big_scan(path: Path, fmt: str) -> Path:
    frames = make_frames(n=5, beams=8)
    n = MAX_MESSAGE_BYTES // 4 + 10
    spec = LidarSpec(-np.pi, 2 * np.pi / n, n, 0.1, 10.0)
    big = Frame(frames[-1].stamp_ns + 100_000_000, Scan(np.ones(n, np.float32), spec), frames[-1].odom)
    return write_log(path, LogContent([*frames, big]), fmt)


@pytest.mark.parametrize(("fmt", "name"), [("ros1", "big.bag"), ("mcap", "big.mcap"), ("ros2-sqlite3", "big_sqlite3")])
def test_a_scan_message_larger_than_any_laser_scan_is_refused(tmp_path: Path, fmt: str, name: str) -> None:
    path = _one_big_scan(tmp_path / name, fmt)
    with pytest.raises(LogError, match=r"a message on /scan at \d+ ns of 1,8\d\d,\d\d\d bytes is larger than this reader holds \(1,848,576"):
        with open_log(path) as log:
            for _ in log.messages("/scan"):
                pass


def test_library_messages_of_several_lines_are_folded_into_one() -> None:
    report = "*** in database main ***\nPage 5: btreeInitPage() returns error code 11\n\n  Page 7: never used"
    assert one_line(report) == ("*** in database main ***; Page 5: btreeInitPage() returns error code 11; "
                                "Page 7: never used")
    assert str(LogError("x.db3", f"not a readable rosbag2 sqlite3 file ({report})")).count("\n") == 0


def test_a_damaged_sqlite_bag_warns_in_one_line(tmp_path: Path) -> None:
    bag = write_log(tmp_path / "bag", LogContent(make_frames(n=200, beams=60)), "ros2-sqlite3")
    db = next(bag.glob("*.db3"))
    raw = bytearray(db.read_bytes())
    page = 4096
    for p in range(2, len(raw) // page):  # every b-tree page header but the first pages: the integrity check fails
        raw[p * page] = 0x55
    db.write_bytes(bytes(raw))
    code, err = _info(bag)
    assert code in (0, 2)
    assert all(line.startswith(("warning:", "mcnkit info:")) for line in err.strip().splitlines())
