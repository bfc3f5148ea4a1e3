"""Raw logger data onto the block's cycle (`--resample`, recordings/resample.py): the rule, and the CLI end to end."""
from __future__ import annotations

import json
from pathlib import Path

import jsonschema
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from tests.cli_runner import thermoplc
from tests.test_json_output import schema
from thermoplc import api
from thermoplc.base.errors import UserError
from thermoplc.recordings.resample import MAX_GAP_CALLS, Resampling, resample
from thermoplc.recordings.table import Table, read_table, write_table

FL_THERMAL = Path(api.__file__).parent / "data" / "fl_thermal" / "fl_thermal.csv"  # the copy the package ships


def _table(t, **columns) -> Table:
    return Table("raw.csv", {"time_s": np.asarray(t, float), **{k: np.asarray(v, float) for k, v in columns.items()}},
                 "0" * 64, np.arange(2, len(t) + 2))


def test_each_column_by_its_rule():
    t = [0.0, 9.5, 21.0, 39.0, 41.5, 80.5, 121.0]
    raw = _table(t, T=[20.0, 20.95, 22.1, 23.9, 24.15, 28.05, 32.1], rpm=[0, 1000, 1000, 2000, 2000, 0, 0],
                 probed=[np.nan, 5.0, np.nan, np.nan, 7.0, np.nan, np.nan],
                 held=[1.0, 1.0, 3.0, 3.0, 3.0, 3.0, 4.0])
    out = resample(raw, "time_s", Resampling(20.0, ("rpm",)), probed=("probed",))
    # the calls run to the first one at or after the last row (121 s): a probing there still has its call
    assert list(out.columns["time_s"]) == [0.0, 20.0, 40.0, 60.0, 80.0, 100.0, 120.0, 140.0]
    np.testing.assert_allclose(out.columns["T"][:-1], 20.0 + 0.1 * out.columns["time_s"][:-1])  # a ramp stays one
    assert out.columns["T"][-1] == 32.1  # after the last row: its value
    assert list(out.columns["rpm"]) == [0, 1000, 2000, 2000, 2000, 0, 0, 0]  # the last value at or before each call
    assert list(np.isfinite(out.columns["probed"])) == [False, True, False, True, False, False, False, False]
    assert out.columns["probed"][1] == 5.0 and out.columns["probed"][3] == 7.0  # at the call that follows
    assert list(out.lines) == [2, 3, 5, 6, 6, 7, 7, 8]  # each call names the raw line at or before it
    held = resample(raw, "time_s", Resampling(20.0), probed=("held",), held=True)
    assert list(held.columns["held"]) == [1.0, 1.0, 3.0, 3.0, 3.0, 3.0, 3.0, 4.0]


def test_a_pulse_between_two_calls_reaches_the_call_that_follows_it_and_the_last_probing_is_kept():
    raw = _table([0.0, 10.0, 15.0, 20.0, 35.0, 47.0], Reset=[0, 0, 1, 0, 0, 0], T=[1, 2, 3, 4, 5, 6],
                 probed=[np.nan, np.nan, np.nan, np.nan, np.nan, 9.0])
    out = resample(raw, "time_s", Resampling(20.0, pulses=("Reset",)), probed=("probed",))
    assert list(out.columns["Reset"]) == [0.0, 1.0, 0.0, 0.0]  # the pulse at 15 s, at the call at 20 s
    assert out.columns["probed"][-1] == 9.0 and out.columns["time_s"][-1] == 60.0


def test_two_probings_in_one_cycle_keep_the_later_and_a_gap_is_refused_with_its_time():
    raw = _table([0.0, 5.0, 6.0, 30.0], probed=[np.nan, 1.0, 2.0, np.nan], T=[1, 2, 3, 4])
    out = resample(raw, "time_s", Resampling(10.0), probed=("probed",))
    assert out.columns["probed"][1] == 2.0 and np.isfinite(out.columns["probed"]).sum() == 1
    gap = _table([0.0, 10.0, 10.0 + 10.0 * MAX_GAP_CALLS + 1, 200.0], T=[1, 2, 3, 4])
    with pytest.raises(UserError, match=r"raw.csv:4: column 'time_s': no row for 81 s \(from 10 s to 91 s\); "
                                        r"--resample 10 bridges at most 8 calls"):
        resample(gap, "time_s", Resampling(10.0))
    resample(_table([0.0, 10.0, 10.0 + 10.0 * MAX_GAP_CALLS, 100.0], T=[1, 2, 3, 4]), "time_s", Resampling(10.0))


@settings(max_examples=60, deadline=None)
@given(steps=st.lists(st.floats(0.5, 60.0), min_size=2, max_size=60), period=st.sampled_from([1.0, 7.5, 10.0, 40.0]),
       seed=st.integers(0, 2 ** 32 - 1))
def test_a_resampled_table_is_on_the_cycle_never_overshoots_and_keeps_every_probing(steps, period, seed):
    rng = np.random.default_rng(seed)
    t = np.r_[0.0, np.cumsum(steps)]
    temps, speed = rng.normal(20, 3, len(t)), rng.choice([0.0, 1500.0, 3000.0], len(t))
    probed = np.where(rng.random(len(t)) < 0.3, rng.normal(0, 10, len(t)), np.nan)
    probed[rng.integers(len(t))] = np.nan  # a target measured at every row is a measured column: linear, as a temperature
    raw = _table(t, T=temps, rpm=speed, probe=probed)
    try:
        out = resample(raw, "time_s", Resampling(period, ("rpm",)), probed=("probe",))
    except UserError as exc:
        assert "bridges at most" in str(exc) and np.max(np.diff(t)) > MAX_GAP_CALLS * period
        return
    calls = out.columns["time_s"]
    assert calls[0] == t[0] and calls[-1] >= t[-1] - 1e-9 * period > calls[-1] - period
    np.testing.assert_allclose(np.diff(calls), period, rtol=1e-12)
    assert np.all(out.columns["T"] >= temps.min() - 1e-9) and np.all(out.columns["T"] <= temps.max() + 1e-9)
    assert set(out.columns["rpm"]) <= set(speed)
    kept = out.columns["probe"][np.isfinite(out.columns["probe"])]
    cycles = np.ceil((t - t[0]) / period - 1e-9).astype(int)
    last_in_cycle = {c: v for c, v in zip(cycles, probed) if np.isfinite(v)}  # none lost
    assert sorted(kept) == sorted(last_in_cycle.values())
    again = resample(raw, "time_s", Resampling(period, ("rpm",)), probed=("probe",))
    for name in out.columns:  # the same bits every time
        assert out.columns[name].tobytes() == again.columns[name].tobytes()


def _raw_logger(folder, hours: float = 8.0) -> str:
    """FL_THERMAL as a raw logger would have written it: every 10 s for 16 min, then 40 s, with 1 s of jitter and a
    130 s gap."""
    whole = read_table(FL_THERMAL)
    rng = np.random.default_rng(7)
    times = [0.0]
    while times[-1] < hours * 3600:
        times.append(times[-1] + (10.0 if times[-1] < 960 else 40.0) + rng.uniform(-1, 1))
    times = np.round(np.array(times), 1)
    times[60:] += 90.0
    columns = {"time_s": times, **{c: np.round(np.interp(times, whole.columns["time_s"], v), 4)
                                   for c, v in whole.columns.items() if c != "time_s"}}
    (folder / "raw.csv").write_text(write_table(columns))
    return "raw.csv"


def test_a_raw_logger_file_is_fitted_generated_and_verified_with_resample(tmp_path):
    raw = _raw_logger(tmp_path)
    fit = ("fit", "--data", raw, "--model", "mlr", "--target", "ch3_um", "--temps", "t4_C,t5_C,t8_C,t11_C",
           "--speed", "spindle_rpm", "--train-until", "20000", "-o", "m.json")
    refused = thermoplc(*fit, cwd=tmp_path, check=None)
    assert refused.returncode == 2 and "give --resample SECONDS" in refused.stderr
    fitted = thermoplc(*fit, "--resample", "40", cwd=tmp_path)
    assert "resampled onto a cycle of 40 s (temperatures linear" in fitted.stdout
    model = json.loads((tmp_path / "m.json").read_text())
    assert model["sample_period_s"] == 40.0 and model["resample"]["period_s"] == 40.0
    thermoplc("generate", "m.json", "-o", "m.scl", "--accept-unvalidated", cwd=tmp_path)
    verified = thermoplc("verify", "m.scl", "--model", "m.json", "--data", raw, "--json", "v.json", "--outputs",
                         "out.csv", cwd=tmp_path)
    assert verified.stdout.startswith("bit-exact") and "taken onto the block's cycle of 40 s first" in verified.stdout
    document = json.loads((tmp_path / "v.json").read_text())  # the JSON says what the text says
    assert document["resampled"] == {"period_s": 40.0, "by": "model file"} and document["outputs_file"] == "out.csv"
    jsonschema.validate(document, schema("verify"))
    other = thermoplc("verify", "m.scl", "--model", "m.json", "--data", raw, "--resample", "10", cwd=tmp_path, check=None)
    assert other.returncode == 2 and "the block runs every 40 s" in other.stderr
    trace = thermoplc("verify", "m.scl", "--expect", "ch3_um", "--data", raw, "--resample", "40", cwd=tmp_path,
                      check=None)
    assert trace.returncode == 2 and "a PLC trace (--expect) is recorded on the block's cycle" in trace.stderr
    odd = thermoplc(*fit, "--resample", "0.0005", "--force", cwd=tmp_path, check=None)
    assert odd.returncode == 2 and "expected the block's cycle in seconds from 0.001" in odd.stderr
    half = thermoplc(*fit, "--resample", "40.0005", "--force", cwd=tmp_path, check=None)
    assert half.returncode == 2 and "whole number of milliseconds" in half.stderr


def test_a_model_fitted_on_data_resampled_beforehand_verifies_raw_data_with_resample(tmp_path):
    raw = _raw_logger(tmp_path, hours=4.0)
    resampled = resample(read_table(str(tmp_path / raw)), "time_s", Resampling(40.0, ("spindle_rpm",)))
    (tmp_path / "by_hand.csv").write_text(write_table(resampled.columns))
    thermoplc("fit", "--data", "by_hand.csv", "--model", "mlr", "--target", "ch3_um", "--temps", "t4_C,t5_C",
              "--train-until", "9000", "-o", "m.json", cwd=tmp_path)
    thermoplc("generate", "m.json", "-o", "m.scl", "--accept-unvalidated", cwd=tmp_path)
    plain = thermoplc("verify", "m.scl", "--model", "m.json", "--data", raw, cwd=tmp_path, check=None)
    assert plain.returncode == 2 and "give --resample 40 (the block's cycle)" in plain.stderr
    verified = thermoplc("verify", "m.scl", "--model", "m.json", "--data", raw, "--resample", "40", cwd=tmp_path)
    assert verified.stdout.startswith("bit-exact") and "(--resample:" in verified.stdout


def test_a_logger_campaign_with_held_probings_is_fused_and_verified_on_its_raw_files(tmp_path):
    written = thermoplc("twin", "--runs", "3", "--hours", "4", "--dt", "40", "--seed", "4", "--probe-minutes", "30",
                        "--logger", "-o", "raw", cwd=tmp_path)
    assert "as a data logger writes them (every 10 s for 16 min, then 40 s, 1 s of jitter)" in written.stdout
    steps = np.diff(read_table(str(tmp_path / "raw" / "run_001.csv")).columns["time_s"])
    assert steps.min() < 12 and steps.max() > 38 and len(set(np.round(steps, 1))) > 10  # mixed, jittered
    fitted = thermoplc("fit", "--data", "raw", "--model", "mlr", "--target", "E_z_um", "--held-target", "--temps",
                       "T_motor,T_bearing", "--speed", "n_rpm", "--folds", "3", "--probe", "--resample", "40",
                       "-o", "m.json", cwd=tmp_path)
    assert "'n_rpm' its last value, each probing at the call that follows it" in fitted.stdout
    assert "the target's own probings (every 45 calls, median)" in fitted.stdout
    thermoplc("generate", "m.json", "-o", "m.scl", "--accept-unvalidated", cwd=tmp_path)
    verified = thermoplc("verify", "m.scl", "--model", "m.json", "--data", "raw", cwd=tmp_path)
    assert verified.stdout.splitlines()[-1].startswith("bit-exact: every run reproduces the reference (3 runs")


def test_a_hand_edited_resample_section_is_one_line_and_a_mapped_speed_is_held(tmp_path):
    thermoplc("twin", "--hours", "3", "--seed", "2", "--dt", "40", "--logger", "-o", "lg.csv", cwd=tmp_path)
    thermoplc("fit", "--data", "lg.csv", "--model", "lumped", "--target", "E_z_um", "--temps", "T_motor,T_bearing",
              "--speed", "n_rpm", "--ambient", "T_env", "--train-until", "7200", "--resample", "40", "-o", "m.json",
              cwd=tmp_path)
    thermoplc("generate", "m.json", "-o", "m.scl", "--accept-unvalidated", cwd=tmp_path)
    doc = json.loads((tmp_path / "m.json").read_text())
    for bad, field in (("abc", "resample.period_s"), (float("nan"), "resample.period_s"), (None, "resample.period_s")):
        edited = {**doc, "resample": {**doc["resample"], "period_s": bad}}
        (tmp_path / "e.json").write_text(json.dumps(edited))
        refused = thermoplc("verify", "m.scl", "--model", "e.json", "--data", "lg.csv", cwd=tmp_path, check=None)
        assert refused.returncode == 2 and f"e.json: field '{field}'" in refused.stderr, refused.stderr
    (tmp_path / "e.json").write_text(json.dumps({**doc, "resample": 40}))
    assert "field 'resample': expected an object" in thermoplc("verify", "m.scl", "--model", "e.json", "--data",
                                                                 "lg.csv", cwd=tmp_path, check=2).stderr
    text = (tmp_path / "lg.csv").read_text()
    (tmp_path / "renamed.csv").write_text(text.replace("n_rpm", "spindle", 1))
    thermoplc("verify", "m.scl", "--model", "m.json", "--data", "lg.csv", "--outputs", "a.csv", cwd=tmp_path)
    thermoplc("verify", "m.scl", "--model", "m.json", "--data", "renamed.csv", "--inputs", "n_rpm=spindle",
              "--outputs", "b.csv", cwd=tmp_path)
    assert (tmp_path / "a.csv").read_bytes() == (tmp_path / "b.csv").read_bytes()  # the mapped column held too


def test_a_probing_between_two_calls_keeps_its_own_value():
    """Issue 60: a sparse ProbeValue (only on the probing's row) reaches the call that follows with the probing's
    value, not the empty row at or before the call; two in one cycle: the later."""
    raw = _table([0.0, 10.0, 15.0, 20.0, 31.0, 34.0, 47.0], ProbeNew=[0, 0, 1, 0, 1, 1, 0],
                 ProbeValue=[np.nan, np.nan, 4.5, np.nan, 6.0, 7.0, np.nan], T=[1, 2, 3, 4, 5, 6, 7])
    rule = Resampling(20.0, hold=("ProbeValue",), pulses=("ProbeNew",), pulse_values=(("ProbeValue", "ProbeNew"),))
    out = resample(raw, "time_s", rule)
    assert list(out.columns["ProbeNew"]) == [0.0, 1.0, 1.0, 0.0]
    assert out.columns["ProbeValue"][1] == 4.5 and out.columns["ProbeValue"][2] == 7.0
    assert np.isnan(out.columns["ProbeValue"][0]) and np.isnan(out.columns["ProbeValue"][3])


@pytest.mark.parametrize("control, values", [("ProbeNew", (2, -1, 0.5)), ("Reset", (2,)), ("Enable", (2,))])
def test_a_control_column_keeps_its_0_or_1_rule_through_resample(tmp_path, control, values):
    """Issue 60: Reset=2, Enable=2 or ProbeNew=0.5 between two calls was a reset or a probing after --resample
    (and verify said bit-exact); refused as without resampling, naming the line."""
    raw = _raw_logger(tmp_path, hours=3.0)
    fit = ("fit", "--data", raw, "--model", "mlr", "--target", "ch3_um", "--temps", "t4_C,t5_C", "--train-until",
           "7000", "--resample", "40", "-o", "m.json")
    thermoplc(*fit, *(("--probe", "--probe-every", "30") if control == "ProbeNew" else ()), cwd=tmp_path)
    thermoplc("generate", "m.json", "-o", "m.scl", "--accept-unvalidated", cwd=tmp_path)
    header, *rows = (tmp_path / raw).read_text().splitlines()
    extra = "ProbeValue,ProbeNew" if control == "ProbeNew" else control
    for value in values:
        cells = [("0,0" if control == "ProbeNew" else "1" if control == "Enable" else "0") for _ in rows]
        cells[40] = f"3.5,{value}" if control == "ProbeNew" else str(value)
        (tmp_path / "ctl.csv").write_text("\n".join([f"{header},{extra}", *(f"{r},{c}" for r, c in zip(rows, cells))])
                                          + "\n")
        refused = thermoplc("verify", "m.scl", "--model", "m.json", "--data", "ctl.csv", cwd=tmp_path, check=2)
        what = f"input {control} of type BOOL" if control == "ProbeNew" else f"the {control} input (BOOL)"
        assert f"ctl.csv: line 42, column '{control}': {float(value):.17g} cannot be {what}; expected 0 or 1" \
            in refused.stderr, refused.stderr


def test_inputs_mapped_in_any_case_drive_the_resampling_as_the_replay(tmp_path):
    """Hostile review of issue 60: `--inputs reset=R` (ST names ignore case) was honoured by the replay but not by
    the resampling, which interpolated R linearly: the pulse was lost and a 2 got through."""
    raw = _raw_logger(tmp_path, hours=3.0)
    thermoplc("fit", "--data", raw, "--model", "mlr", "--target", "ch3_um", "--temps", "t4_C,t5_C", "--train-until",
              "7000", "--resample", "40", "-o", "m.json", cwd=tmp_path)
    thermoplc("generate", "m.json", "-o", "m.scl", "--accept-unvalidated", cwd=tmp_path)
    header, *rows = (tmp_path / raw).read_text().splitlines()
    for value, status in (("1", 0), ("2", 2)):
        cells = ["0"] * len(rows)
        cells[41] = value
        (tmp_path / "r.csv").write_text("\n".join([f"{header},R", *(f"{r},{c}" for r, c in zip(rows, cells))]) + "\n")
        for key in ("Reset", "reset", "RESET"):
            result = thermoplc("verify", "m.scl", "--model", "m.json", "--data", "r.csv", "--inputs", f"{key}=R",
                               cwd=tmp_path, check=status)
            assert ("1 reset call(s)" in result.stdout) if status == 0 else \
                ("column 'R': 2 cannot be the Reset input (BOOL)" in result.stderr)
