"""The `lumped` kind's float32/float64 reference loop, the one source of its arithmetic: models/kinds/lumped_model.py's
docstring gives the per-call order. numba compiles it, or it runs as Python on numpy scalars (base/compiled.py
decides; both give the same bits, tests/test_fast_reference.py). Its inputs are records with named fields, each
field of the precision's dtype (the rules that keep the bits in models/kernels.py)."""
from __future__ import annotations

from collections import namedtuple

import numpy as np

from thermoplc.base import compiled

GEAR_FLOOR_RPM = float(np.float32(1e-3))  # a lagged gear speed below this is 0: a long stop would make it subnormal
COOL_FLOOR = float(np.float32(1e-6))  # a lagged coolant share below this is 0: a long time off would make it subnormal

# Which parts the model has: its effects (gear, cool_on, stop, slow, amb, feed, gear_lag, cool_lag), the structure lag,
# the standstill load H_i and the filter gains KF_i.
Flags = namedtuple("Flags", "gear cool_on stop slow amb structure feed load filtered gear_lag cool_lag")
PER_SENSOR = ("G", "G2", "K", "As", "Bs", "A", "B", "beta", "gamma", "delta", "O", "H", "KF")
# One array per coefficient stem, element i for sensor i + 1 (0 where the file has none), and whether each sensor
# has an offset and a filter gain.
PerSensor = namedtuple("PerSensor", PER_SENSOR)
Present = namedtuple("Present", "offset filter_gain")
SCALARS = ("Gear_rpm", "Stop_rpm", "AS", "BS", "A2", "B2", "AAm", "BAm", "AF", "BF", "beta0", "alpha", "phi",
           "CoolOn", "CoolOff", "AGr", "BGr", "ACl", "BCl")
Scalars = namedtuple("Scalars", SCALARS + ("gear_floor", "cool_floor"))  # absent coefficients 0 (never used then)
SpeedTable = namedtuple("SpeedTable", "node heat slope")  # nonlinear_speed_heat's n^p table, one row per segment

LA, TE0, LF, LG, LC = range(5)  # the carried lags: ambient, the ambient at the first call, feed, gear, coolant
STARTED, COOL = range(2)  # whether the first call happened; the relay


@compiled.jit
def _lumped(temps, te, n, feed, flags, per, present, sc, table, relay, zero, sim, ll, mm, t0, carried, status, out):
    k = temps.shape[0]
    la, te0, lf, lg, lc = carried[LA], carried[TE0], carried[LF], carried[LG], carried[LC]
    cool = status[COOL] != 0
    segs = table.node.shape[0]
    for j in range(out.shape[0]):
        if status[STARTED] == 0:
            for i in range(k):
                if present.offset[i]:
                    sim[i] = temps[i, j] - per.O[i]
                else:
                    sim[i] = temps[i, j]
                ll[i] = sim[i]
                mm[i] = sim[i]
                t0[i] = sim[i]
            la = te[j]
            te0 = te[j]
            lf = zero
            lg = zero
            lc = zero
            status[STARTED] = 1
        s = n[j]
        if segs > 0:
            index = 0
            for m in range(segs - 1, 0, -1):
                if n[j] >= table.node[m]:
                    index = m
                    break
            s = table.heat[index] + (n[j] - table.node[index]) * table.slope[index]
        if flags.gear_lag:
            lg = sc.AGr * lg + sc.BGr * n[j] if n[j] > sc.Gear_rpm else sc.AGr * lg
            if abs(lg) < sc.gear_floor:
                lg = zero
        if flags.cool_lag:
            lc = sc.ACl * lc + sc.BCl if cool else sc.ACl * lc
            if lc < sc.cool_floor:
                lc = zero
        for i in range(k):
            q = per.G[i] * s
            if flags.load:
                q = q + per.H[i]
            if flags.gear_lag:
                q = q + per.G2[i] * lg
            elif flags.gear and n[j] > sc.Gear_rpm:
                q = q + per.G2[i] * n[j]
            if flags.cool_lag:
                q = q + per.K[i] * lc
            elif flags.cool_on and cool:
                q = q + per.K[i]
            if flags.stop and n[j] <= sc.Stop_rpm:
                sim[i] = per.As[i] * sim[i] + per.Bs[i] * (q + te[j])
            else:
                sim[i] = per.A[i] * sim[i] + per.B[i] * (q + te[j])
            if flags.filtered and present.filter_gain[i]:
                sim[i] = sim[i] + per.KF[i] * (temps[i, j] - sim[i])
            if flags.structure:
                ll[i] = sc.AS * ll[i] + sc.BS * sim[i]
            if flags.slow:
                if flags.structure:
                    mm[i] = sc.A2 * mm[i] + sc.B2 * ll[i]
                else:
                    mm[i] = sc.A2 * mm[i] + sc.B2 * sim[i]
        if flags.amb:
            la = sc.AAm * la + sc.BAm * te[j]
        if flags.feed:
            lf = sc.AF * lf + sc.BF * feed[j]
        e = sc.beta0
        for i in range(k):
            e = e + per.beta[i] * (sim[i] - t0[i])
            if flags.structure:
                e = e + per.gamma[i] * (ll[i] - t0[i])
            if flags.slow:
                e = e + per.delta[i] * (mm[i] - t0[i])
        if flags.amb:
            e = e + sc.alpha * (la - te0)
        if flags.feed:
            e = e + sc.phi * lf
        out[j] = e
        if flags.cool_on:
            t_switch = sim[relay]
            if t_switch > sc.CoolOn:
                cool = True
            elif t_switch < sc.CoolOff:
                cool = False
    carried[LA], carried[TE0], carried[LF], carried[LG], carried[LC] = la, te0, lf, lg, lc
    status[COOL] = 1 if cool else 0


class LumpedState:
    """Simulated temperatures, structure and slow lags, their start values, the carried lags (LA .. LC); whether the
    first call happened and the coolant relay (STARTED, COOL)."""

    def __init__(self, k: int, f):
        self.sim, self.ll, self.mm, self.t0 = (np.zeros(k, f) for _ in range(4))
        self.carried = np.zeros(5, f)
        self.status = np.zeros(2, np.int64)


def lumped_loop(temps: list, te, n, feed, flags: Flags, coef: dict, table: list, relay: int, f,
                state: LumpedState | None = None) -> np.ndarray:
    """The reference for these calls from `state` (a new one: the first call). coef: name -> value of dtype f (absent
    coefficients are not in it); table: (node, heat, slope) per segment."""
    k, rows = len(temps), len(te)
    state = state or LumpedState(k, f)
    per = PerSensor(*(np.array([coef.get(f"{stem}_{i + 1}", f(0)) for i in range(k)], f) for stem in PER_SENSOR))
    present = Present(*(np.array([f"{stem}_{i + 1}" in coef for i in range(k)], np.bool_) for stem in ("O", "KF")))
    sc = Scalars(*(coef.get(name, f(0)) for name in SCALARS), f(GEAR_FLOOR_RPM), f(COOL_FLOOR))
    stacked = np.empty((k, rows), f)
    for i, x in enumerate(temps):
        stacked[i] = x
    columns = np.array(table, f).reshape(len(table), 3).T
    out = np.empty(rows, f)
    compiled.route(_lumped, rows)(
        stacked, np.ascontiguousarray(te, f), np.ascontiguousarray(n, f),
        np.ascontiguousarray(feed if feed is not None else te, f), Flags(*(bool(x) for x in flags)), per, present, sc,
        SpeedTable(*(np.ascontiguousarray(c) for c in columns)), np.int64(relay), f(0), state.sim, state.ll, state.mm,
        state.t0, state.carried, state.status, out)
    return out
