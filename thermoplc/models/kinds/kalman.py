"""Kalman fusion of a lumped-mass thermal model with measured temperatures (paper 000).

Per sensor i, every call (the first call starts from TF = T_measured, PF = P0):
    TP = A*TF + B*Te + C*n + D          lumped-mass prediction (eq. 4-5)
    PP = AA*PF + N                       (eq. 6; AA = A*A folded in binary32)
    fault set when |T - T_previous| > Jmp (a sudden jump, paper §5), cleared when |T - TP| <= Agr
    fault:  TF = TP, PF = PP             (gain 0: model-only prediction)
    else:   K = PP/(PP+R); TF = TP + K*(T - TP); PF = PP - K*PP      (eq. 7-9)
then E = beta0 + sum_i beta_i*(TF_i - T0_i) with T0_i the measured temperature at the first call (eq. 10).
"""
from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass, fields
from typing import Callable

import numpy as np

from thermoplc.base.binary32 import round_f32
from thermoplc.base import compiled
from thermoplc.physics import lumped
from thermoplc.models.ga import GA_OPTIONS, genetic_minimize, step_reporter
from thermoplc.models.kinds.mlr import least_squares
from thermoplc.models.kind import Kind, KindOption, Part, fault_key, measured_counts
from thermoplc.models.model import Coefficient, Model


def differential_evolution(*args, **kwargs):  # scipy on first use: verify never fits, and importing it costs ~1 s
    from scipy.optimize import differential_evolution as function
    return function(*args, **kwargs)


SENSOR_COEFFICIENTS = ("A", "AA", "B", "C", "D", "N", "R", "P0", "Jmp", "Agr")
Sensors = namedtuple("Sensors", SENSOR_COEFFICIENTS)  # each a coefficient of every sensor, element i for sensor i+1


@dataclass(frozen=True)
class FitOptions:
    optimizer: str = "ga"  # 'ga' (paper 000) or 'de' (scipy differential evolution)
    seed: int = 0
    population: int = 40
    generations: int = 60
    jump_limit: float | None = None  # K; default from the training data
    recover_limit: float | None = None


def predict(model: Model, inputs: dict, precision: str, valid: dict | None = None) -> dict:
    """Reference in binary32 ('f32') or float64 ('f64'), in the block's order: `_kalman` below.

    valid maps a temperature input to a per-call flag 'reading in range'; a reading out of range
    marks the sensor faulty without touching the jump memory (the block's input guard decides it).
    """
    f = np.float32 if precision == "f32" else np.float64
    temps = model.signals("temperature")
    n = np.asarray(inputs[model.signals("speed")[0].name], f)
    rows = len(n)
    in_range = [np.ones(rows, bool) if valid is None or s.name not in valid else np.asarray(valid[s.name], bool)
                for s in temps]
    error, faults = kalman_loop(inputs[model.signals("ambient")[0].name], n,
                                [np.asarray(inputs[s.name], f) for s in temps], in_range,
                                *kernel_coefficients(model, precision), f)
    return {model.target.name: error, **{fault_key(s.name): faults[i] for i, s in enumerate(temps)}}


def kernel_coefficients(model: Model, precision: str) -> tuple:
    """(sensors, betas, beta0) for kalman_loop: each of SENSOR_COEFFICIENTS by name, element i for sensor i+1 (a
    missing one: UserError naming it)."""
    f = np.float32 if precision == "f32" else np.float64
    k = len(model.signals("temperature"))
    sensors = Sensors(*(np.array([model.coef(f"{c}_{i}", precision) for i in range(1, k + 1)], f)
                        for c in SENSOR_COEFFICIENTS))
    betas = np.array([model.coef(f"beta_{i}", precision) for i in range(1, k + 1)], f)
    return sensors, betas, f(model.coef("beta0", precision))


def _rms(residual: np.ndarray) -> np.ndarray:
    """Eq. 12-13: root mean square with n-1 in the denominator, along the last axis."""
    return np.sqrt(np.sum(residual ** 2, axis=-1) / max(residual.shape[-1] - 1, 1))


def _minimize(objective, lower, upper, options: FitOptions, rng, progress):
    if options.optimizer == "de":
        result = differential_evolution(
            lambda x: objective(np.atleast_2d(x.T)), list(zip(lower, upper)), seed=options.seed,
            maxiter=options.generations, popsize=max(1, options.population // len(lower)), polish=False,
            vectorized=True, updating="deferred", tol=1e-10,
            callback=(lambda intermediate_result: progress(0, float(intermediate_result.fun))) if progress else None)
        return result.x, float(result.fun), (float(result.fun),), int(result.nfev)
    result = genetic_minimize(objective, lower, upper, rng, options.population, options.generations, progress=progress)
    return result.x, result.cost, result.history, result.evaluations


def _lumped_mass(parts: list[Part], i: int, dt: float, name: str, options: FitOptions, rng, reporter,
                 log: dict) -> tuple[float, float, float]:
    """GA step 1 (eq. 12) for sensor i: its time constant (s), speed gain (K/rpm) and standstill rise (K)
    fitted open loop to its readings, each run simulated from its own first reading; the step's entry
    goes into `log`."""
    readings = [p.temps[:, i] for p in parts]
    n_max = max(max(float(np.max(np.abs(p.speed))) for p in parts), 1.0)
    span = max(float(np.ptp(np.concatenate(readings))), 0.1)
    rest = np.concatenate([tm - p.ambient for tm, p in zip(readings, parts)])
    lower = np.array([np.log10(2 * dt), -3 * span / n_max, float(rest.min()) - span])
    upper = np.array([np.log10(48 * 3600.0), 3 * span / n_max, float(rest.max()) + span])

    def f1(pop):
        a, b, c, d = lumped.discrete(10 ** pop[:, 0], pop[:, 1], pop[:, 2], dt)
        return _rms(np.concatenate([lumped.open_loop(a, b, c, d, p.ambient, p.speed, tm[0]) - tm
                                    for tm, p in zip(readings, parts)], axis=-1))

    x, cost, history, evals = _minimize(f1, lower, upper, options, rng, reporter(f"{name} lumped-mass"))
    log["steps"].append({"step": f"lumped-mass {name} (eq. 12)", "rms_K": cost, "evaluations": evals,
                         "history": list(history)})
    return 10 ** x[0], x[1], x[2]


def _sensor_values(name: str, params: tuple, discrete: tuple, noise: tuple, runs: list[tuple[np.ndarray, ...]],
                   options: FitOptions) -> tuple[dict[str, Coefficient], dict]:
    """One sensor's block coefficients (A, AA, B, C, D, N, R, P0, Jmp, Agr) and its settings entry; the
    jump and recover limits, unless given, from the 99.9 % quantile of its steps and innovations over the
    runs (measured, fused and forcing per run)."""
    tau, g_n, g_0 = params
    a, b, c, d = (float(v[0]) for v in discrete)
    noise_n, noise_r = noise
    innovation = np.concatenate([np.abs(measured[1:] - (a * fused[:-1] + forcing[1:]))
                                 for measured, fused, forcing in runs])
    jump = options.jump_limit
    if jump is None:
        steps = np.concatenate([np.abs(np.diff(measured)) for measured, _, _ in runs])
        jump = max(1.0, 3 * float(np.quantile(steps, 0.999)))
    recover = options.recover_limit
    if recover is None:
        recover = max(0.5, 3 * float(np.quantile(innovation, 0.999)))
    coef_a = Coefficient.of(a)
    values = {"A": coef_a, "AA": Coefficient(a * a, round_f32(coef_a.f32 * coef_a.f32)),
              "B": Coefficient.of(b), "C": Coefficient.of(c), "D": Coefficient.of(d),
              "N": Coefficient.of(noise_n), "R": Coefficient.of(noise_r), "P0": Coefficient.of(noise_r),
              "Jmp": Coefficient.of(jump), "Agr": Coefficient.of(recover)}
    described = {"name": name, "tau_s": tau, "gain_K_per_rpm": g_n, "standstill_K": g_0,
                 "v1_per_s": 1 / tau, "v_speed_K_per_s_rpm": g_n / tau, "v0_K_per_s": g_0 / tau,
                 "process_noise_N": noise_n, "measurement_noise_R": noise_r,
                 "jump_limit_K": jump, "recover_limit_K": recover}
    return values, described


def fit_kalman(parts: list[Part], dt: float, names: list[str], options: FitOptions,
               progress: Callable[[str], None] | None = None) -> tuple[dict[str, Coefficient], dict, dict]:
    """Fit on the runs' training rows: GA step 1 per sensor (eq. 12), GA step 2 for N, R (eq. 13), then
    eq. 11 on the measured rows; every run is simulated and filtered from its own first row.

    Returns coefficients, human-readable settings and a fit log.
    """
    rng = np.random.default_rng(options.seed)
    k = parts[0].temps.shape[1]
    log = {"optimizer": options.optimizer, "seed": options.seed, "population": options.population,
           "generations": options.generations, "steps": []}
    reporter = lambda step: step_reporter(step, options.generations, progress)
    lumped_params = [_lumped_mass(parts, i, dt, names[i], options, rng, reporter, log) for i in range(k)]

    discrete = [lumped.discrete(np.array([tau]), np.array([g_n]), np.array([g_0]), dt)
                for tau, g_n, g_0 in lumped_params]
    forcing = [[d[1][0] * p.ambient + d[2][0] * p.speed + d[3][0] for d in discrete] for p in parts]
    measured = [p.measured for p in parts]
    target = np.concatenate([p.target[m] for p, m in zip(parts, measured)])

    def fused_all(pop):
        """Per run, per sensor: the filtered temperatures of every individual."""
        noise_n, noise_r = 10 ** pop[:, 0::2], 10 ** pop[:, 1::2]
        return [[lumped.fused(discrete[i][0][0], forcing[r][i], p.temps[:, i], noise_n[:, i], noise_r[:, i],
                              noise_r[:, i]) for i in range(k)] for r, p in enumerate(parts)]

    def rises(series, individual: int) -> np.ndarray:
        """The map's columns: each run's filtered rises on its measured rows, stacked."""
        return np.vstack([np.column_stack([s[individual] - p.temps[0, i] for i, s in enumerate(run)])[m]
                          for run, p, m in zip(series, parts, measured)])

    def f2(pop):
        series = fused_all(pop)
        cost = np.empty(len(pop))
        for p in range(len(pop)):
            design = np.column_stack([np.ones(len(target)), rises(series, p)])
            beta = np.linalg.lstsq(design, target, rcond=None)[0]
            cost[p] = _rms(target - design @ beta)
        return cost

    lower = np.tile([-8.0, -5.0], k)
    upper = np.tile([1.0, 2.0], k)
    x, cost, history, evals = _minimize(f2, lower, upper, options, rng, reporter("Kalman covariances N, R"))
    log["steps"].append({"step": "Kalman covariances (eq. 13)", "rms_um": cost, "evaluations": evals,
                         "history": list(history)})
    series = fused_all(x[None, :])
    beta, map_log = least_squares(rises(series, 0), target, names, measured_counts(parts))
    log.update(map_log)

    coefficients: dict[str, Coefficient] = {}
    settings = {"sensors": []}
    for i in range(k):
        noise = (10 ** x[2 * i], 10 ** x[2 * i + 1])
        runs = [(p.temps[:, i], run[i][0], forcing[r][i]) for r, (p, run) in enumerate(zip(parts, series))]
        values, described = _sensor_values(names[i], lumped_params[i], discrete[i], noise, runs, options)
        coefficients.update({f"{name}_{i + 1}": values[name] for name in SENSOR_COEFFICIENTS})
        settings["sensors"].append(described)
    coefficients["beta0"] = Coefficient.of(beta[0])
    for i in range(k):
        coefficients[f"beta_{i + 1}"] = Coefficient.of(beta[i + 1])
    return coefficients, settings, log


def _fit(parts, request, names, dt, progress):
    options = FitOptions(**{field.name: request.option(field.name) for field in fields(FitOptions)})
    return fit_kalman(parts, dt, names, options, progress)


OPTIONS = (
    KindOption("optimizer", "--optimizer", "ga", "ga: paper 000's genetic algorithm; de: scipy differential evolution",
               choices=("ga", "de")),
    *GA_OPTIONS,
    KindOption("jump_limit", "--jump-limit", None, "K per call that marks a sensor faulty (default from data)",
               number=(float, 1e-6, 1e3, "kelvin")),
    KindOption("recover_limit", "--recover-limit", None, "K between measurement and model to recover (default from "
               "data)", number=(float, 1e-6, 1e3, "kelvin")),
)


class StreamCore:
    """predict, with the filter's state (KalmanState) kept between chunks."""

    def __init__(self, model: Model, precision: str, f):
        self.f = f
        self.temps = model.signals("temperature")
        self.ambient = model.signals("ambient")[0].name
        self.speed = model.signals("speed")[0].name
        self.args = kernel_coefficients(model, precision)
        self.state = KalmanState(len(self.temps), f)
        self.target = model.target.name

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        rows = len(running[self.ambient])
        in_range = [np.asarray(fused_valid[s.name], bool) if s.name in fused_valid else np.ones(rows, bool)
                    for s in self.temps]
        error, faults = kalman_loop(running[self.ambient], running[self.speed],
                                       [np.asarray(running[s.name], self.f) for s in self.temps], in_range,
                                       *self.args, self.f, self.state)
        out = {self.target: error}
        out.update({fault_key(s.name): faults[i] for i, s in enumerate(self.temps)})
        return out


# The reference's one loop, compiled or run as Python (base/compiled.py; the rules that keep its bits in
# models/kernels.py). state: tf, pf, t0, tm_prev (float, per sensor); fault (bool, per sensor); started[0] (int).

@compiled.jit
def _kalman(te, n, measured, in_range, sensors, betas, beta0, tf, pf, t0, tm_prev, fault, started, error, faults):
    k = measured.shape[0]
    rows = te.shape[0]
    s = sensors
    for j in range(rows):
        if started[0] == 0:
            for i in range(k):
                tf[i] = measured[i, j]
                t0[i] = measured[i, j]
                tm_prev[i] = measured[i, j]
                pf[i] = s.P0[i]
                fault[i] = False
            started[0] = 1
        for i in range(k):
            tm = measured[i, j]
            tp = s.A[i] * tf[i] + s.B[i] * te[j] + s.C[i] * n[j] + s.D[i]
            pp = s.AA[i] * pf[i] + s.N[i]
            if not in_range[i, j]:
                fault[i] = True
                tf[i] = tp
                pf[i] = pp
                faults[i, j] = True
                continue
            jump = abs(tm - tm_prev[i])
            tm_prev[i] = tm
            if not jump <= s.Jmp[i]:
                fault[i] = True
            elif abs(tm - tp) <= s.Agr[i]:
                fault[i] = False
            if fault[i]:
                tf[i] = tp
                pf[i] = pp
            else:
                gain = pp / (pp + s.R[i])
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


def kalman_loop(te, n, measured: list, in_range: list, sensors: Sensors, betas: np.ndarray, beta0, f,
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
    compiled.route(_kalman, rows)(
        np.ascontiguousarray(te, f), np.ascontiguousarray(n, f), stacked, ranges,
        Sensors(*(np.ascontiguousarray(x, f) for x in sensors)), np.ascontiguousarray(betas, f), f(beta0), state.tf,
        state.pf, state.t0, state.tm_prev, state.fault, state.started, error, faults)
    return error, faults


KIND = Kind("kalman", 2, "000", _fit, predict, roles=("speed", "ambient"), fused_guards=True, ambient_apart=True,
            options=OPTIONS,
            auto="iterative", settings_schema={"type": "object", "properties": {"sensors": {"type": "array"}}},
            stream_core=StreamCore)
