"""The fast engine gives the interpreter's bits: on every golden block, with faults, on random programs."""
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from tests.golden_models import DIALECTS, GOLDEN, KINDS, golden_block, golden_twin_csv
from tests.strategies import real_exprs
from thermoplc.base.errors import UserError
from thermoplc.generator.printer import DIALECTS as PRINTERS, _Printer
from thermoplc.models.modelfile import load_model
from thermoplc.models.reference import model_inputs
from thermoplc.recordings.table import read_table
from thermoplc.verifier.engines import native
from thermoplc.verifier.engines.choice import Replayer
from thermoplc.verifier.replays.faults import FAULT_KINDS, inject
from thermoplc.verifier.engines.interpreter import Machine
from thermoplc.verifier.engines.native import NativeBlock
from thermoplc.verifier.reading.block_file import parse_file
from thermoplc.verifier.reading.parser import parse_text


pytestmark = pytest.mark.skipif(native._compiler() is None, reason="no C compiler: the fast engine cannot be built here")


def _bits(values) -> np.ndarray:
    """Bit patterns, every NaN as one pattern: IEEE 754 leaves NaN payloads open (x86 makes
    SQRT(-1) a negative NaN, Python a positive one) and the verifier reports any NaN anyway."""
    array = np.asarray(values)
    if array.dtype.kind != "f":
        return array.astype(bool)
    bits = array.astype(np.float32).view(np.uint32).copy()
    bits[np.isnan(array.astype(np.float32))] = 0x7FC00000
    return bits


def _interpreted(program, columns: dict, rows: int) -> dict:
    machine = Machine(program)
    return machine.replay({k: np.asarray(v).tolist() for k, v in columns.items()}, rows)


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    return read_table(golden_twin_csv(tmp_path_factory.mktemp("engines")))


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("dialect", DIALECTS)
def test_fast_engine_equals_interpreter_on_golden_blocks(kind, dialect, table):
    program = parse_file(golden_block(kind, dialect))
    columns = model_inputs(load_model(GOLDEN / f"{kind}.json"), table)
    fast, flags = NativeBlock(program).run(columns, len(next(iter(columns.values()))))
    assert not flags
    slow = _interpreted(program, columns, table.rows)
    for name in slow:
        assert np.array_equal(_bits(fast[name]), _bits(slow[name])), name


@pytest.mark.parametrize("kind", ["kalman", "lumped", "dlag", "bpnn"])
def test_fast_engine_equals_interpreter_with_faulty_sensors(kind, table):
    program = parse_file(golden_block(kind, "tia"))
    columns = model_inputs(load_model(GOLDEN / f"{kind}.json"), table)
    times = table.columns["time_s"]
    for fault in FAULT_KINDS:
        faulty = dict(columns)
        faulty["T_motor"], _ = inject(columns["T_motor"], times, fault, table.rows // 3)
        fast, _ = NativeBlock(program).run(faulty, len(next(iter(faulty.values()))))
        slow = _interpreted(program, faulty, table.rows)
        for name in slow:
            assert np.array_equal(_bits(fast[name]), _bits(slow[name])), (fault.name, name)


SPECIAL = st.sampled_from([0.0, -0.0, 1.0, -1.5, 1e-38, 3.0e38, 1e-45, float("nan"), float("inf"), 3276.7])
VALUES = st.one_of(st.floats(width=32, allow_nan=True, allow_infinity=True), SPECIAL)


@given(real_exprs(max_leaves=10), real_exprs(max_leaves=6), st.lists(st.tuples(VALUES, VALUES, VALUES), min_size=1, max_size=12))
@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
def test_fast_engine_equals_interpreter_on_random_programs(value, condition, rows):
    """x1, x2 are inputs; x3 is state carried between calls; c_k1/c_k2 are constants."""
    printer = _Printer(PRINTERS["iec"])
    text = (f"FUNCTION_BLOCK R\nVAR_INPUT x1 : REAL; x2 : REAL; END_VAR\nVAR_OUTPUT y : REAL; b : BOOL; END_VAR\n"
            f"VAR x3 : REAL; END_VAR\nVAR CONSTANT c_k1 : REAL := 0.75; c_k2 : REAL := -2.5; END_VAR\n"
            f"IF {printer.expr(condition)} < {printer.expr(value)} THEN\n  y := {printer.expr(value)};\n  b := TRUE;\n"
            f"ELSE\n  y := {printer.expr(condition)};\n  b := FALSE;\nEND_IF;\nx3 := y;\nEND_FUNCTION_BLOCK\n")
    program = parse_text(text)
    columns = {"x1": np.array([r[0] for r in rows], np.float32), "x2": np.array([r[1] for r in rows], np.float32)}
    fast, _ = NativeBlock(program).run(columns, len(rows))
    slow = _interpreted(program, columns, len(rows))
    for name in ("y", "b"):
        assert np.array_equal(_bits(fast[name]), _bits(slow[name])), (name, text)


def test_auto_falls_back_with_a_reason_and_fast_refuses(monkeypatch):
    program = parse_file(golden_block("mlr", "tia"))
    monkeypatch.setattr(native, "_compiler", lambda: None)
    auto = Replayer(program, "mlr.scl", "auto")
    assert auto.native is None and "no C compiler found" in auto.note
    with pytest.raises(UserError, match="the fast engine is not available: no C compiler found"):
        Replayer(program, "mlr.scl", "fast")


def test_values_the_interpreter_reports_are_replayed_by_it():
    program = parse_text("FUNCTION_BLOCK D\nVAR_INPUT x : REAL; END_VAR\nVAR_OUTPUT y : REAL; END_VAR\n"
                         "VAR CONSTANT c_z : REAL := 0.0; END_VAR\ny := x / c_z;\nEND_FUNCTION_BLOCK\n", "d.st")
    replayer = Replayer(program, "d.st", "auto")
    out = replayer.replay({"x": np.array([1.0, 0.0], np.float32)}, 2, ("y",))
    assert replayer.used == "interp" and "replayed with the interpreter" in replayer.note
    assert np.isinf(out["y"][0]) and np.isnan(out["y"][1])
    assert {f.kind for f in replayer.machine.findings.values()} >= {"inf", "nan"}


def test_non_portable_block_runs_on_the_interpreter():
    program = parse_text("FUNCTION_BLOCK E\nVAR_INPUT x : REAL; END_VAR\nVAR_OUTPUT y : REAL; END_VAR\n"
                         "y := EXP(x);\nEND_FUNCTION_BLOCK\n", "e.st")
    replayer = Replayer(program, "e.st", "auto")
    assert replayer.native is None and "EXP is not a portable operation" in replayer.note
