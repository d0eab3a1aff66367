"""ROS2 bag folders that rosbag2 compressed itself (``ros2 bag record --compression-mode file|message``, zstd) read
back frame for frame as the uncompressed bag, in both storages; rosbags, an independent reader, reads what
``write_log(..., compression=...)`` writes; damage is one line naming the compressed file."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import pytest
from rosbags.rosbag2 import Reader as RosbagsReader
from ruamel.yaml import YAML

from mcnkit.app.main import main
from mcnkit.io import LogContent, LogError, open_log, write_log
from mcnkit.io.info import describe
from mcnkit.types import Frame
from tests.io.test_roundtrip import assert_same_frames

STORAGES = ("ros2-sqlite3", "ros2-mcap")


def _copies() -> set[str]:
    """The reader's temporary folders of decompressed bag files (other programs' files in the temporary folder are
    not its business)."""
    return {n for n in os.listdir(tempfile.gettempdir()) if n.startswith("mcnkit-bag-")}


def _metadata(bag: Path) -> dict:
    return YAML(typ="safe").load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]


@pytest.mark.parametrize("storage", STORAGES)
@pytest.mark.parametrize("mode", ["file", "message"])
def test_a_compressed_bag_reads_as_the_uncompressed_one(tmp_path: Path, frames: list[Frame], storage: str,
                                                        mode: str) -> None:
    bag = write_log(tmp_path / "bag", LogContent(frames), storage, compression=mode)
    info = _metadata(bag)
    assert (info["compression_mode"], info["compression_format"]) == (mode.upper(), "zstd")
    names = sorted(p.name for p in bag.iterdir())
    assert all(n.endswith(".zstd") for n in names if n != "metadata.yaml") == (mode == "file")
    temp_before = _copies()
    with open_log(bag) as log:
        assert log.format == storage
        assert_same_frames(frames, list(log.frames()))
        assert {t.name: t.count for t in log.topics}["/scan"] == len(frames)
        assert describe(log)["compression"] == log.compression  # what mcnkit info shows beside the format
        assert log.compression is not None and ("each message" if mode == "message" else "whole file") in log.compression
    assert _copies() <= temp_before  # a decompressed copy is removed on close
    with open_log(write_log(tmp_path / "plain", LogContent(frames), storage)) as plain:
        assert plain.compression is None
    with RosbagsReader(bag) as reader:  # the format rosbag2 writes, as an independent reader understands it
        assert sum(1 for c, _, _ in reader.messages() if c.topic == "/scan") == len(frames)


def test_mode_names_are_read_in_any_case_and_a_bag_cut_short_has_no_metadata(tmp_path: Path,
                                                                               frames: list[Frame]) -> None:
    bag = write_log(tmp_path / "bag", LogContent(frames), "ros2-mcap", compression="file")
    meta = bag / "metadata.yaml"
    meta.write_text(meta.read_text().replace("compression_mode: FILE", "compression_mode: file"))
    with open_log(bag) as log:
        assert_same_frames(frames, list(log.frames()))
    meta.unlink()  # a recording killed before rosbag2 wrote its metadata: the files are found by their names
    with open_log(bag) as log:
        assert_same_frames(frames, list(log.frames()))


def test_an_unknown_compression_is_one_line_naming_the_bag(tmp_path: Path, frames: list[Frame]) -> None:
    bag = write_log(tmp_path / "bag", LogContent(frames), "ros2-sqlite3", compression="message")
    meta = bag / "metadata.yaml"
    meta.write_text(meta.read_text().replace("compression_format: zstd", "compression_format: lz4"))
    with pytest.raises(LogError, match="'lz4' compression is not supported") as err:
        open_log(bag)
    assert err.value.path == bag


def test_a_damaged_compressed_file_is_named_and_leaves_no_temporary_copy(tmp_path: Path,
                                                                        frames: list[Frame]) -> None:
    bag = write_log(tmp_path / "bag", LogContent(frames), "ros2-sqlite3", compression="file")
    (packed,) = bag.glob("*.db3.zstd")
    packed.write_bytes(packed.read_bytes()[: packed.stat().st_size // 3])
    temp_before = _copies()
    with pytest.raises(LogError) as err:
        with open_log(bag) as log:
            list(log.frames())
    assert err.value.path == packed
    assert _copies() <= temp_before


def test_a_damaged_message_is_skipped_and_counted(tmp_path: Path, frames: list[Frame]) -> None:
    import sqlite3

    bag = write_log(tmp_path / "bag", LogContent(frames), "ros2-sqlite3", compression="message")
    (db,) = bag.glob("*.db3")
    with sqlite3.connect(db) as con:
        (tid,) = con.execute("SELECT id FROM topics WHERE name = '/scan'").fetchone()
        (mid,) = con.execute("SELECT min(id) FROM messages WHERE topic_id = ?", (tid,)).fetchone()
        con.execute("UPDATE messages SET data = ? WHERE id = ?", (b"not zstd at all", mid))
    with open_log(bag) as log, pytest.warns(UserWarning, match="1 message"):
        assert len(list(log.frames())) == len(frames) - 1


def test_convert_writes_a_compressed_bag_and_refuses_compression_for_a_single_file(
        tmp_path: Path, frames: list[Frame], capsys: pytest.CaptureFixture[str]) -> None:
    src = write_log(tmp_path / "in.bag", LogContent(frames))
    assert main(["convert", str(src), str(tmp_path / "out"), "--format", "ros2-mcap", "--compression", "file",
                 "--quiet"]) == 0
    assert "file-compressed" in capsys.readouterr().out
    with open_log(tmp_path / "out") as log:
        assert_same_frames(frames, list(log.frames()))
    assert main(["convert", str(src), str(tmp_path / "out.mcap"), "--compression", "message", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "out.mcap" in err and "rosbag2 folders" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out.mcap").exists()
