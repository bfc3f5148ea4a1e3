"""The probe gate at the machine (issue 61 item 2): what one wrong probing does to a fused block's output, and how
fast a real move of the drift is followed, with the gate `fit --probe` chooses now (from the held-out
innovations) beside the gate it chose before (the widest multiple, in practice the limit).

Real data first: FL_THERMAL ch3 on t8, t4, t5, t11, trained until 100035 s, a probing every 120 calls (30 min) as
`fit --probe --probe-every 120` fuses it; then the twin campaign of docs/probing.md (8 runs of 8 h, the drift
probed every 30 min and held), leave one run out, every run replayed. Each fused block's float32 reference (the
block, bit for bit) is replayed with its probings clean, with one probing 20, 50 or 80 um off (a chip on the
probe; each probing of a run in turn), and with the drift stepped 10 um up between two probings (the machine
moved): the largest change of the output from the clean replay, and the error to the stepped drift just after
the first and the second probing that follows the step.

    python -m benchmarks.probe_gate
"""
from __future__ import annotations

import thermoplc  # noqa: F401,E402  (before numpy: it pins OpenBLAS's kernels and threads)

from dataclasses import replace
from pathlib import Path

import numpy as np

from thermoplc.contract.outputs import PROBE_NEW_INPUT, PROBE_VALUE_INPUT
from thermoplc.fitting.crossval import fit_held_out
from thermoplc.fitting.fit import FitRequest
from thermoplc.fitting.probe_fit import fit_probe
from benchmarks.campaign import twin_runs
from thermoplc.machines.campaign import TARGET, TRUTH
from thermoplc.models.probing import Fusion, probings, rising
from thermoplc.models.reference import block_outputs, model_inputs
from thermoplc.models.safety import Limits
from thermoplc.recordings.table import read_table
from thermoplc.verifier.replays.probings import reference_keys

FL = Path(__file__).resolve().parent.parent / "thermoplc" / "data" / "fl_thermal" / "fl_thermal.csv"
OFF_UM = (20.0, 50.0, 80.0)
STEP_UM = 10.0


def _output(model, table, value, new) -> np.ndarray:
    inputs = {**model_inputs(model, table), **reference_keys({PROBE_VALUE_INPUT: value, PROBE_NEW_INPUT: new})}
    return np.asarray(block_outputs(model, inputs, "f32", Limits())[model.target.name], np.float64)


def judge(model, table, every: int | None) -> dict:
    """How much further from the drift one probing OFF_UM off puts the output than the clean replay does (the
    largest over the calls, each probing but the first in turn), and the error to a drift stepped STEP_UM up
    after the second probing, just before the probing that follows the first and the second probing after it
    (the output limiter moves the axis at most its step per call, so the error is read when the move is done)."""
    target = table.column(model.target.column)
    truth = table.columns.get(TRUTH, target)
    value, new = probings(target, every)
    value, new = np.asarray(value, np.float32), np.asarray(new, bool)
    clean = _output(model, table, value, new)
    clean_error = np.abs(clean - truth)
    edges = np.flatnonzero(rising(new))
    further, own = {}, {}
    missing = {}  # each probing's pulse left out: the block without that probing
    for at in edges[1:]:
        gone = new.copy()
        gone[at:at + 3] = False
        missing[at] = _output(model, table, value, gone)
    for off in OFF_UM:
        worst, moved = 0.0, 0.0
        for at in edges[1:]:  # the first is taken whatever it reads (nothing learnt yet)
            wrong = value.copy()
            wrong[at:at + 3] = wrong[at] + np.float32(off)  # the pulse of three calls a PLC holds
            out = _output(model, table, wrong, new)
            worst = max(worst, float(np.nanmax(np.abs(out - truth) - clean_error)))
            moved = max(moved, float(np.max(np.abs(out - missing[at]))))
        further[off], own[off] = worst, moved
    after = []
    if len(edges) > 5:
        step_at = edges[1] + 1
        stepped = np.where(np.arange(len(target)) >= step_at, target + STEP_UM, target)
        s_value, s_new = probings(stepped, every)
        out = _output(model, table, np.asarray(s_value, np.float32), np.asarray(s_new, bool))
        after = [abs(float(out[e - 1] - (truth[e - 1] + STEP_UM))) for e in edges[3:5]]
    return {"further": further, "own": own, "after_step": after}


def _old_gate(model):
    """The fusion with the gate it would have had before: the limit (what the widest multiple reached)."""
    f = model.probe
    return replace(model, probe=Fusion.of(f.value("gain", "f64"), f.value("limit_um", "f64"), f.value("limit_um", "f64"),
                                          f.value("offset_max_um", "f64"),
                                          f.value("rate_gain", "f64") if f.has_rate else None,
                                          f.value("rate_max_um", "f64") if f.has_rate else None,
                                          f.value("decay", "f64") if f.decay else None))


def fl_thermal():
    table = read_table(str(FL))
    request = FitRequest("mlr", "ch3_um", ("t8_C", "t4_C", "t5_C", "t11_C"), train_until=100035.0)
    model = fit_probe(fit_held_out([table], request, None), [table], {}, 120, False)
    return "FL_THERMAL ch3, probing every 30 min", model, [(table, 120)]


def twin():
    campaign = twin_runs("cascade", 11, 8, 8.0, 30.0)
    request = FitRequest("mlr", TARGET, ("T_motor", "T_bearing"))
    predictions: dict = {}
    model = fit_held_out(campaign.tables, request, len(campaign.tables), predictions=predictions)
    model = fit_probe(model, campaign.tables, predictions, None, True)
    return "twin campaign, 8 runs, probed every 30 min", model, [(t, None) for t in campaign.tables]


def main() -> None:
    print(f"{'data':<44}{'gate um':>18}{'one probing off by 20 / 50 / 80 um':>40}{'after a 10 um step':>24}")
    print(f"{'':<44}{'':>18}{'moved it (um)':>20}{'further (um)':>20}{'1st':>12}{'2nd':>12}")
    for name, model, runs in (fl_thermal(), twin()):
        for label, fused in (("chosen", model), ("limit (before)", _old_gate(model))):
            found = [judge(fused, table, every) for table, every in runs]
            own = " / ".join(f"{max(f['own'][off] for f in found):.1f}" for off in OFF_UM)
            further = " / ".join(f"{max(f['further'][off] for f in found):.1f}" for off in OFF_UM)
            steps = [f["after_step"] for f in found if f["after_step"]]
            first, second = (max(s[k] for s in steps) for k in (0, 1))
            gate = fused.probe.value("gate_um", "f64")
            print(f"{name:<44}{f'{label} {gate:.3g}':>18}{own:>20}{further:>20}{first:>12.2f}{second:>12.2f}")
    print("moved it: the largest |output with the wrong probing - output without that probing| (what the wrong value\n"
          "  itself did); further: the largest (|output - drift| with it) - (|output - drift| with the probing clean),\n"
          "  which also holds the correction a refused probing no longer makes; each probing of each run in turn, the\n"
          "  worst; after a step: the largest error to the stepped drift over the runs, just before the probing after\n"
          "  the 1st and the 2nd probing that follow the step (the output limiter moves the axis a step per call)")


if __name__ == "__main__":
    main()
