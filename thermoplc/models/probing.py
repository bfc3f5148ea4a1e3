"""Probe fusion (DESIGN §10): the block learns from the machine's own probing cycles.

A probing cycle touches a reference artefact every 15-120 min and measures the real displacement at one
call. A fused block takes it as two inputs, the value (um) and a BOOL whose rising edge says "a new probing
at this call", and keeps a small state fitted from the innovations (probing minus prediction): an offset
that walks and, where held-out runs want it, a drift rate. Between probings it outputs the static
prediction plus the offset. Per call, in this order (generator/probing.py emits the same operations):

    rate:   Offset := Offset + Rate                       (only with a rate state)
    decay:  Offset := Offset * Decay                      (only when the offset decays between probings)
    counts: Held := Held + 1 while ProbeNew is TRUE, else 0; Since := Since + 1 (both stop at COUNT_MAX)
    edge:   New := ProbeNew AND NOT Seen; Seen := ProbeNew
    if New: the probing is suspect (Suspect) when it comes sooner than MinCalls after the last one (a flooding
            probe; only with a fitted schedule), or when its value equals the last STUCK_COUNT probings' while the
            prediction moved further than STUCK_SHARE of the gate since the first of them (a frozen probe); Since := 0. A suspect
            probing is refused; else it is judged: a probing whose |value| <= Limit gives Innov := value - (static + Offset); with |Innov| <= Gate, or
            as the first probing taken since the start (nothing learnt yet for the gate to judge by), or after
            REJOIN probings in a row beyond the gate, Offset := Offset + Gain * Innov (Rate := Rate + RateGain *
            Innov), Used; else Refused, counted
    held:   ProbeNew TRUE for more than HELD_MAX calls in a row (a stuck bit) sets Suspect too; the next probing
            that is not suspect clears it
    clamp:  Offset within +-OffsetMax, Rate within +-RateMax
    output: static + Offset (then the output limiter of every block)

A refused probing (NaN, Inf, beyond the target's limit, or further from the prediction than the gate)
leaves the state as it was. The state belongs to the block like any other: Reset clears it, Enable FALSE
holds it, a RETAIN block keeps it. The reference here is the float32 (or float64) loop of that order.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from thermoplc.base.binary32 import f32_hex, round_f32
from thermoplc.base.errors import UserError
from thermoplc.base import compiled
from thermoplc.models.pair import constant_pair

PROBE_VALUE, PROBE_NEW = "probe:value", "probe:new"  # the reference's keys of the block's probing inputs
USED, REFUSED, REFUSALS = "status:probe_used", "status:probe_refused", "count:probe_refusals"
SUSPECT = "status:probe_suspect"
COUNT_MAX = 32767  # the refusal counter is an INT: it stops there
REJOIN = 1  # after this many probings in a row refused by the gate alone, the next is taken: the drift really moved
# (a run whose static error starts beyond the gate, a shift after a crash) and the offset must follow it
STUCK_COUNT = 2  # a probing equal to the last this many is frozen when the prediction moved since by more than
STUCK_SHARE = 0.25  # this share of the gate (the gate is 4 x the innovations' RMS: about one typical innovation)
HELD_MAX = 20  # calls ProbeNew may stay TRUE (a PLC's pulse lasts a few): longer is a stuck bit
REQUIRED = ("gain", "gate_um", "limit_um", "offset_max_um")
OPTIONAL = ("rate_gain", "rate_max_um", "decay", "min_calls")


@dataclass(frozen=True)
class Fusion:
    """The fusion's constants, each a binary32 value (f32) with the float64 it was fitted as (f64)."""
    gain: tuple[float, float]
    gate_um: tuple[float, float]
    limit_um: tuple[float, float]
    offset_max_um: tuple[float, float]
    rate_gain: tuple[float, float] | None = None  # None: no rate state
    rate_max_um: tuple[float, float] | None = None
    decay: tuple[float, float] | None = None  # None: the offset is held between probings
    min_calls: tuple[float, float] | None = None  # a probing sooner than this after the last floods; None: not judged

    @staticmethod
    def of(gain: float, gate_um: float, limit_um: float, offset_max_um: float, rate_gain: float | None = None,
           rate_max_um: float | None = None, decay: float | None = None, min_calls: int | None = None) -> "Fusion":
        pair = lambda v: None if v is None else (float(v), round_f32(float(v)))
        return Fusion(pair(gain), pair(gate_um), pair(limit_um), pair(offset_max_um), pair(rate_gain),
                      pair(rate_max_um), pair(decay), pair(min_calls))

    @property
    def has_rate(self) -> bool:
        return self.rate_gain is not None

    def value(self, name: str, precision: str = "f32") -> float:
        pair = getattr(self, name)
        return pair[0] if precision == "f64" else pair[1]

    def values(self) -> dict[str, float]:
        """The binary32 value of each constant the block declares (contract/constants.py names them)."""
        return {name: getattr(self, name)[1] for name in (*REQUIRED, *OPTIONAL) if getattr(self, name) is not None}

    def to_doc(self) -> dict:
        return {name: {"f64": pair[0], "f32": f32_hex(pair[1])}
                for name in (*REQUIRED, *OPTIONAL) if (pair := getattr(self, name)) is not None}

    @staticmethod
    def from_doc(doc, path: str) -> "Fusion":
        """The model file's `probe` section; every problem named by its field."""
        if not isinstance(doc, dict):
            raise UserError(f"{path}: field 'probe': expected an object of the fusion's constants")
        unknown = sorted(set(doc) - set(REQUIRED) - set(OPTIONAL))
        if unknown:
            raise UserError(f"{path}: field 'probe.{unknown[0]}': not a constant of the fusion; it has "
                            f"{', '.join((*REQUIRED, *OPTIONAL))}")
        values = {}
        for name in (*REQUIRED, *OPTIONAL):
            if name not in doc:
                if name in REQUIRED:
                    raise UserError(f"{path}: field 'probe.{name}' is missing")
                continue
            values[name] = constant_pair(doc[name], path, f"probe.{name}")
        if ("rate_gain" in values) != ("rate_max_um" in values):
            raise UserError(f"{path}: field 'probe': a rate state needs both rate_gain and rate_max_um")
        fusion = Fusion(**values)
        _check(fusion, path)
        return fusion


def _check(fusion: Fusion, path: str) -> None:
    """Ranges that keep the state finite and the block's range proof simple."""
    rules = {"gain": (1e-6, 1.0), "rate_gain": (0.0, 1.0), "decay": (1e-6, 1.0), "gate_um": (1e-3, 1e6),
             "limit_um": (1e-3, 1e6), "offset_max_um": (1e-3, 1e6), "rate_max_um": (1e-9, 1e3),
             "min_calls": (1, COUNT_MAX)}
    for name, (low, high) in rules.items():
        pair = getattr(fusion, name)
        if pair is not None and not (np.isfinite(pair[1]) and low <= pair[1] <= high):
            raise UserError(f"{path}: field 'probe.{name}': {pair[0]!r}; expected a value from {low:g} to {high:g}")
    if fusion.min_calls is not None and fusion.min_calls[0] != int(fusion.min_calls[0]):
        raise UserError(f"{path}: field 'probe.min_calls': {fusion.min_calls[0]!r}; expected a whole number of calls")


def fuse(fusion: Fusion, static: np.ndarray, value: np.ndarray, new: np.ndarray, precision: str) -> dict:
    """The fused target per call from the static prediction and the probing inputs, with the status flags
    and the refusal count (block outputs), as the block computes them from its first running call; `before`:
    the prediction a probing at that call is judged against (the worst moment for a part, just before it)."""
    f = np.float32 if precision == "f32" else np.float64
    rows = len(static)
    c = {name: f(fusion.value(name, precision)) for name in fusion.values()}
    out, before = np.empty(rows, f), np.empty(rows, f)
    used, refused, suspect = np.zeros(rows, bool), np.zeros(rows, bool), np.zeros(rows, bool)
    count = np.zeros(rows, np.int16)
    state = np.zeros(2, f)  # offset, rate
    min_calls = int(fusion.min_calls[0]) if fusion.min_calls is not None else 0
    compiled.route(_fuse, rows)(
        np.ascontiguousarray(static, f), np.ascontiguousarray(value, f), np.ascontiguousarray(new, np.bool_),
        state, c["gain"], c.get("rate_gain", f(0)), c.get("decay", f(1)), c["gate_um"], c["limit_um"],
        c["offset_max_um"], c.get("rate_max_um", f(0)), fusion.has_rate, fusion.decay is not None, min_calls,
        c["gate_um"] * f(STUCK_SHARE),
        out, before, used, refused, suspect, count)
    return {"fused": out, "before": before, USED: used, REFUSED: refused, SUSPECT: suspect, REFUSALS: count}


@compiled.jit
def _fuse(static, value, new, state, gain, rate_gain, decay, gate, limit, offset_max, rate_max, has_rate, has_decay,
          min_calls, stuck_move, out, before, used, refused, suspected, count):
    offset, rate = state[0], state[1]
    last, stuck_ref = offset * 0, offset * 0
    seen = False
    refusals = 0
    missed = 0
    anchored = False
    suspect = False
    any_probing = False
    same, held, since = 0, 0, 0
    for j in range(static.shape[0]):
        if has_rate:
            offset = offset + rate
        if has_decay:
            offset = offset * decay
        before[j] = static[j] + offset
        if new[j]:
            if held < COUNT_MAX:
                held += 1
        else:
            held = 0
        if since < COUNT_MAX:
            since += 1
        edge = new[j] and not seen
        seen = new[j]
        if edge:
            if value[j] == last:
                if same < COUNT_MAX:
                    same += 1
            else:
                same = 0
                stuck_ref = static[j]
            last = value[j]
            suspect = (any_probing and since < min_calls) or (same >= STUCK_COUNT and abs(static[j] - stuck_ref) > stuck_move)
            any_probing = True
            since = 0
            accepted = False
            if not suspect and abs(value[j]) <= limit:
                innovation = value[j] - (static[j] + offset)
                if abs(innovation) <= gate or not anchored or missed >= REJOIN:
                    offset = offset + gain * innovation
                    if has_rate:
                        rate = rate + rate_gain * innovation
                    accepted = True
                    missed = 0
                    anchored = True
                else:
                    missed += 1
            if accepted:
                used[j] = True
            else:
                refused[j] = True
                if refusals < COUNT_MAX:
                    refusals += 1
        if held > HELD_MAX:
            suspect = True
        suspected[j] = suspect
        if offset > offset_max:
            offset = offset_max
        elif offset < -offset_max:
            offset = -offset_max
        if has_rate:
            if rate > rate_max:
                rate = rate_max
            elif rate < -rate_max:
                rate = -rate_max
        out[j] = static[j] + offset
        count[j] = refusals
    state[0], state[1] = offset, rate


def fused_core(model, core: dict | None, inputs: dict, start: int, precision: str) -> tuple[dict | None, dict]:
    """The model's values with the target fused from call `start` on (the block's first running call), and
    the fusion's outputs per call; `inputs` without the probing keys is a block whose probing is unwired."""
    rows = len(next(iter(inputs.values())))
    status = {USED: np.zeros(rows, bool), REFUSED: np.zeros(rows, bool), SUSPECT: np.zeros(rows, bool),
              REFUSALS: np.zeros(rows, np.int16)}
    if core is None:
        return core, status
    f = np.float32 if precision == "f32" else np.float64
    value = np.asarray(inputs.get(PROBE_VALUE, np.zeros(rows, f)), f)[start:]
    new = np.asarray(inputs.get(PROBE_NEW, np.zeros(rows, bool)), bool)[start:]
    fused = fuse(model.probe, core[model.target.name], value, new, precision)
    for key in status:
        status[key][start:] = fused[key]
    return {**core, model.target.name: fused["fused"]}, status


HELD_CALLS = 3  # a replayed probing holds ProbeNew TRUE this many calls, as a PLC's pulse does: only its edge counts


def probings(target: np.ndarray, every: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The probing inputs a recording gives the block, (value as float32, new as bool) per call: a probed
    target's measured rows (NaN between) are its probings; `every` N simulates one at calls N, 2N, ... on a
    target measured at every call. The value holds the latest probing (0 before the first), as the NC's
    result variable does; `new` is held TRUE for HELD_CALLS calls from each probing (FALSE again the call
    before the next), so a block that takes a level for an edge differs; back-to-back measured rows are one."""
    target = np.asarray(target, np.float64)
    measured = np.isfinite(target)
    if every is not None:
        calls = np.arange(len(target))
        measured = measured & (calls > 0) & (calls % every == 0)
    latest = np.where(measured, np.arange(len(target)), -1)
    np.maximum.accumulate(latest, out=latest)
    value = np.where(latest >= 0, target[np.maximum(latest, 0)], 0.0).astype(np.float32)
    new = measured.copy()
    for shift in range(1, HELD_CALLS):
        new[shift:] |= measured[:-shift]
    new[:-1] &= measured[:-1] | ~measured[1:]  # FALSE the call before a probing, so that it rises
    return value, new


def rising(new: np.ndarray) -> np.ndarray:
    """The calls at which ProbeNew rises: the probings the block takes."""
    new = np.asarray(new, bool)
    return new & ~np.r_[False, new[:-1]]


def needs_schedule(target: np.ndarray) -> bool:
    """Whether the target is measured at every call, so its probings must be simulated (`every`)."""
    return bool(len(target)) and bool(np.isfinite(target).all())
