"""The `lumped` kind's loop compiled: models/lumped_model.py::predict's arithmetic in the same order, over
positional arrays numba can take (base/compiled.py; the rules that keep its bits in models/kernels.py)."""
from __future__ import annotations

import numpy as np

from thermoplc.base import compiled

GEAR_FLOOR_RPM = float(np.float32(1e-3))  # a lagged gear speed below this is 0: a long stop would make it subnormal
COOL_FLOOR = float(np.float32(1e-6))  # a lagged coolant share below this is 0: a long time off would make it subnormal


# flags: gear, cool_on, stop, slow, amb, structure, feed, load, filtered, gear_lag, cool_lag (0/1); per (k,): G, G2, K,
# As, Bs, A, B, beta, gamma, delta, offset, H (standstill load), KF (filter gain); present (2, k):
# whether each sensor has an offset, a filter gain; sc: Gear_rpm, Stop_rpm, AS, BS, A2, B2, AAm,
# BAm, AF, BF, beta0, alpha, phi, CoolOn, CoolOff, AGr, BGr, ACl, BCl, the gear floor, the coolant floor (absent
# ones 0; never used then);
# table: (segments, 3) node, heat, slope.

@compiled.jit
def _lumped(temps, te, n, feed, flags, per, present, sc, table, relay, zero, sim, ll, mm, t0, carried, status, out):
    k = temps.shape[0]
    gear, cool_on, stop, slow, amb, structure, with_feed, load = (flags[0], flags[1], flags[2], flags[3], flags[4],
                                                                   flags[5], flags[6], flags[7])
    filtered = flags[8]
    gear_lag = flags[9]
    cool_lag = flags[10]
    la = carried[0]
    te0 = carried[1]
    lf = carried[2]
    lg = carried[3]
    lc = carried[4]
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
            lg = zero
            lc = zero
            status[0] = 1
        s = n[j]
        if segs > 0:
            index = 0
            for m in range(segs - 1, 0, -1):
                if n[j] >= table[m, 0]:
                    index = m
                    break
            s = table[index, 1] + (n[j] - table[index, 0]) * table[index, 2]
        if gear_lag:
            lg = sc[15] * lg + sc[16] * n[j] if n[j] > sc[0] else sc[15] * lg
            if abs(lg) < sc[19]:
                lg = zero
        if cool_lag:
            lc = sc[17] * lc + sc[18] if cool else sc[17] * lc
            if lc < sc[20]:
                lc = zero
        for i in range(k):
            q = per[0, i] * s
            if load:
                q = q + per[11, i]
            if gear_lag:
                q = q + per[1, i] * lg
            elif gear and n[j] > sc[0]:
                q = q + per[1, i] * n[j]
            if cool_lag:
                q = q + per[2, i] * lc
            elif cool_on and cool:
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
    carried[3] = lg
    carried[4] = lc
    status[1] = 1 if cool else 0


class LumpedState:
    """Simulated temperatures, structure and slow lags, their start values, the ambient, feed, gear and
    coolant lags, the ambient at the first call; whether the first call happened and the coolant relay."""

    def __init__(self, k: int, f):
        self.sim, self.ll, self.mm, self.t0 = (np.zeros(k, f) for _ in range(4))
        self.carried = np.zeros(5, f)  # LA, Te0, LF, LG, LC
        self.status = np.zeros(2, np.int64)  # started, cool


LUMPED_PER_SENSOR = ("G", "G2", "K", "As", "Bs", "A", "B", "beta", "gamma", "delta", "O", "H", "KF")
LUMPED_SCALARS = ("Gear_rpm", "Stop_rpm", "AS", "BS", "A2", "B2", "AAm", "BAm", "AF", "BF", "beta0", "alpha", "phi",
                  "CoolOn", "CoolOff", "AGr", "BGr", "ACl", "BCl")


def lumped_loop(temps: list, te, n, feed, flags: tuple, coef: dict, table: list, relay: int, f,
                state: LumpedState | None = None) -> np.ndarray:
    """coef: name -> value of dtype f (absent coefficients are not in it)."""
    k = len(temps)
    state = state or LumpedState(k, f)
    per = np.zeros((len(LUMPED_PER_SENSOR), k), f)
    for r, name in enumerate(LUMPED_PER_SENSOR):
        for i in range(k):
            per[r, i] = coef.get(f"{name}_{i + 1}", f(0))
    present = np.array([[f"{stem}_{i + 1}" in coef for i in range(k)] for stem in ("O", "KF")], np.bool_)
    sc = np.array([coef.get(name, f(0)) for name in LUMPED_SCALARS] + [f(GEAR_FLOOR_RPM), f(COOL_FLOOR)], f)
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
