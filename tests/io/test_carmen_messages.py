"""Every line of a CARMEN log stays reachable through ``messages()``: the decoded streams and the raw lines."""

from __future__ import annotations

import gzip
from pathlib import Path

import numpy as np
import pytest

from mcnkit.io import CarmenLog, open_log
from mcnkit.io.carmen import CarmenRecord
from mcnkit.types import Pose2D, Scan


def test_intel_streams_and_lines(shared_data: Path) -> None:
    path = shared_data / "reallab/intel/intel-corrected.log.gz"
    with pytest.warns(UserWarning), open_log(path) as log:
        assert isinstance(log, CarmenLog)
        assert log.keywords == {"PARAM": 2, "ODOM": 14541, "FLASER": 910, "NEFF": 910}
        frames = list(log.frames())
        scans = list(log.messages("/scan"))
        assert [t for t, _ in scans] == [f.stamp_ns for f in frames]
        assert all(isinstance(s, Scan) for _, s in scans)
        np.testing.assert_array_equal(scans[5][1].ranges_m, frames[5].scan.ranges_m)
        odom = list(log.messages("/odom"))
        assert odom[7] == (frames[7].stamp_ns, frames[7].odom)
        truth = log.ground_truth()
        assert truth is not None
        gt = list(log.messages("/ground_truth"))
        assert len(gt) == 910 and isinstance(gt[0][1], Pose2D)
        np.testing.assert_allclose([gt[3][1].x_m, gt[3][1].y_m, gt[3][1].yaw_rad], truth.poses[3])
        flaser = list(log.messages("FLASER"))
        assert len(flaser) == 910 and all(isinstance(r, CarmenRecord) for _, r in flaser)
        first = flaser[0][1]
        assert first.keyword == "FLASER" and first.fields[0] == "180" and first.stamp_ns == 32_906_800_000
        raw_line = gzip.open(path, "rt").read().splitlines()[first.line - 1]
        assert raw_line.split() == ["FLASER", *first.fields]
        params = [r.fields[:2] for _, r in log.messages("PARAM")]
        assert params[0] == ("robot_frontlaser_offset", "0.0")
        neff = list(log.messages("NEFF"))
        assert len(neff) == 910 and neff[0][1].stamp_ns is None  # no stamp of its own: the last one before it
        assert list(log.messages("RAWLASER1")) == [] and list(log.messages("/no_such_topic")) == []


def test_a_dpslam_log_gives_its_lines_too(shared_data: Path) -> None:
    with open_log(shared_data / "reallab/dpslam-loop5/loop5.log") as log:
        assert log.keywords == {"Odometry": 551, "Laser": 551}
        lasers = list(log.messages("Laser"))
        assert len(lasers) == 551 and lasers[0][0] == 0 and int(lasers[0][1].fields[0]) == 181
        assert len(list(log.messages("/scan"))) == 551 and list(log.messages("/ground_truth")) == []
