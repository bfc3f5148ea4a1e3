"""Compiled per-call loops of the float32/float64 references (the fast route, issue 17).

The loops here are the model files' own reference loops (kalman.predict, grey.predict_gm*n,
safety._hold and the limiter of safety.guarded_predict), written once more for numba, in the same
operation order, and compiled by LLVM with fast-math off (no FMA contraction, no reassociation,
IEEE division and NaN semantics). They never see the emitted ST: the proof still compares two
independent computations (the model's loops here, the block's own ST -> C translation in
verifier/native.py).

Rules that keep every value bit-identical to the numpy scalar loops:
- every array and every scalar argument has the precision's dtype (float32 or float64), so
  numba types each operation in that precision: float32 * float32 -> float32, rounded per
  operation as numpy float32 scalars are;
- no Python float literal appears in arithmetic (a literal is float64 and would promote);
- state lives in small arrays the caller passes in, so a recording can be run chunk by chunk
  with the same result as in one piece.

The pure numpy/Python loops stay: they are the oracle in the tests and the path taken when
numba is missing, THERMOPLC_REFERENCE=slow, or a process has asked for few calls: base/compiled.py's
`enabled()` decides.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base.compiled import jit

# ---------------------------------------------------------------------------------------------
# Kalman fusion (models/kalman.py::predict). sc[i] = A, AA, B, C, D, N, R, P0, Jmp, Agr of sensor i.
# state: tf, pf, t0, tm_prev (float, per sensor); fault (bool, per sensor); started[0] (int).

@jit
def _kalman(te, n, measured, in_range, sc, betas, beta0, tf, pf, t0, tm_prev, fault, started, error, faults):
    k = measured.shape[0]
    rows = te.shape[0]
    for j in range(rows):
        if started[0] == 0:
            for i in range(k):
                tf[i] = measured[i, j]
                t0[i] = measured[i, j]
                tm_prev[i] = measured[i, j]
                pf[i] = sc[i, 7]
                fault[i] = False
            started[0] = 1
        for i in range(k):
            tm = measured[i, j]
            tp = sc[i, 0] * tf[i] + sc[i, 2] * te[j] + sc[i, 3] * n[j] + sc[i, 4]
            pp = sc[i, 1] * pf[i] + sc[i, 5]
            if not in_range[i, j]:
                fault[i] = True
                tf[i] = tp
                pf[i] = pp
                faults[i, j] = True
                continue
            jump = abs(tm - tm_prev[i])
            tm_prev[i] = tm
            if not jump <= sc[i, 8]:
                fault[i] = True
            elif abs(tm - tp) <= sc[i, 9]:
                fault[i] = False
            if fault[i]:
                tf[i] = tp
                pf[i] = pp
            else:
                gain = pp / (pp + sc[i, 6])
                tf[i] = tp + gain * (tm - tp)
                pf[i] = pp - gain * pp
            faults[i, j] = fault[i]
        e = beta0
        for i in range(k):
            e = e + betas[i] * (tf[i] - t0[i])
        error[j] = e


class KalmanState:
    """What the block keeps between calls, for a run in chunks."""

    def __init__(self, k: int, f):
        self.f = f
        self.tf, self.pf, self.t0, self.tm_prev = (np.zeros(k, f) for _ in range(4))
        self.fault = np.zeros(k, np.bool_)
        self.started = np.zeros(1, np.int64)


def kalman(te, n, measured: list, in_range: list, sc: np.ndarray, betas: np.ndarray, beta0, f,
           state: KalmanState | None = None):
    """(error, faults (k, rows)) for these calls; state carries over when given."""
    rows = len(te)
    k = len(measured)
    state = state or KalmanState(k, f)
    error = np.empty(rows, f)
    faults = np.zeros((k, rows), np.bool_)
    stacked = np.empty((k, rows), f)
    for i, m in enumerate(measured):
        stacked[i] = m
    ranges = np.empty((k, rows), np.bool_)
    for i, r in enumerate(in_range):
        ranges[i] = r
    _kalman(np.ascontiguousarray(te, f), np.ascontiguousarray(n, f), stacked, ranges, np.ascontiguousarray(sc, f),
            np.ascontiguousarray(betas, f), f(beta0), state.tf, state.pf, state.t0, state.tm_prev, state.fault,
            state.started, error, faults)
    return error, faults


# ---------------------------------------------------------------------------------------------
# Input guard (models/safety.py::_hold). state_f = last, good; state_i = fault, count.

@jit
def _hold(x, valid, is_range, ready_row, offset, settle, jump, state_f, state_i, held, faults):
    fault = state_i[0] != 0
    count = state_i[1]
    last = state_f[0]
    good = state_f[1]
    for jj in range(x.shape[0]):
        j = jj + offset
        ok = valid[jj]
        if is_range:
            fault = not ok
        elif j <= ready_row:
            fault = not ok
            count = 0
        elif not ok:
            fault = True
            count = 0
        elif not abs(x[jj] - last) <= jump:
            fault = True
            count = 0
        elif fault:
            count += 1
            if count >= settle:
                fault = False
                count = 0
        if ok and not is_range:
            last = x[jj]
        if not fault:
            good = x[jj]
        held[jj] = good
        faults[jj] = fault
    state_i[0] = 1 if fault else 0
    state_i[1] = count
    state_f[0] = last
    state_f[1] = good


class HoldState:
    def __init__(self, f):
        self.values = np.zeros(2, f)  # last, good: f(0) at the first call
        self.flags = np.zeros(2, np.int64)  # fault, count


def hold(x, valid, is_range: bool, ready_row: int, settle: int, jump, f, state: HoldState | None = None,
         offset: int = 0):
    """(held, faults) as safety._hold; offset is the row number of x[0] in the whole recording."""
    state = state or HoldState(f)
    rows = len(x)
    held = np.zeros(rows, f)
    faults = np.zeros(rows, np.bool_)
    _hold(np.ascontiguousarray(x, f), np.ascontiguousarray(valid, np.bool_), bool(is_range), np.int64(ready_row),
          np.int64(offset), np.int64(settle), f(jump), state.values, state.flags, held, faults)
    return held, faults


# ---------------------------------------------------------------------------------------------
# Output limiter (the loop over calls in models/safety.py::guarded_predict), one output.
# y[0] is the output of the previous call.

@jit
def _limit(m, start, y_state, series, limited, clamped, invalid, real_max, step_max, step_min, out_max, out_min):
    y = y_state[0]
    for j in range(start, series.shape[0]):
        v = m[j - start]
        if not abs(v) <= real_max:
            invalid[j] = True
        else:
            delta = v - y
            if delta > step_max:
                y = y + step_max
                limited[j] = True
            elif delta < step_min:
                y = y + step_min
                limited[j] = True
            else:
                y = v
        if y > out_max:
            y = out_max
            clamped[j] = True
        elif y < out_min:
            y = out_min
            clamped[j] = True
        series[j] = y
    y_state[0] = y


def limit(model_values, start: int, y_state: np.ndarray, series, limited, clamped, invalid, constants: dict, f) -> None:
    """Rows start.. of series from model_values[0..]; flags OR-ed into limited/clamped/invalid."""
    _limit(np.ascontiguousarray(model_values, f), np.int64(start), y_state, series, limited, clamped, invalid,
           f(constants["real_max"]), f(constants["step_max"]), f(constants["step_min"]),
           f(constants["out_max"]), f(constants["out_min"]))


# ---------------------------------------------------------------------------------------------
# Grey models (models/grey.py::predict_gm0n, predict_gm1n). temps: (k, rows).

@jit
def _gm0n(temps, x1, b, rises, first, started, out):
    k = temps.shape[0]
    for j in range(out.shape[0]):
        if started[0] == 0:
            for i in range(k):
                first[i] = temps[i, j]
            out[j] = x1
            started[0] = 1
            continue
        level = b[0] * (temps[0, j] - first[0] if rises else temps[0, j])
        for i in range(1, k):
            level = level + b[i] * (temps[i, j] - first[i] if rises else temps[i, j])
        out[j] = level


@jit
def _gm1n(temps, x1, keep, gain, b, rises, first, prev, started, out):
    k = temps.shape[0]
    previous = prev[0]
    for j in range(out.shape[0]):
        if started[0] == 0:
            for i in range(k):
                first[i] = temps[i, j]
            level = x1
            started[0] = 1
        elif started[0] == 1:
            forced = b[0] * (temps[0, j] - first[0] if rises else first[0] + temps[0, j])
            for i in range(1, k):
                forced = forced + b[i] * (temps[i, j] - first[i] if rises else first[i] + temps[i, j])
            level = (keep * previous + gain * forced) - x1
            started[0] = 2
        else:
            forced = b[0] * (temps[0, j] - first[0] if rises else temps[0, j])
            for i in range(1, k):
                forced = forced + b[i] * (temps[i, j] - first[i] if rises else temps[i, j])
            level = keep * previous + gain * forced
        out[j] = level
        previous = level
    prev[0] = previous


class GreyState:
    """The first call's temperatures, the previous error estimate and how many calls happened (0, 1, 2+)."""

    def __init__(self, k: int, f):
        self.first = np.zeros(k, f)
        self.prev = np.zeros(1, f)
        self.started = np.zeros(1, np.int64)


def gm0n(temps: list, x1, b: list, f, state: GreyState | None = None, rises: bool = False) -> np.ndarray:
    """GM(0,N) error estimates of `temps` (one array per sensor) by the compiled loop, bit for bit
    those of grey.predict_gm0n; `state` carries the first temperatures from chunk to chunk."""
    state = state or GreyState(len(temps), f)
    stacked = np.array(temps, f).reshape(len(temps), -1)
    out = np.empty(stacked.shape[1], f)
    _gm0n(stacked, f(x1), np.array(b, f), rises, state.first, state.started, out)
    return out


def gm1n(temps: list, x1, keep, gain, b: list, f, state: GreyState | None = None, rises: bool = False) -> np.ndarray:
    """GM(1,N) error estimates of `temps` (one array per sensor) by the compiled loop, bit for bit
    those of grey.predict_gm1n; `state` carries the first temperatures and the last estimate."""
    state = state or GreyState(len(temps), f)
    stacked = np.array(temps, f).reshape(len(temps), -1)
    out = np.empty(stacked.shape[1], f)
    _gm1n(stacked, f(x1), f(keep), f(gain), np.array(b, f), rises, state.first, state.prev, state.started, out)
    return out


# ---------------------------------------------------------------------------------------------
# Lumped-mass simulation with effects (models/lumped_model.py::predict).
# flags: gear, cool_on, stop, slow, amb, structure, feed, load, filtered (0/1); per (k,): G, G2, K,
# As, Bs, A, B, beta, gamma, delta, offset, H (standstill load), KF (filter gain); present (2, k):
# whether each sensor has an offset, a filter gain; sc: Gear_rpm, Stop_rpm, AS, BS, A2, B2, AAm,
# BAm, AF, BF, beta0, alpha, phi, CoolOn, CoolOff (absent ones 0; never used then);
# table: (segments, 3) node, heat, slope.

@jit
def _lumped(temps, te, n, feed, flags, per, present, sc, table, relay, zero, sim, ll, mm, t0, carried, status, out):
    k = temps.shape[0]
    gear, cool_on, stop, slow, amb, structure, with_feed, load = (flags[0], flags[1], flags[2], flags[3], flags[4],
                                                                   flags[5], flags[6], flags[7])
    filtered = flags[8]
    la = carried[0]
    te0 = carried[1]
    lf = carried[2]
    cool = status[1] != 0
    segs = table.shape[0]
    for j in range(out.shape[0]):
        if status[0] == 0:
            for i in range(k):
                if present[0, i]:
                    sim[i] = temps[i, j] - per[10, i]
                else:
                    sim[i] = temps[i, j]
                ll[i] = sim[i]
                mm[i] = sim[i]
                t0[i] = sim[i]
            la = te[j]
            te0 = te[j]
            lf = zero
            status[0] = 1
        s = n[j]
        if segs > 0:
            index = 0
            for m in range(segs - 1, 0, -1):
                if n[j] >= table[m, 0]:
                    index = m
                    break
            s = table[index, 1] + (n[j] - table[index, 0]) * table[index, 2]
        for i in range(k):
            q = per[0, i] * s
            if load:
                q = q + per[11, i]
            if gear and n[j] > sc[0]:
                q = q + per[1, i] * n[j]
            if cool_on and cool:
                q = q + per[2, i]
            if stop and n[j] <= sc[1]:
                sim[i] = per[3, i] * sim[i] + per[4, i] * (q + te[j])
            else:
                sim[i] = per[5, i] * sim[i] + per[6, i] * (q + te[j])
            if filtered and present[1, i]:
                sim[i] = sim[i] + per[12, i] * (temps[i, j] - sim[i])
            if structure:
                ll[i] = sc[2] * ll[i] + sc[3] * sim[i]
            if slow:
                if structure:
                    mm[i] = sc[4] * mm[i] + sc[5] * ll[i]
                else:
                    mm[i] = sc[4] * mm[i] + sc[5] * sim[i]
        if amb:
            la = sc[6] * la + sc[7] * te[j]
        if with_feed:
            lf = sc[8] * lf + sc[9] * feed[j]
        e = sc[10]
        for i in range(k):
            e = e + per[7, i] * (sim[i] - t0[i])
            if structure:
                e = e + per[8, i] * (ll[i] - t0[i])
            if slow:
                e = e + per[9, i] * (mm[i] - t0[i])
        if amb:
            e = e + sc[11] * (la - te0)
        if with_feed:
            e = e + sc[12] * lf
        out[j] = e
        if cool_on:
            t_switch = sim[relay]
            if t_switch > sc[13]:
                cool = True
            elif t_switch < sc[14]:
                cool = False
    carried[0] = la
    carried[1] = te0
    carried[2] = lf
    status[1] = 1 if cool else 0


class LumpedState:
    """Simulated temperatures, structure and slow lags, their start values, the ambient and feed
    lags, the ambient at the first call; whether the first call happened and the coolant relay."""

    def __init__(self, k: int, f):
        self.sim, self.ll, self.mm, self.t0 = (np.zeros(k, f) for _ in range(4))
        self.carried = np.zeros(3, f)  # LA, Te0, LF
        self.status = np.zeros(2, np.int64)  # started, cool


LUMPED_PER_SENSOR = ("G", "G2", "K", "As", "Bs", "A", "B", "beta", "gamma", "delta", "O", "H", "KF")
LUMPED_SCALARS = ("Gear_rpm", "Stop_rpm", "AS", "BS", "A2", "B2", "AAm", "BAm", "AF", "BF", "beta0", "alpha", "phi",
                  "CoolOn", "CoolOff")


def lumped(temps: list, te, n, feed, flags: tuple, coef: dict, table: list, relay: int, f,
           state: LumpedState | None = None) -> np.ndarray:
    """coef: name -> value of dtype f (absent coefficients are not in it)."""
    k = len(temps)
    state = state or LumpedState(k, f)
    per = np.zeros((len(LUMPED_PER_SENSOR), k), f)
    for r, name in enumerate(LUMPED_PER_SENSOR):
        for i in range(k):
            per[r, i] = coef.get(f"{name}_{i + 1}", f(0))
    present = np.array([[f"{stem}_{i + 1}" in coef for i in range(k)] for stem in ("O", "KF")], np.bool_)
    sc = np.array([coef.get(name, f(0)) for name in LUMPED_SCALARS], f)
    rows = len(te)
    stacked = np.empty((k, rows), f)
    for i, x in enumerate(temps):
        stacked[i] = x
    table_array = np.array(table, f).reshape(len(table), 3)
    out = np.empty(rows, f)
    _lumped(stacked, np.ascontiguousarray(te, f), np.ascontiguousarray(n, f),
            np.ascontiguousarray(feed if feed is not None else te, f), np.array(flags, np.bool_), per, present, sc,
            table_array, np.int64(relay), f(0), state.sim, state.ll, state.mm, state.t0, state.carried, state.status,
            out)
    return out
