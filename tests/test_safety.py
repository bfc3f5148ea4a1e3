"""The safety logic every block carries: guards, start gate, clamp, rate limit, K0, fault injection."""
import json

import numpy as np
import pytest

from tests.bad_inputs import table_entry_edited
from tests.golden_models import GOLDEN, KINDS, golden_block, golden_twin_csv
from tests.cli_runner import thermoplc
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import render
from thermoplc.models.modelfile import load_model
from thermoplc.contract.outputs import block_names, named
from thermoplc.models.reference import block_outputs, model_inputs
from thermoplc.models.safety import K0_MM_PER_UM, Limits
from thermoplc.recordings.table import read_table
from thermoplc.verifier.replays.faults import CONTROL_KINDS, FAULT_KINDS, verify_faults
from thermoplc.verifier.engines.interpreter import Machine
from thermoplc.verifier.reading.parser import parse_text


@pytest.fixture(scope="module")
def golden_table(tmp_path_factory):
    return read_table(golden_twin_csv(tmp_path_factory.mktemp("safety")))


@pytest.mark.parametrize("kind", KINDS)
def test_every_fault_on_every_golden_block_stays_exact_finite_and_limited(kind, golden_table):
    model = load_model(GOLDEN / f"{kind}.json")
    report = verify_faults(str(golden_block(kind, "tia")), model, golden_table)
    assert report.constants_checked and not report.constant_errors and not report.unsafe
    cases = report.cases
    temperatures = [s for s in model.inputs if {"temperature", "ambient"} & set(s.role.split(","))]
    check = model.plausibility
    swings = 2 if check is not None and check.swings else 0  # pause, late-start
    levels = 2 if check is not None else 0  # reset-far, pause-flagged
    # sensors, then Enable/Reset, then the restarts: a Reset after a step on each sensor, reset-stuck, pause-stuck ...
    assert len(cases) == (len(FAULT_KINDS) + 1) * len(temperatures) + len(CONTROL_KINDS) + 2 + swings + levels
    assert report.not_run == ()
    assert [(c.sensor, c.kind.name) for c in cases if not (c.bit_exact and c.finite and c.within_clamp
                                                           and c.within_rate)] == []
    # judged against no compensation: only a slowly drifting sensor, which no guard flags yet, may pull the axis
    # further than no compensation (issue 61 item 4); the verdict says so
    unsafe = [(c.sensor, c.kind.name) for c in cases if not c.safe]
    assert {kind for _, kind in unsafe} <= {"sine"}
    assert report.ok == (not unsafe) and all((c.harm is None) == (not c.kind.judged) for c in cases)
    assert {c.kind.name for c in cases if not c.kind.judged} == {
        "reset", "reset-held", "disable", "disable+reset", "reset-after", "reset-stuck", "pause-stuck",
        *(("reset-far", "pause-flagged") if levels else ()), *(("pause", "late-start") if swings else ())}
    for c in cases:
        if c.kind.name in ("nan", "open", "short", "jump", "dead", "offset"):
            assert c.flagged, (c.sensor, c.kind.name)
        if c.kind.name in ("nan", "open", "short") and model.kind != "kalman":
            assert c.clear_at_end, (c.sensor, c.kind.name)


def _run(block_text: str, columns: dict) -> dict:
    machine = Machine(parse_text(block_text, "b.scl"), "b.scl")
    rows = len(next(iter(columns.values())))
    return {k: np.asarray(v) for k, v in machine.replay({k: list(v) for k, v in columns.items()}, rows).items()}


def _same_bits(block: dict, reference: dict) -> None:
    for name, want in reference.items():
        got = block[name]
        if want.dtype.kind == "f":
            assert np.array_equal(got.astype(np.float32).view(np.uint32), want.astype(np.float32).view(np.uint32)), name
        else:
            assert np.array_equal(got.astype(bool), want), name


def test_model_starts_only_when_every_input_is_in_range(golden_table):
    model = load_model(GOLDEN / "mlr.json")
    inputs = model_inputs(model, golden_table)
    inputs["T_motor"] = inputs["T_motor"].copy()
    inputs["T_motor"][:5] = [np.nan, 3276.7, -3276.8, np.nan, 200.0]
    expected = named(block_outputs(model, inputs, "f32", Limits.for_model(model)), block_names(model))
    produced = _run(render(lower(model)), inputs)
    _same_bits(produced, expected)
    assert not produced["Ready"][:5].any() and produced["Ready"][5:].all()
    assert (produced["E_z_um"][:5] == 0).all() and produced["Fault_T_motor"][:5].all()
    assert not produced["Fault_T_motor"][5]


def test_clamp_and_rate_limit_hold_and_say_so(golden_table):
    model = load_model(GOLDEN / "kalman.json")
    inputs = model_inputs(model, golden_table)
    limits = Limits(max_output=3.0, max_step=0.05)
    expected = named(block_outputs(model, inputs, "f32", limits), block_names(model))
    produced = _run(render(lower(model, limits), "step7"), inputs)
    _same_bits(produced, expected)
    error = produced["E_z_um"].astype(np.float64)
    assert np.abs(error).max() == 3.0 and produced["Clamped"].any()
    assert produced["Limited"].any() and np.abs(np.diff(error)).max() <= 0.05 + 1e-6
    k0 = produced["K0_1"].astype(np.float32)
    assert np.array_equal(k0.view(np.uint32), (error.astype(np.float32) * np.float32(K0_MM_PER_UM)).view(np.uint32))


def test_verify_faults_from_the_command_line(tmp_path):
    thermoplc("generate", GOLDEN / "mlr.json", "--dialect", "iec", "-o", "b.st", cwd=tmp_path)
    data = golden_twin_csv(tmp_path)
    out = thermoplc("verify", "b.st", "--data", data, "--model", GOLDEN / "mlr.json", "--faults", cwd=tmp_path).stdout
    assert "28 cases" in out and "all cases bit-exact, finite, inside the clamp and the rate limit" in out
    assert "offset: paper 000 eq. 19: -2 degC" in out


def test_generate_rejects_limits_that_make_no_sense(tmp_path):
    result = thermoplc("generate", GOLDEN / "mlr.json", "--max-step-um", "0", "-o", "b.scl", cwd=tmp_path, check=2)
    assert "argument --max-step-um: expected micrometres" in result.stderr and not (tmp_path / "b.scl").exists()
    result = thermoplc("generate", GOLDEN / "mlr.json", "--temp-range", "80,20", "-o", "b.scl", cwd=tmp_path, check=2)
    assert "argument --temp-range: expected LOW,HIGH with LOW below HIGH" in result.stderr


def test_verify_faults_checks_the_declared_constants_as_plain_verify_does(tmp_path):
    """tab_Pred[6] of the Bayes block is an answer no fault case of the golden twin reaches: replay
    alone passes the edited block; the constants check that plain verify makes fails it (exit 1)."""
    edited = table_entry_edited(golden_block("bayes", "tia").read_text(), "tab_Pred", 6, "99.5")
    (tmp_path / "b.scl").write_text(edited)
    data = golden_twin_csv(tmp_path)
    out = thermoplc("verify", "b.scl", "--data", data, "--model", GOLDEN / "bayes.json", "--faults", cwd=tmp_path,
                    check=1).stdout
    assert out.startswith("NOT bit-exact: b.scl holds constants that differ from the model")
    assert "all cases bit-exact, finite, inside the clamp and the rate limit" in out  # the replay alone passes
    assert "constants and tables: 112 values checked against the model, 1 differs" in out
    assert "tab_Pred[6]: block 99.5 (0x42C70000), model 15.5 (0x41780000)" in out


def test_the_fault_hold_keeps_a_short_fault_near_and_fades_a_dead_sensor_to_no_compensation():
    """Issue 61 item 4: while any fault bit is set each output stays within the bound of its value before the
    fault, and that value fades to 0, so a sensor that died leaves the block at no compensation, not frozen."""
    from thermoplc.models import fault_hold
    rows = 5000
    model = np.linspace(30.0, -60.0, rows).astype(np.float32)  # the machine cools while the sensor is dead
    faulty = np.zeros(rows, bool)
    faulty[1000:1030] = True  # a 30-call NaN
    faulty[2000:] = True  # then the sensor dies
    held = fault_hold.apply(model, faulty, 2.0, 0.995, "f32").astype(np.float64)
    before = float(model[999])
    assert np.all(np.abs(held[1000:1030] - before) <= 2.0 + 1e-5)
    assert held.view(np.uint64)[:1000].tolist() == model.astype(np.float64).view(np.uint64)[:1000].tolist()
    assert np.all(held[1030:2000] == model[1030:2000].astype(np.float64))  # released: the model again
    assert abs(held[-1]) <= 2.0 + 1e-5 and abs(held[2000] - model[1999]) <= 2.0 + 1e-5
    state = np.zeros(3, np.float32)
    chunked = np.concatenate([fault_hold.apply(model[:2500], faulty[:2500], 2.0, 0.995, "f32", state),
                              fault_hold.apply(model[2500:], faulty[2500:], 2.0, 0.995, "f32", state)])
    assert chunked.view(np.uint32).tolist() == fault_hold.apply(model, faulty, 2.0, 0.995, "f32").view(np.uint32).tolist()


def test_a_restart_case_the_data_are_too_short_for_is_named_not_passed(tmp_path):
    """150 calls of the twin: no room for a 211-call step and a Reset after it; the text and --json say so."""
    full = golden_twin_csv(tmp_path).read_text().splitlines()
    (tmp_path / "short.csv").write_text("\n".join(full[:151]) + "\n")
    args = ("verify", GOLDEN / "mlr.iec.st", "--model", GOLDEN / "mlr.json", "--data", "short.csv", "--faults")
    out = thermoplc(*args, cwd=tmp_path, check=None).stdout
    assert ("not run (the data are too short): reset-after on T_motor: a step of 211 calls, a Reset and a call after "
            "it need 214 calls") in out
    faults = [line.split()[1] for line in out.splitlines() if line.startswith(("T_motor ", "T_bearing "))]
    assert "reset-after:" not in faults and "reset-stuck:" in faults
    doc = json.loads(thermoplc(*args, "--json", "-", cwd=tmp_path, check=None).stdout)  # the text goes to stderr
    assert [why.split(":")[0] for why in doc["not_run"]] == ["reset-after on T_motor", "reset-after on T_bearing"]
