"""verify --faults: replay the data with sensor faults injected and check the block stays exact and safe.

Each fault kind is injected on each temperature input in turn, starting a third into the data;
then the PLC program's side: Reset pulses, Reset held, Enable off for a while (with a Reset inside).
For every case the block must still match the float32 reference bit for bit, keep every REAL
output finite, inside the clamp and within the rate limit, and - where the data measure the target -
stay no further from the measured drift than no compensation, unless a status bit says so (the
sensor's fault bit or SensorsDisagree, ProbeRefused, Ready/ENO): no single fault may move the axis further than
no compensation would, unannounced (issue 61). The table also says whether the fault bit was clear
again at the end and how far the fault moved the output compared with the run without it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.models.model import Model
from thermoplc.contract.outputs import (DISAGREE_OUTPUT, ENABLE_INPUT, ENO, K0_PREFIX, PROBE_NEW_INPUT,
                                       PROBE_REFUSED_OUTPUT,
                                       PROBE_SUSPECT_OUTPUT,
                                       PROBE_VALUE_INPUT, READY_OUTPUT, RESET_INPUT, block_names, control_of, named)
from thermoplc.models.kind import fault_key
from thermoplc.models.plausibility import DISAGREE
from thermoplc.models.probing import rising
from thermoplc.models.reference import block_outputs, model_inputs
from thermoplc.models.safety import Limits, guards
from thermoplc.recordings.table import Table
from thermoplc.verifier.replays.probings import probing_inputs, reference_keys, start_value_errors
from thermoplc.verifier.replays.restarts import restart_cases, step_calls
from thermoplc.verifier.replays.expectation import check_interface, check_model_inputs
from thermoplc.verifier.replays.replay import (load_block, replay_and_compare, block_limits, compare_constants, constants_lines,
                                       subnormal_declarations)

TRANSIENT_CALLS = 30
WRONG_PROBING_UM = 50.0  # a chip on the probe: inside any limit a machine has, far beyond what drift does between probings


def _constant(value: float):
    return lambda x, t: np.full_like(x, value)


@dataclass(frozen=True)
class FaultKind:
    name: str
    description: str
    lasting: bool  # True: from the start to the end of the data; False: TRANSIENT_CALLS calls
    apply: object  # (values, seconds since the fault began) -> faulty values
    judged: bool = True  # False: not judged against no compensation: a drive to the clamp tests the clamp, no
    # fault of a machine; Enable/Reset is the PLC program's command, and a Reset starts a run whose drift the
    # recording does not measure


FAULT_KINDS = (
    FaultKind("nan", "reads NaN", False, _constant(np.nan)),
    FaultKind("open", "open circuit, PT100 code 3276.7", False, _constant(3276.7)),
    FaultKind("short", "short circuit, PT100 code -3276.8", False, _constant(-3276.8)),
    FaultKind("jump", "jumps by +5 K", False, lambda x, t: x + np.float32(5.0)),
    FaultKind("dead", "dies: NaN to the end", True, _constant(np.nan)),
    FaultKind("stuck", "frozen: its reading to the end", True, lambda x, t: np.full_like(x, x[0])),
    FaultKind("sine", "paper 000 eq. 18: +2 sin(t/350) degC", True, lambda x, t: x + 2.0 * np.sin(t / 350.0)),
    FaultKind("offset", "paper 000 eq. 19: -2 degC", True, lambda x, t: x - np.float32(2.0)),
)


# what a probing cycle gone wrong sends a fused block: (kind, how the value and the edges change from a probing on)
PROBE_KINDS = (
    FaultKind("probe-nan", "one probing reads NaN", False, None),
    FaultKind("probe-inf", "one probing reads +Inf", False, None),
    FaultKind("probe-spike", "one probing 1000 um off", False, None),
    FaultKind("probe-wrong", "one probing 50 um off (a chip)", False, None),
    FaultKind("probe-stuck", "stuck to the end, edges go on", True, None),
    FaultKind("probe-flood", "ProbeNew toggles for 30 calls", False, None),
    FaultKind("probe-held", "ProbeNew held TRUE for 30 calls", False, None),
)
# probings at either limit, one every second call, until the taught offset stands at that side's clamp: a block
# whose clamp (either branch) is missing or wrong differs from the reference there (the other cases never take
# the offset that far)
PROBE_CLAMPS = {1.0: FaultKind("probe-clamp+", "at +limit, as often as allowed", False, None, False),
                -1.0: FaultKind("probe-clamp-", "at -limit, as often as allowed", False, None, False)}
CLAMP_HOLD_CALLS = 50  # calls the run of probings goes on once the offset is at its clamp


def _probe_fault(kind: FaultKind, value: np.ndarray, new: np.ndarray, first: int) -> tuple[dict, int]:
    """The probing inputs with `kind` applied at the first probing from row `first` on; the last row touched."""
    value, new = np.array(value, np.float32), np.array(new, bool)
    edges = np.flatnonzero(rising(new))
    at = int(edges[edges >= first][0]) if (edges >= first).any() else first
    last = at
    if kind.name in ("probe-nan", "probe-inf", "probe-spike", "probe-wrong"):
        off = np.float32(WRONG_PROBING_UM if kind.name == "probe-wrong" else 1000.0)
        bad = {"probe-nan": np.nan, "probe-inf": np.inf}.get(kind.name, value[at] + off)
        value[at:] = np.where(np.arange(at, len(value)) < (edges[edges > at][0] if (edges > at).any() else len(value)),
                              np.float32(bad), value[at:])
    elif kind.name == "probe-stuck":
        value[at:] = value[at]
        last = len(value) - 1
    else:
        last = min(len(new) - 1, at + TRANSIENT_CALLS - 1)
        held = kind.name == "probe-held"
        new[at:last + 1] = True if held else (np.arange(at, last + 1) - at) % 2 == 0
    return {PROBE_VALUE_INPUT: value, PROBE_NEW_INPUT: new}, last


def _probe_clamp(model: Model, static: np.ndarray, value: np.ndarray, new: np.ndarray, sign: float
                 ) -> tuple[dict, int, int, np.ndarray]:
    """The probing inputs with a run of probings at `sign` times the limit, an edge every second call (or, with a
    fitted schedule, as often as it lets a probing through: every `min_calls`), until the offset the reference learns
    from them has stood at that side's clamp for CLAMP_HOLD_CALLS calls (or the data end), then the schedule's own
    probings again: an offset that went past its clamp comes back on other calls than one held there, even where
    the output clamp hides the offset itself (an offset limit wider than the output clamp). The run starts where
    the static prediction leaves the offset the most room to that side (in the first three quarters of the data:
    a clamp wider than the limit minus the prediction can never be reached). Returns the inputs, the run's first
    and last rows, and per call whether the offset is there (on the inputs returned)."""
    fusion = model.probe
    limit, clamp = np.float32(fusion.value("limit_um")), np.float32(fusion.value("offset_max_um"))
    scheduled_value, scheduled_new = value, new
    value, new = np.array(value, np.float32), np.array(new, bool)
    rows = len(new)
    first = int(np.argmin(sign * static[:max(1, rows - rows // 4)].astype(np.float64)))
    value[first:] = np.float32(sign) * limit
    spacing = max(2, int(fusion.min_calls[0])) if fusion.min_calls is not None else 2
    new[first:] = (np.arange(first, rows) - first) % spacing == 0
    reached = np.flatnonzero(_at_clamp(fusion, static, value, new, sign, clamp)[first:])
    last = min(rows - 1, first + int(reached[0]) + CLAMP_HOLD_CALLS) if len(reached) else rows - 1
    value[last + 1:], new[last + 1:] = scheduled_value[last + 1:], scheduled_new[last + 1:]
    after = last + 1  # a scheduled probing already under way, or one that would join the run's last edge, is left
    while after < rows and new[after]:  # out: the schedule's next probing is a rising edge of its own
        new[after] = False
        after += 1
    return ({PROBE_VALUE_INPUT: value, PROBE_NEW_INPUT: new}, first, last,
            _at_clamp(fusion, static, value, new, sign, clamp))


def _at_clamp(fusion, static: np.ndarray, value: np.ndarray, new: np.ndarray, sign: float, clamp) -> np.ndarray:
    """Per call, whether the offset the reference learns from these probings stands at `sign`'s clamp."""
    from thermoplc.models.probing import fuse
    offset = fuse(fusion, static, value, new, "f32")["fused"].astype(np.float64) - static.astype(np.float64)
    return sign * offset >= np.float64(clamp) * (1 - 1e-6)


def _pulses(rows: int, first: int, *offsets: int) -> np.ndarray:
    flags = np.zeros(rows, bool)
    flags[[r for r in (first + k for k in offsets) if r < rows]] = True
    return flags


def _window(rows: int, first: int, calls: int, value: bool) -> np.ndarray:
    flags = np.full(rows, not value)
    flags[first:first + calls] = value
    return flags


# what a PLC program does with the block's Enable and Reset: (kind, inputs per call, last row of the action)
CONTROL_KINDS = (
    (FaultKind("reset", "TRUE 1 call, again 30 calls on", False, None, False),
     lambda rows, first: {RESET_INPUT: _pulses(rows, first, 0, TRANSIENT_CALLS)}, TRANSIENT_CALLS),
    (FaultKind("reset-held", "TRUE for 30 calls", False, None, False),
     lambda rows, first: {RESET_INPUT: _window(rows, first, TRANSIENT_CALLS, True)}, TRANSIENT_CALLS - 1),
    (FaultKind("disable", "Enable FALSE 300 calls", False, None, False),
     lambda rows, first: {ENABLE_INPUT: _window(rows, first, 10 * TRANSIENT_CALLS, False)}, 10 * TRANSIENT_CALLS - 1),
    (FaultKind("disable+reset", "off 300 calls, Reset in/after", False, None, False),
     lambda rows, first: {ENABLE_INPUT: _window(rows, first, 10 * TRANSIENT_CALLS, False),
                          RESET_INPUT: _pulses(rows, first, 5, 10 * TRANSIENT_CALLS)}, 10 * TRANSIENT_CALLS),
)


@dataclass(frozen=True)
class Harm:
    """Over a case's rows (the fault's and every later one where the output differs from the fault-free block's):
    the faulted block's largest distance from the measured drift, where it was, and no compensation's largest."""
    worst: float
    worst_row: int
    none: float


def harm_of(output: np.ndarray, baseline: np.ndarray, measured: np.ndarray | None, first: int, last: int
            ) -> Harm | None:
    """How far the faulted target output is from the measured drift beside compensating nothing, on the case's
    rows where the target is measured; None without a measured target there."""
    if measured is None:
        return None
    moved = np.flatnonzero(output.view(np.uint32) != baseline.view(np.uint32))
    end = max(last, int(moved[-1]) if len(moved) else last)
    rows = np.arange(first, end + 1)
    rows = rows[np.isfinite(measured[rows])]
    if not len(rows):
        return None
    error = np.abs(output[rows].astype(np.float64) - measured[rows])
    k = int(np.argmax(error))
    return Harm(float(error[k]), int(rows[k]), float(np.max(np.abs(measured[rows]))))



@dataclass(frozen=True)
class FaultCase:
    kind: FaultKind
    sensor: str
    first_row: int
    last_row: int
    bit_exact: bool
    finite: bool
    within_clamp: bool
    within_rate: bool
    flagged: bool
    clear_at_end: bool
    max_change: float  # largest |output with fault - output without| of the model's target
    failure: str | None = None  # the block's run-time error in this case (verifier/engines/semantics.py::BlockFailure)
    harm: Harm | None = None  # the faulted block against no compensation; None: the data do not measure the target

    @property
    def safe(self) -> bool:
        """Not further from the measured drift than no compensation, or a status bit said so."""
        return self.harm is None or self.flagged or self.harm.worst <= self.harm.none

    @property
    def ok(self) -> bool:
        return self.bit_exact and self.finite and self.within_clamp and self.within_rate and self.safe


def inject(values: np.ndarray, times: np.ndarray, kind: FaultKind, first: int) -> tuple[np.ndarray, int]:
    """A copy of a float32 column with the fault applied from row `first`; returns it and the last faulty row."""
    out = np.array(values, np.float32)
    last = len(out) - 1 if kind.lasting else min(len(out) - 1, first + TRANSIENT_CALLS - 1)
    span = slice(first, last + 1)
    seconds = (times[span] - times[first]).astype(np.float64)
    out[span] = np.asarray(kind.apply(out[span].astype(np.float64), seconds), np.float64).astype(np.float32)
    return out, last


def _within_rate(series: np.ndarray, step: float) -> bool:
    """Each change at most the step, allowing the rounding of y + step in binary32."""
    y = series.astype(np.float64)
    allowed = step + np.spacing(np.maximum(np.abs(y[1:]), np.abs(y[:-1])).astype(np.float32)).astype(np.float64)
    return bool(np.all(np.abs(np.diff(y)) <= allowed))


@dataclass(frozen=True)
class FaultReport:
    """Every case, and the checks the data cannot make: the declared constants and tables against the
    model's (an entry no replayed case reaches is covered by this alone) and subnormal declarations."""
    block: str
    rows: int
    cases: tuple[FaultCase, ...]
    constants_checked: int
    constant_errors: tuple[str, ...]
    unsafe: tuple[str, ...]
    not_run: tuple[str, ...] = ()  # restart cases the data are too short for, and why

    @property
    def ok(self) -> bool:
        return all(c.ok for c in self.cases) and not self.constant_errors and not self.unsafe

    def text(self) -> str:
        verdict = [f"NOT bit-exact: {self.block} holds constants that differ from the model (listed after the "
                   f"fault cases)"] if self.constant_errors else []
        return "\n".join([*verdict, format_cases(list(self.cases), self.block, self.rows),
                          *(f"not run (the data are too short): {why}" for why in self.not_run),
                          *self._failures(),
                          *constants_lines(self.constants_checked, self.constant_errors),
                          *(f"UNSAFE: {line}" for line in self.unsafe)])


    def _failures(self) -> list[str]:
        """Each run-time error of the block once, with the cases that met it."""
        met: dict[str, list[str]] = {}
        for c in self.cases:
            if c.failure:
                met.setdefault(c.failure, []).append(f"{c.sensor}/{c.kind.name}")
        return [f"run-time error in {len(cases)} case(s) ({', '.join(cases[:4])}{', ...' if len(cases) > 4 else ''}): "
                f"{failure}" for failure, cases in met.items()]


def verify_faults(block: str, model: Model, table: Table, overrides: dict | None = None,
                  engine: str = "auto", probe_every: int | None = None) -> FaultReport:
    """The block replayed once per fault case against the model's reference, its declared values
    checked against the model's as plain verify checks them."""
    program, machine = load_block(block, engine)
    limits: Limits = block_limits(program, block)
    cases, not_run = _cases(machine, block, model, table, overrides, limits, probe_every)
    checked, errors = compare_constants(program, model, limits)
    errors = (*errors, *(start_value_errors(machine.inputs) if model.probe is not None else ()))
    return FaultReport(block, table.rows, tuple(cases), checked, errors,
                       tuple(subnormal_declarations(program.decls, block)), tuple(not_run))


def _reference(model: Model, inputs: dict, limits: Limits, control: dict | None = None) -> dict:
    """The reference's outputs for block inputs keyed by the block's names (the probing under the reference's)."""
    return block_outputs(model, {**inputs, **reference_keys(inputs)}, "f32", limits, control)


def _cases(machine, block: str, model: Model, table: Table, overrides: dict | None, limits: Limits,
           probe_every: int | None) -> tuple[list[FaultCase], list[str]]:
    """Each fault on each temperature input in turn, then each Enable/Reset action, the restarts, then (a fused
    block) each probing fault, replayed and compared; and the restart cases not run, with why."""
    check_model_inputs(machine, block, model, "model file")  # the command line puts the file's name in
    probing = probing_inputs(model, table, overrides, probe_every)
    clean = {**model_inputs(model, table, overrides), **probing}
    check_interface(machine, block, clean, "the model inputs")
    times = table.columns[model.time_column] if model.time_column in table.columns else np.arange(table.rows) * 1.0
    fault_free = _reference(model, clean, limits)
    baseline = fault_free[model.target.name]
    already = np.asarray(fault_free.get(DISAGREE, False), bool)  # a disagreement the fault did not cause says nothing
    measured = (np.asarray(table.columns[model.target.column], np.float64)
                if model.target.column in table.columns else None)
    first = table.rows // 3
    names = block_names(model, [d.name for d in machine.outputs])
    cases = []
    temperatures = [g.name for g in guards(model) if g.low == "temp_min"]
    for name in temperatures:
        for kind in FAULT_KINDS:
            inputs = dict(clean)
            inputs[name], last = inject(clean[name], np.asarray(times), kind, first)
            expected = named(_reference(model, inputs, limits), names)
            report = replay_and_compare(machine, block, "reference", table, model.time_column, inputs, expected, {})
            cases.append(_case(kind, name, first, last, expected, report, machine, limits, model, baseline, measured,
                               _sensor_flags(expected, names, name, already)))
    declared = {d.name for d in machine.inputs}
    for kind, action, length in CONTROL_KINDS:
        control = action(table.rows, first)
        if not set(control) <= declared:
            continue  # a block generated before Enable and Reset existed
        expected = named(_reference(model, clean, limits, control_of(control)), names)
        report = replay_and_compare(machine, block, "reference", table, model.time_column, {**clean, **control},
                                     expected, {})
        cases.append(_case(kind, "/".join(control), first, min(first + length, table.rows - 1), expected, report,
                           machine, limits, model, baseline, measured, _stopped(expected)))
    restarted, not_run = _restart_cases(machine, block, model, table, clean, temperatures, first, limits, names,
                                        baseline, measured, already, probing)
    cases += restarted
    for kind in PROBE_KINDS if probing else ():
        faulty, last = _probe_fault(kind, probing[PROBE_VALUE_INPUT], probing[PROBE_NEW_INPUT], first)
        inputs = {**clean, **faulty}
        expected = named(_reference(model, inputs, limits), names)
        report = replay_and_compare(machine, block, "reference", table, model.time_column, inputs, expected, {})
        cases.append(_case(kind, PROBE_VALUE_INPUT, first, last, expected, report, machine, limits, model, baseline,
                           measured, np.asarray(expected[PROBE_REFUSED_OUTPUT], bool)
                           | np.asarray(expected.get(PROBE_SUSPECT_OUTPUT, False), bool)))
    static = _reference(model, {**clean, PROBE_NEW_INPUT: np.zeros(table.rows, bool)}, limits)[model.target.name] \
        if probing else None
    for sign, kind in PROBE_CLAMPS.items() if probing else ():
        faulty, start, last, at_clamp = _probe_clamp(model, static, probing[PROBE_VALUE_INPUT],
                                                     probing[PROBE_NEW_INPUT], sign)
        inputs = {**clean, **faulty}
        expected = named(_reference(model, inputs, limits), names)
        report = replay_and_compare(machine, block, "reference", table, model.time_column, inputs, expected, {})
        cases.append(_case(kind, PROBE_VALUE_INPUT, start, last, expected, report, machine, limits, model, baseline, measured,
                           at_clamp))
    return cases, not_run


def _sensor_flags(expected: dict, names: dict, sensor: str, already: np.ndarray) -> np.ndarray:
    """Per call, whether the sensor's fault bit or a SensorsDisagree the fault caused is set."""
    return (np.asarray(expected[names[fault_key(sensor)]], bool)
            | np.asarray(expected.get(DISAGREE_OUTPUT, False), bool) & ~already)


def _stopped(expected: dict) -> np.ndarray:
    """Per call, whether Ready or ENO is FALSE: the block says it does not compensate."""
    return ~np.asarray(expected[READY_OUTPUT], bool) | ~np.asarray(expected[ENO], bool)


def _restart_cases(machine, block: str, model: Model, table: Table, clean: dict, temperatures: list[str], first: int,
                   limits: Limits, names: dict, baseline: np.ndarray, measured: np.ndarray | None,
                   already: np.ndarray, probing: dict) -> tuple[list[FaultCase], list[str]]:
    """Where the block's state starts afresh, or carries on, after the data moved (verifier/replays/restarts.py), each
    replayed; and why a case the data are too short for was not run."""
    cases = []
    declared = {d.name for d in machine.inputs}
    default_row = min(first + step_calls(model, limits.settle_calls), table.rows - 1)
    restarts, not_run = restart_cases(model, clean, temperatures, declared, limits, default_row, probing or None)
    for r in restarts:
        inputs = {**clean, **r.columns}
        expected = named(_reference(model, inputs, limits, control_of(r.control)), names)
        report = replay_and_compare(machine, block, "reference", table, model.time_column, {**inputs, **r.control},
                                    expected, {})
        flags = _stopped(expected)
        if r.sensor is not None:
            flags = flags | _sensor_flags(expected, names, r.sensor, already)
        cases.append(_case(FaultKind(r.name, r.description, False, None, False), r.what, r.first, r.last, expected,
                           report, machine, limits, model, baseline, measured, flags))
    return cases, not_run


def _case(kind: FaultKind, what: str, first: int, last: int, expected: dict, report, machine, limits: Limits,
          model: Model, baseline: np.ndarray, measured: np.ndarray | None, flags: np.ndarray) -> FaultCase:
    """A case's row of the table from the reference outputs and the replay's report."""
    real = [np.asarray(v, np.float32) for v in expected.values() if np.asarray(v).dtype.kind == "f"]
    limited = [np.asarray(expected[v.name], np.float32) for v in machine.outputs
               if v.type.base == "REAL" and not v.name.startswith(K0_PREFIX)]
    return FaultCase(
        kind, what, first, last, report.mismatch is None and report.failure is None,
        all(bool(np.all(np.isfinite(v))) for v in real) and not any(f.kind in ("nan", "inf") for f in report.findings),
        all(bool(np.all(np.abs(v) <= np.float32(limits.max_output))) for v in limited),
        all(_within_rate(v, limits.max_step) for v in limited),
        bool(flags[first:last + 1].any()), not bool(flags[-1]),
        float(np.max(np.abs(expected[model.target.name].astype(np.float64) - baseline.astype(np.float64)))),
        report.failure, None if not kind.judged else harm_of(np.asarray(expected[model.target.name], np.float32), np.asarray(baseline, np.float32), measured,
                first, last))


def format_cases(cases: list[FaultCase], block: str, rows: int) -> str:
    lines = [f"fault injection on {block}: {len(cases)} cases over {rows} calls each, sensor faults start at call "
             f"{cases[0].first_row if cases else 0}; transient faults last {TRANSIENT_CALLS} calls",
             f"{'sensor':<16}{'fault':<44}{'bit-exact':>10}{'finite':>8}{'clamp':>7}{'rate':>6}"
             f"{'flagged':>9}{'clear at end':>14}{'max change':>12}{'error':>9}{'none':>8}"]
    yes = lambda b: "yes" if b else "NO"
    judged = lambda h: f"{h.worst:>9.4g}{h.none:>8.4g}" if h is not None else f"{'-':>9}{'-':>8}"
    for c in cases:
        lines.append(f"{c.sensor:<16}{c.kind.name + ': ' + c.kind.description:<44}{yes(c.bit_exact):>10}"
                     f"{yes(c.finite):>8}{yes(c.within_clamp):>7}{yes(c.within_rate):>6}"
                     f"{'yes' if c.flagged else 'no':>9}{'yes' if c.clear_at_end else 'no':>14}{c.max_change:>12.4g}"
                     f"{judged(c.harm)}")
    bad = [c for c in cases if not c.ok]
    lines.append("all cases bit-exact, finite, inside the clamp and the rate limit, none further from the measured "
                 "drift than no compensation unflagged" if not bad else
                 f"{len(bad)} case(s) FAILED: " + ", ".join(f"{c.sensor}/{c.kind.name}" for c in bad))
    lines += [f"{c.sensor}/{c.kind.name}: {c.harm.worst:.4g} um from the measured drift at call {c.harm.worst_row}, "
              f"further than no compensation ({c.harm.none:.4g} um at most on calls {c.first_row}..), and no status "
              f"bit said so" for c in cases if not c.safe]
    probed = any(c.kind in PROBE_KINDS for c in cases)
    lines.append("clear at end describes the block's behaviour, it is no pass criterion; max change is the largest "
                 "|error with fault - error without| in the target's unit; error is the faulted block's largest "
                 "|output - measured drift| and none no compensation's (the largest |drift|) over the case's calls "
                 "(from the fault on, as long as the output differs from the fault-free block's); a case whose error "
                 "exceeds none fails unless flagged ('-': not judged: the data do not measure the target, a drive to "
                 "the clamp, or an Enable/Reset action the PLC program commands); for a sensor, flagged means its "
                 "fault bit or SensorsDisagree came up; for Enable/Reset, Ready or ENO went FALSE; reset-after: the temperature "
                 "reads off by the step until the check's slow mean has followed it, then comes a Reset where it differs "
                 "most from what the others say, and from there off by what the row says (a sensor swapped in the stop); "
                 "reset-far: a Reset after which a temperature reads beyond its level gate, then comes back; pause: Enable FALSE "
                 "across the largest move of a difference from its slow mean that no jump check flags; pause-flagged: a "
                 "temperature ramped beyond its gate and back, then Enable FALSE while SensorsDisagree waits for its "
                 "settle calls; reset-stuck: a "
                 "temperature frozen until its stuck check fires, then a Reset; pause-stuck: frozen, Enable FALSE one "
                 "call in fifty; probe-reset: a NaN probing and ProbeNew held, then a Reset; probe-pause: Enable "
                 "FALSE between two probings; late-start: the block enabled a few "
                 "calls before the call where a temperature differs most from what the others say, a temperature NaN "
                 "until then; each restart case at calls where every input is in range" + ("; for a probing, that ProbeRefused or ProbeSuspect came up; for "
                                                            "probe-clamp+/-, that the offset reached that clamp"
                                                            if probed else ""))
    lines += [f"{c.kind.name}: the offset never reached its clamp from call {c.first_row} on (the limit minus the "
              f"prediction stays inside it); that clamp is checked against the model file's constant only"
              for c in cases if c.kind in PROBE_CLAMPS.values() and not c.flagged]
    return "\n".join(lines)
