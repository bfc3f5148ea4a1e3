"""GA-optimised back-propagation network (paper 002), with portable activations.

Inputs: temperature rises scaled to [-1, 1] by the training range; one hidden layer; linear
outputs scaled back to their units (axial elongation um, yaw and pitch tilt urad, ...). The
hidden activation is tanh approximated by the Pade (7,6) rational function on a clipped input:
    act(x) = r(min(max(x, -4.97), 4.97)),  r(x) = x*(1 + p1 x^2 + p2 x^4 + p3 x^6)/(1 + q1 x^2 + q2 x^4 + q3 x^6)
with |act(x) - tanh(x)| <= 9.6e-5 for every x (measured on a 1e-5 grid over [0, 8]); only
+ - * / MIN MAX, so the block is portable (numeric contract rule 4). Training uses this same function, so the
fitted network is the one the block computes.

A genetic algorithm with paper 002's operators (roulette, single-point crossover, one mutated
position) first chooses the hidden-layer size (fitness eq. 16: 1/sum|y - Q| on held-back rows
after a short training), then the initial weights and thresholds (fitness eq. 17: 1/sum(y - Q)^2
of the untrained network); back-propagation (batch gradient descent with momentum) trains from
there. Paper 002's compensation equations with the tool length L (small tilt angles, axial
elongation far below L): Dx = L*yaw, Dy = L*pitch, Dz = elongation (um with L in mm, angles in urad).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from thermoplc.base.errors import UserError
from thermoplc.models.ga import GA_OPTIONS, genetic_minimize, step_reporter
from thermoplc.base.identifiers import block_identifier
from thermoplc.base.binary32 import round_f32
from thermoplc.models.kind import Kind, KindOption, measured_counts
from thermoplc.models.kinds.mlr import least_squares, on_rises, weight_by
from thermoplc.models.model import Coefficient, Model

PADE_P = (1.0, 17325 / 135135, 378 / 135135, 1 / 135135)
PADE_Q = (1.0, 62370 / 135135, 3150 / 135135, 28 / 135135)
CLIP = 4.97
ACTIVATION_ERROR_BOUND = 9.6e-5
HIDDEN_RANGE = (2, 12)
PROGRESS_EPOCHS = 100  # back-propagation reports every this many epochs
PAPER_002_MUTATION = 0.1  # share of individuals mutated at one position (paper 002 gives no value)
# paper 000's Gaussian mutation draws per gene: its rate as in the Kalman fit (models/ga.py's default)
MUTATION = {"paper002": PAPER_002_MUTATION, "paper000": 0.02}


@dataclass(frozen=True)
class Network:
    w1: np.ndarray  # (hidden, inputs)
    b1: np.ndarray
    w2: np.ndarray  # (outputs, hidden)
    b2: np.ndarray


def _numerator_denominator(z):
    z2 = z * z
    num = z * (PADE_P[0] + z2 * (PADE_P[1] + z2 * (PADE_P[2] + z2 * PADE_P[3])))
    den = PADE_Q[0] + z2 * (PADE_Q[1] + z2 * (PADE_Q[2] + z2 * PADE_Q[3]))
    return num, den


def activation(x: np.ndarray) -> np.ndarray:
    """The hidden layer's tanh stand-in, Pade (7,6) on x clipped to +-4.97, in float64: the function training
    uses and the block computes (within 9.6e-5 of tanh)."""
    num, den = _numerator_denominator(np.clip(x, -CLIP, CLIP))
    return num / den


def activation_slope(x: np.ndarray) -> np.ndarray:
    """The derivative of `activation` for back-propagation: 0 where |x| >= 4.97, since the clip holds it."""
    z = np.clip(x, -CLIP, CLIP)
    z2 = z * z
    num, den = _numerator_denominator(z)
    dnum = PADE_P[0] + z2 * (3 * PADE_P[1] + z2 * (5 * PADE_P[2] + z2 * 7 * PADE_P[3]))
    dden = z * (2 * PADE_Q[1] + z2 * (4 * PADE_Q[2] + z2 * 6 * PADE_Q[3]))
    return np.where(np.abs(x) < CLIP, (dnum * den - num * dden) / (den * den), 0.0)


def forward(net: Network, x: np.ndarray) -> np.ndarray:
    """The network's outputs (rows, outputs) for inputs `x` (rows, inputs), both in the scaled units it trains on."""
    return activation(x @ net.w1.T + net.b1) @ net.w2.T + net.b2


def _random_network(rng, inputs: int, hidden: int, outputs: int) -> Network:
    return Network(rng.uniform(-1, 1, (hidden, inputs)), rng.uniform(-1, 1, hidden),
                   rng.uniform(-1, 1, (outputs, hidden)), rng.uniform(-1, 1, outputs))


def _unpack(genes: np.ndarray, inputs: int, hidden: int, outputs: int) -> Network:
    sizes = [hidden * inputs, hidden, outputs * hidden, outputs]
    parts = np.split(genes, np.cumsum(sizes)[:-1])
    return Network(parts[0].reshape(hidden, inputs), parts[1], parts[2].reshape(outputs, hidden), parts[3])


def train(net: Network, x: np.ndarray, y: np.ndarray, epochs: int, goal_mse: float,
          rate: float = 0.2, momentum: float = 0.9,
          progress: Callable[[int, float], None] | None = None) -> tuple[Network, int, float]:
    """Batch gradient descent with momentum until the training MSE reaches goal_mse.
    Returns the network, the epochs used, and the final MSE."""
    w1, b1, w2, b2 = (a.copy() for a in (net.w1, net.b1, net.w2, net.b2))
    velocity = [np.zeros_like(a) for a in (w1, b1, w2, b2)]
    mse = float("inf")
    for epoch in range(1, epochs + 1):
        pre = x @ w1.T + b1
        hidden = activation(pre)
        error = hidden @ w2.T + b2 - y
        mse = float(np.mean(error ** 2))
        if progress and epoch % PROGRESS_EPOCHS == 0:
            progress(epoch, mse)
        if mse <= goal_mse:
            return Network(w1, b1, w2, b2), epoch - 1, mse
        grad_out = 2 * error / error.size
        grad_hidden = (grad_out @ w2) * activation_slope(pre)
        grads = (grad_hidden.T @ x, grad_hidden.sum(0), grad_out.T @ hidden, grad_out.sum(0))
        for v, g, p in zip(velocity, grads, (w1, b1, w2, b2)):
            v *= momentum
            v -= rate * g
            p += v
    return Network(w1, b1, w2, b2), epochs, mse


OPERATOR_NAMES = {"paper002": "paper 002's operators (single-point crossover, one mutated position)",
                  "paper000": "paper 000's operators (arithmetic crossover, Gaussian mutation)"}


def _scale(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per column (scale, shift) mapping the training range onto [-1, 1]."""
    low, high = values.min(axis=0), values.max(axis=0)
    span = np.where(high > low, high - low, 1.0)
    return 2.0 / span, -1.0 - 2.0 * low / span


def _coefficient_names(m: int, hidden: int, q: int) -> list[str]:
    """The network's coefficient names in block order (`_coefficients`)."""
    names = [f"in_{what}_{i}" for i in range(1, m + 1) for what in ("scale", "shift")]
    for j in range(1, hidden + 1):
        names += [f"b1_{j}", *(f"w1_{j}_{i}" for i in range(1, m + 1))]
    for k in range(1, q + 1):
        names += [f"b2_{k}", *(f"w2_{k}_{j}" for j in range(1, hidden + 1)), f"out_scale_{k}", f"out_shift_{k}"]
    return names + ["act_p1", "act_p2", "act_p3", "act_q1", "act_q2", "act_q3", "act_one", "act_clip", "act_nclip"]


def _coefficients(net, scaled_in: tuple, scaled_out: tuple) -> dict[str, Coefficient]:
    """The model file's coefficients in block order (`_coefficient_names`): input scaling, hidden layer, output
    layer with the scaling back to um, then the activation's Pade constants and clip."""
    (in_scale, in_shift), (out_scale, out_shift) = scaled_in, scaled_out
    hidden, m = net.w1.shape
    q = net.w2.shape[0]
    values = [v for i in range(m) for v in (in_scale[i], in_shift[i])]
    for j in range(hidden):
        values += [net.b1[j], *net.w1[j]]
    for k in range(q):
        values += [net.b2[k], *net.w2[k], 1.0 / out_scale[k], -out_shift[k] / out_scale[k]]
    values += [*PADE_P[1:], *PADE_Q[1:], 1.0, CLIP, -CLIP]
    return {name: Coefficient.of(v) for name, v in zip(_coefficient_names(m, hidden, q), values, strict=True)}


def fit_bpnn(rises: np.ndarray, targets: np.ndarray, names: list[str], seed: int, population: int,
             generations: int, epochs: int = 3000, goal_mse: float = 2e-3,
             operators: str = "paper002", progress: Callable[[str], None] | None = None,
             runs: list[int] | None = None, from_zero: bool = False) -> tuple[dict, dict, dict]:
    """rises (rows, sensors) since each run's first row, targets (rows, outputs): the measured training
    rows of every run (`runs` rows each), in run order. `progress` hears each of its steps with an
    estimate of its time left (the weight GA is the long one: population x generations forward passes).
    With `from_zero` (what a ridge leaves, `--skip ridge`) back-propagation starts from the GA's hidden layer
    with the output layer at 0 um and stops early (`_early_stopped`); the paper's comparison is not run."""
    rng = np.random.default_rng(seed)
    steps = 3 if from_zero else 4  # the steps progress counts
    in_scale, in_shift = _scale(rises)
    x = rises * in_scale + in_shift
    out_scale, out_shift = _scale(targets)
    y = targets * out_scale + out_shift
    rows = len(x)
    stride = max(1, rows // 2000)  # training set thinned to ~2000 rows; thermal data is smooth
    fit_rows = np.arange(0, int(rows * 0.8), stride)
    check_rows = np.arange(int(rows * 0.8), rows, stride)
    if len(fit_rows) < 10 or len(check_rows) < 2:
        raise UserError(f"--model bpnn needs at least 50 training rows, got {rows}")
    m, q = x.shape[1], y.shape[1]
    scores: dict[int, float] = {}

    def hidden_fitness(pop: np.ndarray) -> np.ndarray:
        out = []
        for gene in pop[:, 0]:
            n = int(gene)
            if n not in scores:
                trial = _random_network(np.random.default_rng(seed + n), m, n, q)
                trained, _, _ = train(trial, x[fit_rows], y[fit_rows], 150, 0.0)
                scores[n] = float(np.sum(np.abs(forward(trained, x[check_rows]) - y[check_rows])))  # eq. 16
            out.append(scores[n])
        return np.array(out)

    hidden_generations = max(3, generations // 4)
    hidden_ga = genetic_minimize(hidden_fitness, np.array([HIDDEN_RANGE[0]]), np.array([HIDDEN_RANGE[1] + 0.999]),
                                 rng, population=max(6, population // 4), generations=hidden_generations,
                                 p_mutation=MUTATION[operators], operators=operators,
                                 progress=step_reporter(f"bpnn 1/{steps} hidden size", hidden_generations, progress,
                                                        cost="best error"))
    hidden = int(hidden_ga.x[0])
    length = hidden * m + hidden + q * hidden + q
    xs, ys = x[fit_rows], y[fit_rows]

    def weight_fitness(pop: np.ndarray) -> np.ndarray:
        sse = np.empty(len(pop))
        for p, genes in enumerate(pop):
            sse[p] = np.sum((forward(_unpack(genes, m, hidden, q), xs) - ys) ** 2)
        return sse

    weight_ga = genetic_minimize(weight_fitness, -np.ones(length), np.ones(length), rng, population, generations,
                                 p_mutation=MUTATION[operators], operators=operators,
                                 progress=step_reporter(f"bpnn 2/{steps} weights of {hidden} hidden neurons",
                                                        generations, progress, cost="best SSE"))
    if from_zero:
        start = _unpack(weight_ga.x, m, hidden, q)
        start = Network(start.w1, start.b1, np.zeros_like(start.w2), out_shift.copy())  # 0 um out
        runs = runs or [rows]
        net, stopping = _early_stopped(start, x, y, runs, epochs, out_scale,
                                       step_reporter("bpnn 3/3 back-propagation from 0 um, stopped early",
                                                     epochs * stopping_folds(runs), progress, unit="epoch",
                                                     cost="validation MSE um^2"))
        return (_coefficients(net, (in_scale, in_shift), (out_scale, out_shift)),
                _settings(m, hidden, q), {**_ga_log(operators, scores, weight_ga), **stopping})
    net, epochs_ga, mse_ga = train(_unpack(weight_ga.x, m, hidden, q), xs, ys, epochs, goal_mse,
                                   progress=step_reporter("bpnn 3/4 back-propagation from the GA's weights", epochs,
                                                          progress, unit="epoch", cost="MSE"))
    _, epochs_plain, mse_plain = train(_random_network(np.random.default_rng(seed), m, hidden, q), xs, ys,
                                       epochs, goal_mse,
                                       progress=step_reporter("bpnn 4/4 plain back-propagation (the paper's "
                                                              "comparison)", epochs, progress, unit="epoch",
                                                              cost="MSE"))
    coefficients = _coefficients(net, (in_scale, in_shift), (out_scale, out_shift))
    log = {**_ga_log(operators, scores, weight_ga), "goal_mse": goal_mse, "epoch_limit": epochs,
           "ga_bp_epochs": epochs_ga, "ga_bp_mse": mse_ga, "plain_bp_epochs": epochs_plain, "plain_bp_mse": mse_plain}
    return coefficients, _settings(m, hidden, q), log


def _settings(m: int, hidden: int, q: int) -> dict:
    return {"inputs": m, "hidden": hidden, "outputs": q, "activation": "Pade(7,6) tanh on clip(x, +-4.97)",
            "activation_error_bound": ACTIVATION_ERROR_BOUND}


def _ga_log(operators: str, scores: dict[int, float], weight_ga) -> dict:
    return {"method": f"GA with {OPERATOR_NAMES[operators]} (hidden size, initial weights) + back-propagation with "
                      f"momentum",
            "hidden_size_scores": {str(k): v for k, v in sorted(scores.items())},
            "weight_ga_history": list(weight_ga.history)}


STOPPING_EPOCHS = 50  # early stopping looks at the validation rows every this many epochs
STOPPING_FOLDS = 4  # a campaign's runs in at most this many groups, each the validation rows once
TRAINING_ROWS = 2000  # back-propagation's rows, thinned evenly: thermal data is smooth


def _early_stopped(start: Network, x: np.ndarray, y: np.ndarray, runs: list[int], epochs: int, out_scale: np.ndarray,
                   progress) -> tuple[Network, dict]:
    """Back-propagation from `start` for the epochs (a multiple of STOPPING_EPOCHS, 0 included: the start)
    that predict rows it did not train on best, then again from `start` on every row (thinned to about
    TRAINING_ROWS) for that many. Rows not trained on: on a campaign each of up to STOPPING_FOLDS groups of whole
    runs in turn, the squared errors summed; on one recording its last fifth (the input and output scaling and
    the GA's hidden layer come from every row). On FL_THERMAL's 6 h runs (ch3, every sensor) one group (the last
    quarter of the runs) took epochs the first run did not confirm: 1.36 x the ridge held out."""
    run_of_row = np.repeat(np.arange(len(runs)), runs)
    groups = np.array_split(np.arange(len(runs)), stopping_folds(runs)) if len(runs) >= 2 else []
    folds = [np.isin(run_of_row, group) for group in groups] or [np.arange(len(x)) >= int(len(x) * 0.8)]
    checkpoints = np.arange(0, epochs + 1, STOPPING_EPOCHS)
    squared = np.zeros(len(checkpoints))
    for number, held in enumerate(folds, start=1):
        fitted, checked = _thinned(np.flatnonzero(~held)), _thinned(np.flatnonzero(held))
        error = lambda net: float(np.sum(((forward(net, x[checked]) - y[checked]) / out_scale) ** 2) / len(checked))
        net = start
        squared[0] += error(net)
        for point, done in enumerate(checkpoints[1:], start=1):
            net = train(net, x[fitted], y[fitted], STOPPING_EPOCHS, 0.0)[0]
            squared[point] += error(net)
            if progress:
                progress((number - 1) * epochs + done, squared[point] / number)
    best = int(np.argmin(squared))
    every = _thinned(np.arange(len(x)))
    final = train(start, x[every], y[every], int(checkpoints[best]), 0.0)[0] if best else start
    validation = f"{len(folds)} groups of {len(runs)} runs, each left out in turn" if groups else \
        "the last fifth of the rows"
    return final, {"early_stopping": {"epochs": int(checkpoints[best]), "validation": validation,
                                      "validation_rmse_um_at_0_um": float(np.sqrt(squared[0] / len(folds))),
                                      "validation_rmse_um": float(np.sqrt(squared[best] / len(folds)))}}


def stopping_folds(runs: list[int]) -> int:
    """How many groups of runs early stopping leaves out in turn (1: one recording's last fifth)."""
    return min(STOPPING_FOLDS, len(runs)) if len(runs) >= 2 else 1


def _thinned(rows: np.ndarray) -> np.ndarray:
    """At most about TRAINING_ROWS of `rows`, evenly spaced."""
    return rows[::max(1, len(rows) // TRAINING_ROWS)]


def output_names(model: Model) -> list[str]:
    """The block output name of each target, in the network's output order (settings 'targets')."""
    return [t["name"] for t in model.settings["targets"]]


def has_compensation(model: Model) -> bool:
    """True when the model has a tool length input and at least three targets (elongation, yaw, pitch):
    the block then also outputs Dx_um, Dy_um and Dz_um."""
    return bool(model.signals("tool_length")) and len(model.settings["targets"]) >= 3


def predict(model: Model, inputs: dict, precision: str) -> dict:
    """Reference, vectorised over rows in binary32 or float64, in the block's operation order."""
    f = np.float32 if precision == "f32" else np.float64
    c = lambda name: f(model.coef(name, precision))
    m, hidden, q = model.settings["inputs"], model.settings["hidden"], model.settings["outputs"]
    temps = model.signals("temperature")
    x = []
    for i, s in enumerate(temps, start=1):
        t = np.asarray(inputs[s.name], f)
        x.append((t - t[0]) * c(f"in_scale_{i}") + c(f"in_shift_{i}"))
    p = [c(f"act_p{n}") for n in (1, 2, 3)]
    qq = [c(f"act_q{n}") for n in (1, 2, 3)]
    one, clip, nclip = c("act_one"), c("act_clip"), c("act_nclip")
    h = []
    for j in range(1, hidden + 1):
        z = np.full(len(x[0]), c(f"b1_{j}"), f)
        for i in range(1, m + 1):
            z = z + c(f"w1_{j}_{i}") * x[i - 1]
        z = np.where(z < nclip, nclip, np.where(z > clip, clip, z))  # IF z < -clip ... ELSIF z > clip
        z2 = z * z
        num = z * (one + z2 * (p[0] + z2 * (p[1] + z2 * p[2])))
        den = one + z2 * (qq[0] + z2 * (qq[1] + z2 * qq[2]))
        h.append(num / den)
    out = {}
    names = output_names(model)
    for k in range(1, q + 1):
        y = np.full(len(x[0]), c(f"b2_{k}"), f)
        for j in range(1, hidden + 1):
            y = y + c(f"w2_{k}_{j}") * h[j - 1]
        out[names[k - 1]] = y * c(f"out_scale_{k}") + c(f"out_shift_{k}")
        if model.settings.get("skip") == "ridge":  # Ridge + network, the ridge as mlr's output
            ridge = on_rises([inputs[s.name] for s in temps], [model.coef(f"ridge{k}_{i}", precision)
                                                               for i in range(len(temps) + 1)], f)
            out[names[k - 1]] = ridge + out[names[k - 1]]
    if has_compensation(model):
        length = np.asarray(inputs[model.signals("tool_length")[0].name], f)
        milli = c("um_per_mm_urad")
        out["Dx_um"] = length * out[names[1]] * milli
        out["Dy_um"] = length * out[names[2]] * milli
        out["Dz_um"] = out[names[0]]
    return out


def _unit_of(column: str) -> str:
    return "urad" if column.lower().endswith("urad") else "um"


def _fit(parts, request, names, dt, progress):
    rises = np.vstack([p.rises[p.measured] for p in parts])
    targets = np.vstack([np.column_stack([p.target, p.extra])[p.measured] for p in parts])
    skip = request.option("skip") == "ridge"
    weights, ridges, ridge_log = _skip_paths(parts, rises, targets, names) if skip else ([], None, {})
    coefficients, settings, log = fit_bpnn(rises, targets - ridges if skip else targets, names,
                                           request.option("seed"), request.option("population"),
                                           request.option("generations"), operators=request.option("ga_operators"),
                                           progress=progress, runs=measured_counts(parts), from_zero=skip)
    if skip:
        coefficients.update({f"ridge{k}_{i}": Coefficient.of(w) for k, beta in enumerate(weights, start=1)
                             for i, w in enumerate(beta)})
        settings["skip"] = "ridge"
        log = {**ridge_log, **log, "method": f"a ridge on every temperature's rise (weight by {weight_by(ridge_log)})"
                                             f" plus a network fitted to what it leaves: {log['method']}"}
    settings["targets"] = [{"name": block_identifier(c, "target"), "column": c, "unit": _unit_of(c)}
                           for c in (request.target, *request.extra_targets)]
    if request.option("tool_length"):
        if len(settings["targets"]) < 3:
            raise UserError("--tool-length needs three targets: axial elongation (um), yaw and pitch (urad)")
        coefficients["um_per_mm_urad"] = Coefficient.of(1e-3)
    return coefficients, settings, log


def _skip_paths(parts, rises: np.ndarray, targets: np.ndarray, names: list[str]):
    """`--skip ridge`: per target the weights w_0..w_n of a ridge on the rises (mlr's fit, binary32), its
    prediction on the measured rows as the block computes it (rows, targets), and the first target's ridge log
    (with every target's weight where there are several)."""
    weights, predictions, logs = [], [], []
    for k in range(targets.shape[1]):
        beta, log = least_squares(rises, targets[:, k], names, measured_counts(parts))
        weights.append([round_f32(w) for w in beta])
        predictions.append(np.concatenate([on_rises(list(p.temps.T), weights[-1], np.float32)[p.measured]
                                           for p in parts]).astype(float))
        logs.append(log)
    per_target = {"ridge_weight_per_target": [log["ridge_weight"] for log in logs]} if len(logs) > 1 else {}
    return weights, np.column_stack(predictions), {**logs[0], **per_target}


def check_settings(model: Model, path: str) -> None:
    """One network input per temperature, one output per target; with a ridge skip path its weights."""
    s, temps = model.settings, len(model.signals("temperature"))
    if s["inputs"] != temps or s["outputs"] != len(s["targets"]):
        raise UserError(f"{path}: field 'settings': inputs {s['inputs']} and outputs {s['outputs']} must be the "
                        f"{temps} temperature inputs and the {len(s['targets'])} targets")
    ridges = [f"ridge{k}_{i}" for k in range(1, s["outputs"] + 1) for i in range(temps + 1)]
    missing = [name for name in ridges if s.get("skip") == "ridge" and name not in model.coefficients]
    if missing:
        raise UserError(f"{path}: field 'coefficients': the ridge skip path has no weight {', '.join(missing)} "
                        f"(per target k: ridgek_0, the intercept, and one per temperature)")
    known = set(_coefficient_names(temps, s["hidden"], s["outputs"]))
    known |= set(ridges if s.get("skip") == "ridge" else ())
    known |= {"um_per_mm_urad"} if has_compensation(model) else set()
    unused = [name for name in model.coefficients if name not in known]
    if unused:
        raise UserError(f"{path}: field 'coefficients': {', '.join(unused)} not used by this bpnn model (a "
                        f"{temps}-{s['hidden']}-{s['outputs']} network"
                        f"{', with its ridge skip path' if s.get('skip') == 'ridge' else ', without a skip path'})")


SKIPS = ("none", "ridge")
SETTINGS_SCHEMA = {
    "type": "object",
    "required": ["inputs", "hidden", "outputs", "targets"],
    "properties": {"inputs": {"type": "integer", "minimum": 1, "maximum": 64},
                   "hidden": {"type": "integer", "minimum": 1, "maximum": 100},
                   "outputs": {"type": "integer", "minimum": 1, "maximum": 16},
                   "skip": {"enum": list(SKIPS)},
                   "targets": {"type": "array", "minItems": 1, "maxItems": 16,
                               "items": {"type": "object", "required": ["name", "column", "unit"],
                                         "properties": {"name": {"type": "string", "minLength": 1, "maxLength": 24},
                                                        "column": {"type": "string"},
                                                        "unit": {"enum": ["um", "urad"]}}}}}}

OPTIONS = (
    *GA_OPTIONS,
    KindOption("ga_operators", "--ga-operators", "paper002", "the GA's crossover and mutation, paper 002's "
               "single-point crossover and one mutated position, or paper 000's arithmetic crossover and Gaussian "
               "mutation (default: %(default)s; benchmarks/ga_operators.py compares them held out)",
               choices=("paper002", "paper000")),
    KindOption("tool_length", "--tool-length", None, "tool length column, mm; adds paper 002's X/Y/Z compensation "
               "outputs", metavar="COLUMN", column=("tool_length", "mm"), owned="--tool-length is"),
    KindOption("skip", "--skip", SKIPS[0], "a path around the network: none (paper 002), or a ridge on every "
               "temperature's rise, the network then fitted to what the ridge leaves from an output of 0 um and "
               "stopped early on runs it did not train on, so that it adds only what they confirm (many sensors, "
               "campaigns; default: %(default)s)", choices=SKIPS, owned="--skip is"),
)
KIND = Kind("bpnn", 8, "002", _fit, predict, owns_options=(("extra_targets", "several targets are"),),
            options=OPTIONS,
            auto="iterative", shrunk=(("skip", "ridge"),),
            settings_schema=SETTINGS_SCHEMA, check_settings=check_settings)
