from __future__ import annotations

import numpy as np
import pytest

from mcnkit.completion.retrieval import retrieve
from mcnkit.completion.scores import mean_ci95, score_maps

F, U, OC = 0.0, 0.5, 1.0


def test_hand_computed_free_scores() -> None:
    target = np.array([[[F, F], [OC, OC]]], np.float32)
    partial = np.array([[[F, U], [U, U]]], np.float32)
    pred = np.array([[[F, OC], [F, OC]]], np.float32)  # tp 1, fn 1, fp 1, tn 1
    s = score_maps(pred, target, partial, "free")
    assert (s.accuracy, s.precision, s.recall, s.f_measure) == (0.5, 0.5, 0.5, 0.5)
    # unknown cells (0,1) F→OC, (1,0) OC→F, (1,1) OC→OC: free IoU 0/2, occupied IoU 1/3
    assert s.miou_unknown == pytest.approx((0 + 1 / 3) / 2)
    o = score_maps(pred, target, partial, "occupied")
    assert o.f_measure == pytest.approx(0.5)


def test_partial_map_has_full_precision_and_unknown_is_negative() -> None:
    target = np.array([[[F, F], [F, OC]]], np.float32)
    partial = np.array([[[F, U], [U, OC]]], np.float32)
    s = score_maps(partial, target, partial, "free")
    assert s.precision == 1.0 and s.recall == pytest.approx(1 / 3)
    assert s.miou_unknown == 0.0


def test_ci_and_shapes() -> None:
    mean, ci = mean_ci95(np.array([0.0, 1.0, 0.0, 1.0]))
    assert mean == 0.5 and ci == pytest.approx(1.96 * np.std([0, 1, 0, 1], ddof=1) / 2)
    with pytest.raises(ValueError, match="shapes differ"):
        score_maps(np.zeros((1, 2, 2)), np.zeros((1, 3, 3)), np.zeros((1, 2, 2)))


def test_retrieval_picks_best_agreement_and_keeps_observed() -> None:
    bank = np.array([[[F, F], [F, F]], [[F, OC], [OC, OC]], [[OC, OC], [OC, OC]]], np.float32)
    partial = np.array([[[F, U], [U, OC]]], np.float32)
    r = retrieve(partial, bank)
    assert r.index.tolist() == [1] and r.score.tolist() == [1.0]
    assert r.prediction[0].tolist() == [[F, OC], [OC, OC]]
