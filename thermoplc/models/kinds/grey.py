"""Grey models GM(0,N) and GM(1,N) on first-order accumulated (1-AGO) sequences (paper 003).

With S_i(k) = x_i(1) + ... + x_i(k) the running sums of the temperatures:
- GM(0,N): X1(k) = a + sum_i b_i*S_i(k); the error estimate is X1(k) - X1(k-1) = sum_i b_i*x_i(k),
  and x1(1) (the error at the first sample of the fit) at the first call, where X1(0) is not defined.
- GM(1,N): the grey difference equation the parameters are estimated from,
  x1(k) + a*z1(k) = sum_i b_i*S_i(k) with the background value z1(k) = (X1(k) + X1(k-1))/2,
  run forward: X1(k) = Keep*X1(k-1) + In*sum_i b_i*S_i(k), Keep = (1 - a/2)/(1 + a/2),
  In = 1/(1 + a/2), and the error estimate x1(k) = X1(k) - X1(k-1); x1(1) at the first call.
  The block (and the reference) compute both without running sums, which in binary32 move the output
  by um over two days and grow without bound on a PLC that runs for weeks: GM(0,N) as sum_i b_i*x_i(k),
  GM(1,N) differenced once, x1(k) = Keep*x1(k-1) + In*sum_i b_i*x_i(k) (exact from the third call; the
  second is the equation's own start), a first-order filter whose state stays bounded.
  The paper estimates a with the b_i by least squares, and that is the model whenever its time
  constant dt/a is positive and within the training span. On real recordings it often is not:
  a <= 0 (FL_THERMAL ch3: -9.4e-5), where the recursion never settles, or a time constant of 73 h
  fitted on 24 h (ch5), which extrapolates (38 um held out against 24 um with no compensation).
  Then a is chosen with a ridge weight for the b_i by forward validation among time constants from
  two samples to the training span, instead of refusing.
  (The whitened time response, which treats sum_i b_i*S_i as constant, does not fit even the
  training data when the sums grow and a is small; this recursion needs no exp either.)
GM(1,1), the paper's baseline, is GM(1,N) without temperatures (a time trend only).
On a campaign (two runs or more) a unit sequence x_0 = 1 drives the model beside the temperatures, as GM(1,1)'s
grey input b: its coefficient b_0 is the model's offset, which the block adds first (b_0 + sum_i b_i*x_i(k); at
GM(1,N)'s second call 2*b_0, the unit's running sum). Without it the grey kinds had no intercept where the ridge
floor has one: on FL_THERMAL's 6 h runs (every sensor) GM(0,N) was 1.19-1.63 x the floor, with it 0.99-1.07 x.
"""
from __future__ import annotations

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.base import ridge
from thermoplc.base import compiled
from thermoplc.models import grey_campaign
from thermoplc.models.kind import Kind, Part
from thermoplc.models.model import Coefficient, Model

DEVELOPMENT_GRID = 16  # candidate development coefficients a, log-spaced in time constant


def accumulate(x: np.ndarray) -> np.ndarray:
    """The 1-AGO running sums S(k) = x(1) + ... + x(k), down each column (rows are samples)."""
    return np.cumsum(x, axis=0)


def sequences(part: Part, rises: bool, constant: bool = False) -> np.ndarray:
    """A run's driving sequences x_i: the temperatures' readings (the paper's), or their rises since the run's
    start; with `constant` a unit sequence x_0 = 1 first (a grey input, as GM(1,1)'s b: the model's offset)."""
    x = part.rises if rises else part.temps
    return np.column_stack([np.ones(len(x)), x]) if constant else x


def _split(constant: bool, b: np.ndarray) -> dict:
    """The coefficients b_0 (with the unit sequence) and b_1..b_N of the temperatures."""
    first = 0 if constant else 1
    return {f"b_{i}": Coefficient.of(bi) for i, bi in enumerate(b, start=first)}


def _gm1n_slopes_path(runs: list[tuple[np.ndarray, np.ndarray]], a: float, weights) -> list[np.ndarray]:
    """_gm1n_slopes for every weight from one SVD of the standardised sums (the validation tries 14 weights
    for each of 16 a: one factorisation per a instead of one least-squares solve per pair)."""
    design = np.vstack([sums[1:] for sums, _ in runs])
    y = np.concatenate([target[1:] + a * _background(target) for _, target in runs])
    spread = np.sqrt(np.mean(design ** 2, axis=0))
    spread[spread == 0.0] = 1.0
    u, singular, vt = np.linalg.svd(design / spread, full_matrices=False)
    projected = u.T @ y
    kept = singular > np.finfo(float).eps * max(design.shape) * singular[0]  # lstsq's default cut-off
    path = []
    for weight in weights:
        shrink = np.where(kept, singular / (singular ** 2 + weight * len(y)), 0.0) if weight else \
            np.where(kept, 1.0 / np.where(kept, singular, 1.0), 0.0)
        path.append((vt.T @ (shrink * projected)) / spread)
    return path


def fit_gm0n(parts: list[Part], names: list[str], rises: bool = False):
    """X1(k) = a + sum_i b_i*S_i(k) on k = 2..n of every run by least squares (paper 003), each run's sums
    from its own first row. On one recording, shrinking the b_i by a forward-validated ridge made the held-out
    error worse (FL_THERMAL ch3 7.1 -> 10.2 um, and on the twin), so only sums too collinear for binary32 get it.
    On a campaign the estimate is chosen leaving out each run (models/grey_campaign.py). A probed target is
    filled between its measurements for the running sums (`Part.filled_target`); the validation scores the
    measured rows only."""
    targets = [p.filled_target() for p in parts]
    constant = len(parts) >= 2
    sums = [accumulate(sequences(p, rises, constant))[1:] for p in parts]
    target_sums = [accumulate(t)[1:] for t in targets]
    steps = [sequences(p, rises, constant)[1:] for p in parts]
    errors = [p.target[1:] for p in parts]
    if constant:
        ridge.refuse_flat(np.vstack(sums), ["the unit sequence", *names])
        estimate, weight, rmse = grey_campaign.gm0n(sums, target_sums, steps, errors)
        if estimate == "sums":
            offset, slopes = ridge.ridge(np.vstack(sums), np.concatenate(target_sums), weight)
        else:
            measured = np.isfinite(np.concatenate(errors))
            offset, slopes = 0.0, ridge.ridge(np.vstack(steps)[measured], np.concatenate(errors)[measured], weight,
                                              intercept=False)[1]
        fitted = ridge.LinearFit(offset, slopes, weight, rmse, len(parts))
        method = (f"GM(0,N) (paper 003), {grey_campaign.label(GM0N_ESTIMATES[estimate], weight)}, chosen leaving "
                  f"out each of {len(parts)} runs")
    else:
        error, step = errors[0], steps[0]
        measured = np.isfinite(error)
        fitted = ridge.fit_linear(sums[0], target_sums[0], names, weights=(0.0,),
                                  output_error=lambda offset, b, rows: (error[rows] - step[rows] @ b)[measured[rows]])
        method = "least squares on 1-AGO sequences (paper 003, GM(0,N))"
    coefficients = {"X1": Coefficient.of(_first_error(targets)), **_split(constant, fitted.slopes)}
    settings = {"a": fitted.intercept, **({"rises": True} if rises else {})}  # a: its difference drops it
    return coefficients, settings, {"method": method, **fitted.log()}


GM0N_ESTIMATES = {"sums": "the paper's fit on the 1-AGO sums",
                  "steps": "fitted to the error itself (b_0 + sum_i b_i*x_i(k))"}
GM1N_ESTIMATES = {"paper": "the paper's least-squares a and b", "equation": "b fitted to the grey equation",
                  "output": "b fitted to the error the block outputs"}


def _first_error(targets: list[np.ndarray]) -> float:
    """x1(1), the block's output at its first call: the runs' first errors on average (one run: its own)."""
    return float(np.mean([t[0] for t in targets]))


def _background(target: np.ndarray) -> np.ndarray:
    """z1(k) = (X1(k) + X1(k-1))/2, k = 2..n."""
    target_sums = accumulate(target)
    return 0.5 * (target_sums[1:] + target_sums[:-1])


def _gm1n_parameters(runs: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    """[a, b_1..b_N] by least squares on every run's x1(k) = -a*z1(k) + sum_i b_i*S_i(k), k = 2..n."""
    design = np.vstack([np.column_stack([-_background(target), sums[1:]]) for sums, target in runs])
    return np.linalg.lstsq(design, np.concatenate([target[1:] for _, target in runs]), rcond=None)[0]


def _responses(sums: np.ndarray, first: float, a: float) -> tuple[np.ndarray, np.ndarray]:
    """The grey difference equation run forward in float64, as the block runs it, taken apart, as it is linear
    in b: each sensor's sums through the recursion, and the start's decay, so that the level after the first
    call is filtered @ b + start for any b."""
    from scipy.signal import lfilter  # on first use: verify never fits, and importing scipy costs about 1 s
    keep, gain = _keep_and_gain(a)
    filtered = lfilter([gain], [1.0, -keep], sums[1:], axis=0)
    start = lfilter([gain], [1.0, -keep], np.zeros(len(sums) - 1), zi=[keep * first])[0]
    return filtered, start


def _keep_and_gain(a: float) -> tuple[float, float]:
    """Keep = (1 - a/2)/(1 + a/2) and In = 1/(1 + a/2) of X1(k) = Keep*X1(k-1) + In*sum_i b_i*S_i(k)."""
    return (1 - a / 2) / (1 + a / 2), 1 / (1 + a / 2)


def _gm1n_slopes(runs: list[tuple[np.ndarray, np.ndarray]], a: float, weight: float) -> np.ndarray:
    """b for a given a: x1(k) + a*z1(k) = sum_i b_i*S_i(k) on every run, ridge with no intercept (the
    equation has none)."""
    design = np.vstack([sums[1:] for sums, _ in runs])
    y = np.concatenate([target[1:] + a * _background(target) for _, target in runs])
    return ridge.ridge(design, y, weight, intercept=False)[1]


def development_candidates(dt: float, rows: int) -> np.ndarray:
    """a = dt/tau for time constants from two samples to the training span (at most 48 h)."""
    longest = max(min(rows * dt, 48 * 3600.0), 4 * dt)
    return dt / np.exp(np.linspace(np.log(2 * dt), np.log(longest), DEVELOPMENT_GRID))


def fit_gm1n(parts: list[Part], names: list[str], dt: float, rises: bool = False):
    """The paper's least-squares a and b when a settles within the training span; else a working
    alternative: a among the time constants the span can show, with a ridge weight for b, both
    chosen by forward validation of what the block outputs. Every run has its own sums and its own
    start; the validation fits on the first two thirds of each run and scores the rest of each, run
    forward from its start, on the measured rows (a probed target is filled between its measurements
    for the sums, `Part.filled_target`). On a campaign, a and the weight are chosen leaving out each run
    (models/grey_campaign.py)."""
    constant = len(parts) >= 2
    runs = [(accumulate(sequences(p, rises, constant)), p.filled_target()) for p in parts]
    ridge.refuse_flat(np.vstack([sequences(p, rises) for p in parts]), names)  # a rise that never moves: no slope
    params = _gm1n_parameters(runs)
    paper_a = float(params[0])
    rows = [len(p.target) for p in parts]
    span_s = max(rows) * dt
    resolvable = ridge.condition(np.vstack([sums[1:] for sums, _ in runs]), intercept=False) <= ridge.CONDITION_LIMIT
    if len(parts) >= 2:
        a, b, weight, rmse, chosen = _gm1n_on_a_campaign(parts, runs, dt, resolvable, span_s)
    elif 0 < paper_a < 2 and dt / paper_a <= span_s and resolvable:
        a, b, weight, rmse = paper_a, params[1:], 0.0, None
        chosen = "the paper's least-squares a and b"
    else:
        cuts = [ridge.validation_cut(n) for n in rows]
        if all(cut is None for cut in cuts):
            raise UserError(f"GM(1,N) fit gives development coefficient a = {paper_a:.4g}: "
                            f"{_unsettled(paper_a, dt, resolvable)}; {max(rows)} rows are too few to choose another "
                            f"a by validation (use --model gm0n, or more rows)")
        early = [(sums[:cut or len(target)], target[:cut or len(target)]) for (sums, target), cut in zip(runs, cuts)]
        scored = []
        for candidate in development_candidates(dt, max(cut or 0 for cut in cuts)):
            responses = [_responses(sums, target[0], candidate) for sums, target in runs]  # once per a, not per weight
            path = _gm1n_slopes_path(early, candidate, ridge.WEIGHTS)
            for candidate_weight, slopes in zip(ridge.WEIGHTS, path):
                late = [(p.target - np.diff(np.r_[target[0], filtered @ slopes + start], prepend=0.0))[cut:]
                        for p, (_, target), (filtered, start), cut in zip(parts, runs, responses, cuts)
                        if cut is not None]
                residual = np.concatenate(late)
                scored.append((ridge.rms(residual[np.isfinite(residual)]), float(candidate), candidate_weight))
        rmse, a, weight = min(scored)
        b = _gm1n_slopes(runs, a, weight)
        chosen = (f"the paper's least-squares a = {paper_a:.4g} {_unsettled(paper_a, dt, resolvable)}, so a and "
                  f"a ridge weight for b were chosen by forward validation")
    keep, gain = _keep_and_gain(a)
    coefficients = {"X1": Coefficient.of(_first_error([target for _, target in runs])), "Keep": Coefficient.of(keep),
                    "In": Coefficient.of(gain), **_split(constant, b)}
    settings = {"a": a, "b": [float(x) for x in b[int(constant):]], "time_constant_s": dt / a,
                **({"rises": True} if rises else {})}
    return coefficients, settings, {
        "method": f"grey difference equation on 1-AGO sequences (paper 003, GM(1,N)), {chosen}",
        "least_squares_a": paper_a, "ridge_weight": weight, "ridge_validation_rmse": rmse}


def _output_pieces(sums: np.ndarray, first: float, a: float) -> tuple[np.ndarray, np.ndarray]:
    """The block's output after its first call as design @ b + offset, for a given a and start: the grey
    recursion is linear in b, so b can be fitted to the error the block outputs instead of to the equation."""
    filtered, start = _responses(sums, first, a)
    return np.diff(np.vstack([np.zeros((1, filtered.shape[1])), filtered]), axis=0), np.diff(np.r_[first, start])


def _gm1n_on_a_campaign(parts: list[Part], runs: list[tuple[np.ndarray, np.ndarray]], dt: float, resolvable: bool,
                        span_s: float) -> tuple[float, np.ndarray, float, float, str]:
    """a, b, the ridge weight, the held-out error and how they were chosen, leaving out each run
    (models/grey_campaign.py): the grid of a from the longest run, the paper's a where it settles within it."""
    def paper(chosen: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray | None:
        params = _gm1n_parameters(chosen)
        return params if 0 < params[0] < 2 and dt / params[0] <= span_s and resolvable else None

    grid = [*(float(a) for a in development_candidates(dt, max(len(target) for _, target in runs))), NO_MEMORY]
    estimate, a, weight, rmse = grey_campaign.gm1n(runs, [p.target for p in parts], grid, _output_pieces, paper,
                                                   _background, NO_MEMORY)
    if estimate == "paper":
        params = paper(runs)
        a, b = float(params[0]), params[1:]
    elif estimate == "equation":
        b = _gm1n_slopes(runs, a, weight)
    else:
        first = _first_error([target for _, target in runs])
        pieces = [_output_pieces(sums, first, a) for sums, _ in runs]
        measured = [np.isfinite(p.target[1:]) for p in parts]
        b = ridge.ridge(np.vstack([d[m] for (d, _), m in zip(pieces, measured)]),
                        np.concatenate([(p.target[1:] - o)[m] for p, (_, o), m in zip(parts, pieces, measured)]),
                        weight, intercept=False)[1]
    return a, b, weight, rmse, (f"{grey_campaign.label(GM1N_ESTIMATES[estimate], weight)}, a and b chosen "
                                f"leaving out each of {len(runs)} runs")


NO_MEMORY = 2.0  # a = 2: Keep = 0, x1(k) = sum_i b_i*x_i(k)/2, the shrunk linear fit (a ridge on the sequences)
CAMPAIGN_RUNS = 3  # a campaign of at least this many runs is fitted on the rises


def fit_on_sequences(parts: list[Part], names: list[str], fitter) -> tuple[dict, dict, dict]:
    """The paper's readings on one or two runs; on a campaign of three or more, the temperatures' rises since
    each run's start. A campaign's drift is zeroed at each run's start and the hall air moves from run to run:
    readings give each run an offset no coefficient removes. The choice between them was once made leaving out
    each run: on FL_THERMAL ch3 cut into 6 h runs (every sensor) the readings won on the seven runs of one fold
    by a third, each of the seven runs better, and missed the eighth by 12.6 um where the rises miss it by 1.7
    (GM(1,N): 5.69 um held out against 3.51 with the rises in every fold); on the twin campaigns (cascade and
    portal, seeds 1 and 2) the readings never won by more than a standard error."""
    return fitter(parts, names, rises=len(parts) >= CAMPAIGN_RUNS)


def _unsettled(a: float, dt: float, resolvable: bool) -> str:
    if not resolvable:
        return "comes with sensor sums too collinear for binary32 to resolve their slopes"
    if not 0 < a < 2:
        return "never settles (the grey difference equation settles only for 0 < a < 2)"
    return f"settles with a time constant of {dt / a / 3600:.3g} h, longer than the training rows span"


def gm11_predict(target_train: np.ndarray, rows: int) -> np.ndarray:
    """GM(1,1) baseline (float64): fitted on the training target, extrapolated over `rows` samples."""
    a, b = _gm1n_parameters([(np.ones((len(target_train), 1)), target_train)])
    accumulated = (target_train[0] - b / a) * np.exp(-a * np.arange(rows)) + b / a
    return np.diff(accumulated, prepend=0.0)


def predict_gm0n(model: Model, inputs: dict, precision: str) -> dict:
    """Reference in binary32 ('f32') or float64, in the block's operation order: {target name: error
    estimate per row}. X1 at the first call, then the first difference of a + sum_i b_i*S_i(k), which is
    sum_i b_i*x_i(k) exactly: no running sums, so nothing grows on a PLC that runs for weeks (x_i the
    readings, or with settings.rises their rises since the first call; with b_0 the unit sequence's term
    b_0*1 first)."""
    f = np.float32 if precision == "f32" else np.float64
    temps = [np.asarray(inputs[s.name], f) for s in model.signals("temperature")]
    x1 = f(model.coef("X1", precision))
    b = [f(model.coef(f"b_{i}", precision)) for i in range(1, len(temps) + 1)]
    b0 = unit_coefficient(model, precision, f)
    rises = bool(model.settings.get("rises"))
    return {model.target.name: gm0n_loop(temps, x1, b, f, rises=rises, b0=b0)}


def unit_coefficient(model: Model, precision: str, f):
    """b_0, the unit sequence's coefficient, where the fit drove the model with one (a campaign); else None."""
    return f(model.coef("b_0", precision)) if "b_0" in model.coefficients else None


def predict_gm1n(model: Model, inputs: dict, precision: str) -> dict:
    """Reference in binary32 ('f32') or float64, in the block's operation order: {target name: error
    estimate per row}. The grey difference equation X1(k) = Keep*X1(k-1) + In*sum_i b_i*S_i(k) differenced
    once: x1(k) = Keep*x1(k-1) + In*sum_i b_i*x_i(k) from the third call, the same estimates without
    running sums (bounded however long the block runs); the first call gives X1 and the second
    (Keep*X1 + In*sum_i b_i*(x_i(1) + x_i(2))) - X1, the equation's own start (x_i the readings, or with
    settings.rises their rises since the first call, 0 at the first; with b_0 the unit sequence's term first:
    b_0*1, and (b_0 + b_0) at the second call, its running sum there being 2)."""
    f = np.float32 if precision == "f32" else np.float64
    temps = [np.asarray(inputs[s.name], f) for s in model.signals("temperature")]
    c = lambda name: f(model.coef(name, precision))
    b = [c(f"b_{i}") for i in range(1, len(temps) + 1)]
    x1, keep, gain = c("X1"), c("Keep"), c("In")
    b0 = unit_coefficient(model, precision, f)
    rises = bool(model.settings.get("rises"))
    return {model.target.name: gm1n_loop(temps, x1, keep, gain, b, f, rises=rises, b0=b0)}


class StreamCore:
    """predict_gm0n / predict_gm1n with the first temperatures and the last estimate kept."""

    def __init__(self, model: Model, precision: str, f):
        self.f, self.kind, self.target = f, model.kind, model.target.name
        self.temps = model.signals("temperature")
        c = lambda name: f(model.coef(name, precision))
        self.b = [c(f"b_{i}") for i in range(1, len(self.temps) + 1)]
        self.scalars = (c("X1"),) if model.kind == "gm0n" else (c("X1"), c("Keep"), c("In"))
        self.state = GreyState(len(self.temps), f)
        self.rises = bool(model.settings.get("rises"))
        self.b0 = unit_coefficient(model, precision, f)

    def __call__(self, running: dict, fused_valid: dict) -> dict:
        temps = [np.asarray(running[s.name], self.f) for s in self.temps]
        if self.kind == "gm0n":
            out = gm0n_loop(temps, *self.scalars, self.b, self.f, self.state, self.rises, self.b0)
        else:
            out = gm1n_loop(temps, *self.scalars, self.b, self.f, self.state, self.rises, self.b0)
        return {self.target: out}


# The references' one loop per kind, compiled or run as Python (base/compiled.py; the rules that keep its bits in
# models/kernels.py). temps: (k, rows).

@compiled.jit
def _gm0n(temps, x1, b, b0, unit, rises, first, started, out):
    k = temps.shape[0]
    for j in range(out.shape[0]):
        if started[0] == 0:
            for i in range(k):
                first[i] = temps[i, j]
            out[j] = x1
            started[0] = 1
            continue
        level = b[0] * (temps[0, j] - first[0] if rises else temps[0, j])
        if unit:
            level = b0 + level
        for i in range(1, k):
            level = level + b[i] * (temps[i, j] - first[i] if rises else temps[i, j])
        out[j] = level


@compiled.jit
def _gm1n(temps, x1, keep, gain, b, b0, unit, rises, first, prev, started, out):
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
            if unit:
                forced = (b0 + b0) + forced
            for i in range(1, k):
                forced = forced + b[i] * (temps[i, j] - first[i] if rises else first[i] + temps[i, j])
            level = (keep * previous + gain * forced) - x1
            started[0] = 2
        else:
            forced = b[0] * (temps[0, j] - first[0] if rises else temps[0, j])
            if unit:
                forced = b0 + forced
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


def gm0n_loop(temps: list, x1, b: list, f, state: GreyState | None = None, rises: bool = False,
              b0=None) -> np.ndarray:
    """GM(0,N) error estimates of `temps` (one array per sensor); `state` carries the first temperatures from chunk
    to chunk."""
    state = state or GreyState(len(temps), f)
    stacked = np.array(temps, f).reshape(len(temps), -1)
    out = np.empty(stacked.shape[1], f)
    compiled.route(_gm0n, len(out))(stacked, f(x1), np.array(b, f), f(0.0 if b0 is None else b0), b0 is not None,
                                    rises, state.first, state.started, out)
    return out


def gm1n_loop(temps: list, x1, keep, gain, b: list, f, state: GreyState | None = None, rises: bool = False,
              b0=None) -> np.ndarray:
    """GM(1,N) error estimates of `temps` (one array per sensor); `state` carries the first temperatures and the last
    estimate."""
    state = state or GreyState(len(temps), f)
    stacked = np.array(temps, f).reshape(len(temps), -1)
    out = np.empty(stacked.shape[1], f)
    compiled.route(_gm1n, len(out))(stacked, f(x1), f(keep), f(gain), np.array(b, f), f(0.0 if b0 is None else b0),
                                    b0 is not None, rises, state.first, state.prev, state.started, out)
    return out


GM0N = Kind("gm0n", 5, "003", lambda parts, request, names, dt, progress: fit_on_sequences(parts, names, fit_gm0n),
            predict_gm0n, auto="closed-form",
            settings_schema={"type": "object", "properties": {"a": {"type": "number"}, "rises": {"type": "boolean"}}},
            stream_core=StreamCore)
GM1N = Kind("gm1n", 6, "003", lambda parts, request, names, dt, progress: fit_on_sequences(
                parts, names, lambda runs, labels, rises: fit_gm1n(runs, labels, dt, rises)),
            predict_gm1n, auto="closed-form",
            settings_schema={"type": "object", "properties": {"a": {"type": "number"},
                                                              "b": {"type": "array", "items": {"type": "number"}},
                                                              "rises": {"type": "boolean"}}},
            stream_core=StreamCore)
