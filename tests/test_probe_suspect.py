"""A frozen, stuck or flooding probe sets ProbeSuspect and stops the offset learning (issue 61 item 3)."""
from __future__ import annotations

import numpy as np
import pytest

from thermoplc.models.probing import HELD_MAX, REFUSED, SUSPECT, USED, Fusion, fuse, probings, rising

FUSION = Fusion.of(0.5, 5.0, 100.0, 100.0, min_calls=50)


def _edges(rows: int, at: list[int], held: int = 3) -> np.ndarray:
    new = np.zeros(rows, bool)
    for k in at:
        new[k:k + held] = True
    return new


@pytest.mark.parametrize("precision", ["f32", "f64"])
def test_a_frozen_probe_is_suspect_at_its_third_equal_probing_once_the_prediction_moved_beyond_the_gate(precision):
    rows = 1000
    static = np.linspace(0.0, 40.0, rows)  # the model moves 40 um; the probe keeps reading 1.0
    value = np.full(rows, 1.0)
    new = _edges(rows, [100, 200, 300, 400, 500])
    out = fuse(FUSION, static, value, new, precision)
    edges = np.flatnonzero(rising(new))
    assert not out[SUSPECT][:300].any()  # two equal probings say nothing yet
    assert out[SUSPECT][300] and out[REFUSED][300] and not out[USED][300]  # the third: 8 um moved, gate 5
    assert out[SUSPECT][edges[-1]:].all()
    offset = out["fused"].astype(np.float64) - static
    assert np.ptp(offset[300:]) < 1e-5  # learning stopped: the offset holds (to the rounding of static + offset)


def test_a_frozen_probe_of_a_machine_that_did_not_move_is_no_suspect():
    rows = 1000
    out = fuse(FUSION, np.full(rows, 1.5), np.full(rows, 1.0), _edges(rows, [100, 200, 300, 400, 500]), "f32")
    assert not out[SUSPECT].any() and out[USED].sum() == 5


def test_probenew_held_true_is_suspect_after_held_max_calls_and_the_next_plausible_probing_clears_it():
    rows = 600
    static = np.zeros(rows)
    value = np.linspace(0.0, 1.0, rows)
    new = _edges(rows, [100, 400])
    new[200:200 + HELD_MAX + 5] = True  # a stuck bit: one edge, then TRUE for 25 calls
    out = fuse(FUSION, static, value, new, "f32")
    assert not out[SUSPECT][:200 + HELD_MAX].any() and out[SUSPECT][200 + HELD_MAX]
    assert out[SUSPECT][200 + HELD_MAX:400].all() and not out[SUSPECT][400:].any()
    assert out[USED][400]


def test_probings_faster_than_the_schedule_are_suspect_and_refused():
    rows = 600
    static = np.zeros(rows)
    value = np.full(rows, 2.0)
    value[300:] = np.linspace(2.0, 3.0, rows - 300)
    new = _edges(rows, [100, 200, 210, 220, 400], held=2)
    out = fuse(FUSION, static, value, new, "f32")
    assert out[USED][100] and out[USED][200]
    assert out[SUSPECT][210] and out[REFUSED][210] and out[SUSPECT][220] and out[REFUSED][220]
    assert out[USED][400] and not out[SUSPECT][400]
    no_schedule = fuse(Fusion.of(0.5, 5.0, 100.0, 100.0), static, value, new, "f32")
    assert not no_schedule[SUSPECT].any()  # a model file without a schedule judges no flood


def test_the_fitted_schedule_lets_every_probing_of_the_fitted_runs_through():
    from thermoplc.fitting.probe_fit import min_calls
    from types import SimpleNamespace
    target = np.zeros(1000)
    runs = [SimpleNamespace(target=target)]
    assert min_calls(runs, None, 120) == 60
    value, new = probings(target, 120)
    out = fuse(Fusion.of(0.5, 5.0, 100.0, 100.0, min_calls=60), np.zeros(1000), value, new, "f32")
    assert not out[SUSPECT].any() and out[USED].sum() == len(np.flatnonzero(rising(new)))
