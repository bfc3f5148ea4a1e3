"""Raw logger data onto the block's cycle (`--resample PERIOD`): explicit, never silent.

A real logger records at its own pace (every 10 s for a while, then 40 s, with a second of jitter and an odd
gap); the block runs on a fixed cycle. The calls are t0, t0 + P, ... up to the first call at or after the last
row (t0 the first row's), so a probing on the last row still has its call. Each column is taken onto them by the
rule that matches what the PLC would have seen at that call (after the last row: the last row's value):
- temperatures (and every other measured column): linear between the two rows around the call; a
  temperature moves slowly and continuously, so the line is the best guess and never overshoots;
- the speed and the other `hold` columns: the last value at or before the call (the PLC reads the drive's
  current speed; a mean over the cycle would invent speeds the spindle never ran between two set points);
- a probed target (empty between its probings): each probing at the first call at or after it (the block
  can take a probing only once it has happened; two in one cycle: the later), empty elsewhere; a held
  target (`held`): its last value, so each change still marks a probing, at the call that follows it;
- a target measured at every row: linear, as a temperature;
- pulses (a replay's Reset and ProbeNew: `pulses`): true at a call when true on any row since the call before,
  so a pulse between two calls still reaches the block, at the call that follows it; a pulse's value (ProbeValue
  beside ProbeNew: `pulse_values`) is taken from the pulse's own row (the later of two in one cycle), the last
  value elsewhere, so a probing's value is never one of the empty rows around it.
A row gap longer than MAX_GAP_CALLS cycles is refused with its time named: no rule knows what happened there.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.recordings.table import Table

MAX_GAP_CALLS = 8  # a gap up to this many cycles is bridged by the rules; a longer one is refused
SLACK = 1e-9  # of a cycle: a row at a call's time (up to rounding) is at that call


@dataclass(frozen=True)
class Resampling:
    """The block's cycle and the columns held at their last value (the speed); the model file records it."""
    period_s: float
    hold: tuple[str, ...] = ()
    pulses: tuple[str, ...] = ()  # given by a replay for the block's control inputs, not recorded
    pulse_values: tuple[tuple[str, str], ...] = ()  # (value column, its pulse column): ProbeValue with ProbeNew

    def to_doc(self) -> dict:
        return {"period_s": self.period_s, "hold": list(self.hold), "rule": RULE}

    @classmethod
    def holding(cls, period_s: float | None, held: tuple[str | None, ...]) -> "Resampling | None":
        """The rule fit, verify and diagnose take a raw recording onto a cycle of `period_s` by (None: none): the
        columns of `held` that are given (speed, feed: a set point holds until it changes) hold their last value."""
        return cls(period_s, tuple(column for column in held if column)) if period_s else None

    @classmethod
    def from_doc(cls, doc: dict) -> "Resampling":
        return cls(float(doc["period_s"]), tuple(doc.get("hold", ())))


RULE = ("calls every period_s from the first row; temperatures and a target measured at every row linear; the hold "
        "columns (speed) and a held target the last value at or before the call; a probed target's probings at the "
        "first call at or after each")


def resample(table: Table, time_column: str, rule: Resampling, probed: tuple[str, ...] = (),
             held: bool = False) -> Table:
    """`table` on the calls of `rule`; a probed column (in `probed`) empty between its probings, or `held`."""
    t = table.column(time_column)
    step = rule.period_s
    if len(t) < 2:
        raise UserError(f"{table.path}: --resample needs at least two rows")
    gaps = np.diff(t)
    wide = np.flatnonzero(gaps > MAX_GAP_CALLS * step)
    if len(wide):
        k = int(wide[0])
        raise UserError(f"{table.path}:{table.lines[k + 1]}: column {time_column!r}: no row for {gaps[k]:g} s (from "
                        f"{t[k]:g} s to {t[k + 1]:g} s); --resample {step:g} bridges at most {MAX_GAP_CALLS} calls "
                        f"({MAX_GAP_CALLS * step:g} s): cut the run there into two runs")
    calls = t[0] + step * np.arange(int(np.ceil((t[-1] - t[0]) / step - SLACK)) + 1)
    at_or_before = np.clip(np.searchsorted(t, calls + SLACK * step, side="right") - 1, 0, len(t) - 1)
    columns = {}
    values_of_pulse = {value: pulse for value, pulse in rule.pulse_values if pulse in table.columns}
    for name, values in table.columns.items():
        if name == time_column:
            columns[name] = calls
        elif name in values_of_pulse:
            columns[name] = _value_at_pulses(t, values, table.columns[values_of_pulse[name]], step, at_or_before)
        elif name in rule.pulses:
            columns[name] = _pulses_at_calls(t, values, t[0], step, len(calls))
        elif name in rule.hold or (held and name in probed):
            columns[name] = values[at_or_before]
        elif name in probed and not np.all(np.isfinite(values)):
            columns[name] = _probings_at_calls(t, values, t[0], step, len(calls))
        else:
            columns[name] = np.interp(calls, t, values)
    return replace(table, columns=columns, lines=table.lines[at_or_before])


def _following_call(t: np.ndarray, start: float, step: float) -> np.ndarray:
    """For each row, the first call at or after it (the calls reach the last row: every row has one)."""
    return np.ceil((t - start) / step - SLACK).astype(int)


def _probings_at_calls(t: np.ndarray, values: np.ndarray, start: float, step: float, calls: int) -> np.ndarray:
    """Each finite value at the first call at or after its row; the later of two in one cycle; NaN elsewhere."""
    out = np.full(calls, np.nan)
    rows = np.flatnonzero(np.isfinite(values))
    out[_following_call(t[rows], start, step)] = values[rows]  # in time order: a later probing in a cycle wins
    return out


def _value_at_pulses(t: np.ndarray, values: np.ndarray, pulse: np.ndarray, step: float,
                     at_or_before: np.ndarray) -> np.ndarray:
    """`values` at each call: from the row of the latest pulse since the call before, else the last value."""
    out = values[at_or_before]
    rows = np.flatnonzero(pulse != 0.0)
    out[_following_call(t[rows], t[0], step)] = values[rows]  # in time order: a later pulse in a cycle wins
    return out


def _pulses_at_calls(t: np.ndarray, values: np.ndarray, start: float, step: float, calls: int) -> np.ndarray:
    """1 at a call when any row since the call before it (or at it) is non-zero, else 0."""
    out = np.zeros(calls)
    np.maximum.at(out, _following_call(t, start, step), (values != 0.0).astype(float))
    return out
