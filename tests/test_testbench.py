"""Issue 64: the test bench the engineer runs on the PLC. Every golden block, plain and fused, in every
dialect, runs its bench in thermoplc's interpreter with 0 mismatches; a one-ULP change in the block or in
one expected value is found at the call verify names; the files keep every target's limits."""
from __future__ import annotations

import re
from dataclasses import replace

import numpy as np
import pytest
from blark.parse import parse_source_code
from hypothesis import given, settings, strategies as st

from tests.cli_runner import thermoplc
from tests.golden_models import (FUSED, FUSED_EVERY, GOLDEN, KINDS, golden_bench, golden_block, golden_twin_csv,
                                 rendered_bench)
from thermoplc.base.version import __version__
from thermoplc.contract.constants import LIMIT_NAMES
from thermoplc.base.identifiers import MAX_LENGTH, identifier_problem
from thermoplc.generator import testbench as plan_module
from thermoplc.generator.literals import real_literal
from thermoplc.generator.testbench_text import render_bench
from thermoplc.models.modelfile import load_model
from thermoplc import pipeline
from thermoplc.pipeline import run_bench_text
from thermoplc.recordings.table import read_table, write_table
from thermoplc.verifier.reading import syntax as s
from thermoplc.verifier.replays.bench_run import data_arrays
from thermoplc.verifier.reading.bench_source import parse_sources
from thermoplc.verifier.reading.block_file import parse_file
from thermoplc.verifier.reading.plcopen import read_plcopen
from thermoplc.verifier.replays.replay import verify_against_model

BENCH_DIALECTS = ("tia", "step7", "iec", "plcopen")
ALL_KINDS = (*KINDS, *FUSED)
ELEMENT_BYTES = {"REAL": 4, "INT": 2, "BOOL": 1}


@pytest.fixture(scope="module")
def twin(tmp_path_factory):
    """The golden twin, with a Reset column that resets the block at the first row only: verify replays it
    as a bench window from row 1 drives the block (Reset at call 1)."""
    folder = tmp_path_factory.mktemp("bench")
    table = read_table(golden_twin_csv(folder))
    columns = {**table.columns, "Reset": np.r_[1.0, np.zeros(table.rows - 1)]}
    path = folder / "twin_reset.csv"
    path.write_text(write_table(columns))
    return read_table(path)


def _bench(kind: str, dialect: str, table, first: int = 0, calls: int | None = 150, **options):
    model_path = GOLDEN / f"{kind}.json"
    every = FUSED_EVERY if kind in FUSED else None
    return pipeline.testbench(str(golden_block(kind, dialect)), load_model(model_path), str(model_path), table, first, calls,
                     probe_every=every, **options)


def _next_up(value: float) -> float:
    return float(np.nextafter(np.float32(value), np.float32(np.inf)))


@pytest.mark.parametrize("dialect", BENCH_DIALECTS)
@pytest.mark.parametrize("kind", ALL_KINDS)
def test_every_golden_block_passes_its_bench_in_the_interpreter(kind, dialect, twin):
    bench = _bench(kind, dialect, twin, first=37, calls=150, rows_per_cycle=7)
    c = bench.counters
    assert (c.done, c.calls, c.mismatches, c.first_mismatch_call) == (True, 150, 0, 0)
    assert not any(c.max_diff) and c.cycles == 22  # 150 calls at 7 per cycle
    assert bench.dialect == ("iec" if dialect == "plcopen" else dialect) and bench.plcopen == (dialect == "plcopen")


def _constants(program: s.Program):
    """The block's model constants (not its safety limits: verify reads those back from the block itself, so an
    edited limit moves verify's reference with it, and the bench's expected values are the unedited block's)."""
    limits = {name.upper() for name in LIMIT_NAMES.values()}
    return [d for d in program.decls if d.section == "constant" and d.type.base == "REAL" and not d.type.bounds
            and isinstance(d.initial, float) and d.initial != 0.0 and d.name.upper() not in limits]


def _edited(text: str, decl: s.VarDecl) -> str:
    """The block text with constant `decl` one ULP up, written as the printer writes it (in PLCopen XML on a line
    after the variable's)."""
    lines = text.split("\n")
    old = real_literal(decl.initial)
    at = next(k for k in range(decl.pos[0] - 1, len(lines)) if re.search(rf"(?<![0-9.]){re.escape(old)}(?![0-9])", lines[k]))
    lines[at] = re.sub(rf"(?<![0-9.]){re.escape(old)}(?![0-9])", real_literal(_next_up(decl.initial)), lines[at], count=1)
    return "\n".join(lines)


def _first_edit_that_matters(kind: str, dialect: str, twin, tmp_path):
    """The block with the first constant whose one-ULP edit changes an output over the twin, and verify's report."""
    path = golden_block(kind, dialect)
    model_path = GOLDEN / f"{kind}.json"
    for decl in _constants(parse_file(path)):
        edited = tmp_path / f"edited{path.suffix}"
        edited.write_text(_edited(path.read_text(), decl))
        report = verify_against_model(str(edited), load_model(model_path), str(model_path), twin,
                                      probe_every=FUSED_EVERY if kind in FUSED else None)
        if report.mismatch is not None:
            return edited, report
    raise AssertionError(f"no constant of {kind} reaches an output")


def _ulp_edits_found_where_verify_says(kind: str, dialect: str, twin, tmp_path, most: int) -> int:
    """Edit constants one ULP until `most` of them change the outputs; each time the bench of the unedited
    block, run against the edited one, counts mismatches from the cycle verify names. Returns how many."""
    path = golden_block(kind, dialect)
    model_path = GOLDEN / f"{kind}.json"
    model = load_model(model_path)
    every = FUSED_EVERY if kind in FUSED else None
    bench = _bench(kind, dialect, twin, calls=twin.rows)
    program = parse_file(path)
    found = 0
    for decl in _constants(program):
        edited = tmp_path / f"edited{path.suffix}"
        edited.write_text(_edited(path.read_text(), decl))
        report = verify_against_model(str(edited), model, str(model_path), twin, probe_every=every)
        if report.mismatch is None:
            continue  # this constant does not reach an output over the recording (a limit never met)
        counters = run_bench_text(bench.text, "bench", parse_file(edited), str(edited), twin.rows, bench.plcopen)
        assert counters.mismatches > 0, decl.name
        assert counters.first_mismatch_call == report.mismatch.cycle + 1, decl.name
        found += 1
        if found == most:
            break
    return found


@pytest.mark.parametrize("dialect", BENCH_DIALECTS)
@pytest.mark.parametrize("kind", ("mlr", pytest.param("kalman_fused", marks=pytest.mark.slow),
                                  pytest.param("gm1n", marks=pytest.mark.slow)))
def test_a_one_ulp_edit_of_a_constant_is_found_at_the_call_verify_names(kind, dialect, twin, tmp_path):
    assert _ulp_edits_found_where_verify_says(kind, dialect, twin, tmp_path, most=2) == 2


@pytest.mark.slow
@pytest.mark.parametrize("kind", ALL_KINDS)
def test_one_ulp_edits_of_every_kind_are_found_at_the_call_verify_names(kind, twin, tmp_path):
    assert _ulp_edits_found_where_verify_says(kind, "tia", twin, tmp_path, most=6) >= 1


@pytest.mark.parametrize("dialect", BENCH_DIALECTS)
def test_a_one_ulp_edit_of_one_expected_value_is_that_call_and_that_output(dialect, twin):
    bench = _bench("kalman", dialect, twin, calls=200)
    first = bench.plan.outputs[0]
    expected = first.values[122]
    wanted = _next_up(expected)
    edited = replace(bench.plan, outputs=(replace(first, values=(*first.values[:122], wanted, *first.values[123:])),
                                          *bench.plan.outputs[1:]))
    text = render_bench(edited, bench.dialect, bench.plcopen, __version__)
    assert len(difflib_lines(bench.text, text)) == 1  # one value of one line differs
    program = parse_file(golden_block("kalman", dialect))
    c = run_bench_text(text, "bench", program, str(golden_block("kalman", dialect)), 100, bench.plcopen)
    assert (c.done, c.mismatches, c.first_mismatch_call, c.first_mismatch_output) == (True, 1, 123, 1)
    assert (c.first_expected, c.first_actual) == (wanted, expected)
    assert c.max_diff[0] == abs(np.float32(wanted) - np.float32(expected))


def difflib_lines(a: str, b: str) -> list[str]:
    return [x for x, y in zip(a.splitlines(), b.splitlines()) if x != y]


def test_tolerance_passes_a_deviation_within_it_and_says_so(twin, tmp_path):
    edited, _ = _first_edit_that_matters("mlr", "tia", twin, tmp_path)
    exact = _bench("mlr", "tia", twin, calls=400)
    tolerant = _bench("mlr", "tia", twin, calls=400, tolerance=0.001)
    assert "Tol1 : Real := 0.001;" in tolerant.text and "Tol2 : Real := 1.0E-6;" in tolerant.text  # K0_1 is in mm
    assert "Tol1" not in exact.text
    strict = run_bench_text(exact.text, "bench", parse_file(edited), str(edited), 100)
    within = run_bench_text(tolerant.text, "bench", parse_file(edited), str(edited), 100)
    assert strict.mismatches > 0 and within.mismatches == 0 and 0 < within.max_diff[0] < 0.001


def test_blark_parses_the_iec_bench(twin):
    bench = _bench("kalman_fused", "iec", twin, calls=3)  # blark reads long arrays slowly (minutes at 100 calls)
    result = parse_source_code(bench.text)
    assert result.exception is None, result.exception
    assert f"FUNCTION_BLOCK {bench.name}" in bench.text and "Dut(" in bench.text


def _limits_kept(bench, dialect: str) -> None:
    """Every data block (Siemens) or constant array (IEC) within 64 KiB counted from the parsed file, every
    name a valid identifier within the 24 characters every dialect keeps."""
    if dialect == "plcopen":
        sources = s.Sources((read_plcopen(bench.text, "bench", bench=True),), ())
    else:
        sources = parse_sources(bench.text, "bench")
    size = lambda d: (d.type.bounds[1] - d.type.bounds[0] + 1) * ELEMENT_BYTES[d.type.base]
    for db in sources.data_blocks:
        assert sum(size(d) for d in db.decls) <= 65536, db.name
    names = [db.name for db in sources.data_blocks] + [b.name for b in sources.blocks]
    for block in sources.blocks:
        names += [d.name for d in block.decls]
        assert all(size(d) <= 65536 for d in block.decls if d.type.bounds)
    names += [d.name for db in sources.data_blocks for d in db.decls]
    names = [n for n in names if n != "ENO"]  # the SCL enable flag the reader adds to a block with BEGIN
    assert all(identifier_problem(n) is None and len(n) <= MAX_LENGTH for n in names), names


@pytest.mark.parametrize("dialect", BENCH_DIALECTS)
def test_many_data_blocks_keep_the_limits_and_the_rows_in_order(dialect, twin, monkeypatch):
    small = {name: replace(t, chunk_bytes=2048) for name, t in plan_module.TARGETS.items()}
    monkeypatch.setattr(plan_module, "TARGETS", small)
    bench = _bench("dlag", dialect, twin, first=5, calls=900, rows_per_cycle=40)
    assert bench.data_blocks >= 10
    c = bench.counters
    assert (c.done, c.calls, c.mismatches) == (True, 900, 0)
    _limits_kept(bench, dialect)


@pytest.mark.parametrize("dialect", [pytest.param(d, marks=pytest.mark.slow) if d in ("tia", "step7") else d
                                     for d in BENCH_DIALECTS])  # a data block source of 4,321 rows reads in 20 s
def test_the_default_bench_fits_one_download_and_its_limits(dialect, twin):
    bench = _bench("kalman_fused", dialect, twin, calls=None, rows_per_cycle=100)
    target = plan_module.TARGETS[bench.dialect]
    assert bench.plan.calls * (bench.plan.row_bytes + 1) <= target.download_bytes
    assert bench.data_blocks <= target.download_bytes // target.chunk_bytes
    assert bench.plan.calls == min(twin.rows, plan_module.default_calls(bench.plan.row_bytes, 10 ** 6, bench.dialect))
    assert bench.counters.mismatches == 0 and bench.counters.done
    _limits_kept(bench, dialect)


def test_a_long_block_name_gives_bench_names_within_24_characters():
    name, prefix = plan_module.bench_names("A" * 24)
    other, _ = plan_module.bench_names("A" * 23 + "B")
    assert len(name) <= 24 and len(prefix) + 2 <= 24 and name != other


def test_the_block_under_test_never_calls_or_reads_a_data_block():
    from thermoplc.verifier.reading.parser import StSyntaxError, parse_text
    for body in ('x := "D".a[1];', "x := D.a;", "D(a := 1.0);"):
        with pytest.raises(StSyntaxError, match="only a test bench"):
            parse_text(f"FUNCTION_BLOCK B VAR x : REAL; D : REAL; END_VAR {body} END_FUNCTION_BLOCK", "b.st")


def test_the_command_writes_the_bench_and_says_what_it_holds(tmp_path):
    data = golden_twin_csv(tmp_path)
    block, model = golden_block("kalman", "tia"), GOLDEN / "kalman.json"
    out = thermoplc("testbench", block, "--model", model, "--data", data, "-o", "bench", "--calls", "300",
                    "--from", "11", cwd=tmp_path).stdout
    assert "test bench ThermalComp_TB (tia) for kalman.tia.scl: 300 calls, rows 11 to 310 of golden_twin.csv's 4,321" in out
    assert "run here (thermoplc's interpreter): Done = True, Calls = 300, Mismatches = 0: exact" in out
    written = (tmp_path / "bench" / "ThermalComp_TB.scl").read_text()
    assert 'DATA_BLOCK "ThermalComp_TB_D1"' in written and "FUNCTION_BLOCK \"ThermalComp_TB\"" in written
    again = thermoplc("testbench", block, "--model", model, "--data", data, "-o", "bench", "--calls", "300",
                      "--from", "11", cwd=tmp_path, check=2)
    assert "exists; refusing to replace it" in again.stderr and len(again.stderr.splitlines()) == 1
    thermoplc("testbench", block, "--model", model, "--data", data, "-o", "bench", "--calls", "300", "--from", "11",
              "--force", cwd=tmp_path)
    assert (tmp_path / "bench" / "ThermalComp_TB.scl").read_text() == written  # same inputs, same bytes


@pytest.mark.parametrize("args, message", [
    (("--calls", "5000"), "golden_twin.csv has 4321 rows from row 1"),
    (("--from", "4322"), "golden_twin.csv has rows 1 to 4321"),
    (("--calls", "0"), "--calls: expected"),
    (("--rows-per-cycle", "1001"), "--rows-per-cycle: expected"),
    (("--tolerance-um", "-1"), "--tolerance-um: expected"),
])
def test_the_command_refuses_a_window_outside_the_data_in_one_line(tmp_path, args, message):
    data = golden_twin_csv(tmp_path)
    result = thermoplc("testbench", golden_block("mlr", "iec"), "--model", GOLDEN / "mlr.json", "--data", data,
                       "-o", "bench", *args, cwd=tmp_path, check=2)
    assert message in result.stderr and len(result.stderr.splitlines()) == 1, result.stderr
    assert not (tmp_path / "bench").exists()


def golden_twin_table(folder):
    return read_table(golden_twin_csv(folder))


def test_the_command_writes_nothing_for_a_block_that_fails_its_bench(tmp_path):
    data = golden_twin_csv(tmp_path)
    edited, _ = _first_edit_that_matters("mlr", "step7", golden_twin_table(tmp_path), tmp_path)
    result = thermoplc("testbench", edited, "--model", GOLDEN / "mlr.json", "--data", data, "-o", "bench",
                       "--calls", "500", cwd=tmp_path, check=1)
    assert "Mismatches = " in result.stdout and "differs from the reference in its own test bench" in result.stderr
    assert not (tmp_path / "bench").exists()


finite32 = st.floats(width=32, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(st.lists(finite32, min_size=1, max_size=30), st.lists(st.booleans(), min_size=30, max_size=30),
       st.sampled_from(("tia", "step7", "iec")))
def test_the_values_a_bench_holds_read_back_bit_for_bit(reals, flags, dialect):
    calls = len(reals)
    plan = plan_module.BenchPlan("Block", (plan_module.Port("T", "REAL", tuple(reals)),
                                           plan_module.Port("On", "BOOL", tuple(flags[:calls]))),
                                 (plan_module.Port("Y", "REAL", tuple(reversed(reals))),), 5, ("a note",))
    sources = parse_sources(render_bench(plan, dialect), "bench")
    if dialect == "iec":
        arrays = {d.name: d.initial for d in sources.blocks[0].decls if d.name.startswith("D1_")}
        got = {name[3:]: list(values) for name, values in arrays.items()}
    else:
        found = data_arrays(sources.data_blocks, "bench")["BLOCK_TB_D1"]
        got = {name.capitalize(): values for name, (_, values) in found.items()}
    bits = lambda xs: np.asarray(xs, np.float32).view(np.uint32).tolist()
    assert bits(got["In1"]) == bits(reals) and got["In2"] == flags[:calls]
    assert bits(got["Exp1"]) == bits(list(reversed(reals)))


@pytest.mark.parametrize("a, b", [(1.0, 1.0), (1.0, 2.0), (0.0, -0.0), (float("nan"), 1.0)])
def test_not_equal_is_one_operator_and_sees_what_ieee_sees(a, b):
    from thermoplc.verifier.engines.interpreter import Machine
    from thermoplc.verifier.reading.parser import parse_text
    machine = Machine(parse_text("FUNCTION_BLOCK B VAR_INPUT a, b : REAL; END_VAR VAR_OUTPUT y : BOOL; END_VAR "
                                 "y := a <> b; END_FUNCTION_BLOCK", "b.st"), "b.st")
    machine.call({"a": a, "b": b})
    assert machine.values[machine.slots["Y"]] == (a != b)


@pytest.mark.parametrize("name", ("Calls", "Dut", "row", "In1", "Exp12", "D3_x"))
def test_a_block_named_like_a_variable_of_its_bench_is_refused(name):
    plan = plan_module.BenchPlan(name, (plan_module.Port("T", "REAL", (1.0,)),),
                                 (plan_module.Port("Y", "REAL", (2.0,)),), 5, ())
    with pytest.raises(plan_module.GenerationError, match="also the name of a variable of its test bench"):
        render_bench(plan, "iec")


def test_a_tolerance_never_lets_a_differing_block_be_written(tmp_path):
    data = golden_twin_csv(tmp_path)
    edited, _ = _first_edit_that_matters("mlr", "tia", golden_twin_table(tmp_path), tmp_path)
    result = thermoplc("testbench", edited, "--model", GOLDEN / "mlr.json", "--data", data, "-o", "bench",
                       "--calls", "500", "--tolerance-um", "0.0001", cwd=tmp_path, check=1)
    assert "NOT exact" in result.stdout and "differs from the reference" in result.stderr
    assert not (tmp_path / "bench").exists()


def test_the_recording_is_never_the_bench_written(tmp_path):
    (tmp_path / "x").mkdir()
    data = tmp_path / "x" / "ThermalComp_TB.scl"
    data.write_text(golden_twin_csv(tmp_path).read_text())
    result = thermoplc("testbench", golden_block("mlr", "tia"), "--model", GOLDEN / "mlr.json", "--data", data,
                       "-o", "x", "--calls", "10", "--force", cwd=tmp_path, check=2)
    assert "is also an input of this command" in result.stderr
    assert data.read_text().startswith("time_s")


@pytest.mark.parametrize("dialect", BENCH_DIALECTS)
def test_the_bench_is_its_golden_file(dialect, tmp_path):
    """A change in what a bench holds or how it is printed shows as a diff of tests/golden/bench.* in review
    (python scripts/regen_golden.py rewrites them)."""
    assert rendered_bench(dialect, tmp_path) == golden_bench(dialect).read_text()
