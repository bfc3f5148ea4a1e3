"""How the diagnosis fits a candidate and judges it: the score of a model on the training and held-out
rows (BIC with one variance per channel, noise-normalised held-out error), the BIC change over the
effective rows of the residual, and the held-out evidence an identified model's extension needs."""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from thermoplc.diagnosis.parts import Parts
from thermoplc.diagnosis.windows import measured
from thermoplc.physics import identified_effects
from thermoplc.physics import simulation as sim_
from thermoplc.physics.fitted import Simulation
from thermoplc.physics.primitives import Series

BIC_MARGIN = 10.0
HELD_OUT_SHARE = 0.2
MIN_TRAIN_EXCESS = 0.05  # ... and its training MSE by this share
MIN_TRAIN_EVIDENCE = 100.0  # or a candidate cuts its training squared error by this many noise variances
MIN_EXCESS = 0.1  # a channel counts as off when its held-out MSE exceeds its noise variance by this share


@dataclass(frozen=True)
class Score:
    rmse_train: dict  # channel -> RMSE on the training rows
    rmse_held_out: dict
    max_abs_held_out: dict
    bic: float
    held_out: float  # sum over channels of held-out MSE / noise variance
    held_out_by_channel: dict
    train_by_channel: dict  # channel -> training MSE / noise variance


def channels_of(series: Series, target_name: str) -> tuple[str, ...]:
    return (*series.names, target_name)


def simulate(sim: Simulation, parts: Parts, channels) -> tuple[tuple[dict, dict], dict]:
    """((simulated channels as shown, residuals as shown), residuals judged), each pooled over the runs
    (parts.pool), every run from its own first row. The judged residuals are measured minus what the model
    predicts: for an identified model the temperatures' one-step innovations of the filter. The shown ones are
    where its physics and the data disagree: the temperatures simulated open loop (filter gains 0), since a heat
    the model lacks is taken by the filter for noise and shows only there as a window. The displacement's are
    the same; a model without filter gains shows what it judges."""
    outs = [sim_.run(sim, run) for run in parts.runs]
    names = parts.runs[0].names
    simulated = {c: parts.pool([out[c] for out in outs]) for c in names}
    simulated[channels[-1]] = parts.pool([out["target"] for out in outs])
    measured = {c: parts.pool([run.temps[:, i] for run in parts.runs]) for i, c in enumerate(names)}
    measured[channels[-1]] = parts.pool([run.target for run in parts.runs])
    judged = {c: measured[c] - simulated[c] for c in channels}
    if not sim.filtered:
        return (simulated, judged), judged
    open_loop = tuple(replace(p, filter_gain=0.0) for p in sim.sensors)
    readings = [sim_.temperatures(run, sim.shared, open_loop, sim.effects)[0] for run in parts.runs]
    shown = {**simulated, **{c: parts.pool([r[:, i] for r in readings]) for i, c in enumerate(names)}}
    return (shown, {c: measured[c] - shown[c] for c in channels}), judged


def score(sim: Simulation, residual: dict, sigma: dict, n_train: int) -> Score:
    bic = 0.0
    held = 0.0
    rmse_train, rmse_held, max_held, normalised = {}, {}, {}, {}
    for c, r in residual.items():  # a probed target counts its probings (NaN between them)
        train, rest = measured(r[:n_train]), measured(r[n_train:])
        sse, rows = float(train @ train), max(len(train), 1)
        bic += rows * np.log(max(sse, 1e-300) / rows)
        rmse_train[c] = float(np.sqrt(sse / rows))
        rmse_held[c] = float(np.sqrt(np.mean(rest ** 2))) if len(rest) else None
        max_held[c] = float(np.max(np.abs(rest))) if len(rest) else None
        if len(rest):
            normalised[c] = float(np.mean(rest ** 2)) / max(sigma[c], 1e-12) ** 2
            held += normalised[c]
    bic += sim.parameter_count() * np.log(n_train * len(residual))
    train_normalised = {c: (rmse_train[c] / max(sigma[c], 1e-12)) ** 2 for c in residual}
    return Score(rmse_train, rmse_held, max_held, float(bic), held, normalised, train_normalised)


def effective_rows(residual: np.ndarray) -> float:
    """Rows a residual counts for in the BIC: n (1 - rho) / (1 + rho), rho its lag-1 autocorrelation
    (not centred, so a bias counts as memory); the AR(1) effective size of a mean, fewer than the
    n (1 - rho^2) / (1 + rho^2) of a sum of squares, so the count errs toward refusing. A white
    residual counts every row;
    a residual that is a slow misfit (a real machine the model does not follow) counts a handful,
    however many samples it has: the Gaussian BIC treats rows as independent and otherwise credits
    any extra parameter that bends the model toward a slow misfit with thousands of units. A probed target's
    residual counts its probings, in order."""
    residual = measured(residual)
    energy = float(residual @ residual)
    rho = float(residual[1:] @ residual[:-1]) / energy if energy > 0 and len(residual) > 1 else 0.0
    rho = min(max(rho, 0.0), 1.0 - 1e-9)
    return max(len(residual) * (1.0 - rho) / (1.0 + rho), 1.0)


def effective_delta_bic(before: dict, after: dict, added_parameters: int, n_train: int) -> float:
    """The BIC change with each channel's likelihood counted over the effective rows of the
    candidate's training residual (`effective_rows`): on white residuals the plain change, on
    residuals that keep a slow misfit a small fraction of it. An effect that explains what is
    missing leaves white residuals behind; one that only bends the model toward a misfit it cannot
    follow does not (residual whiteness as the stopping rule; CTSM judges the filter's innovations,
    this judges the open-loop residual the diagnosis compares)."""
    change = 0.0
    for c, r in after.items():
        new, old = measured(r[:n_train]), measured(before[c][:n_train])
        change += effective_rows(new) * np.log(max(float(new @ new), 1e-300) / max(float(old @ old), 1e-300))
    return float(change + added_parameters * np.log(n_train * len(after)))


def held_out_gain(before: Score, after: Score, n_train: int) -> float:
    """The largest share of a channel's excess above noise removed, over channels that are off on the
    held-out part and that the training part supports: visibly off there too, or fitted better by
    the candidate beyond what chance allows. A held-out gap the training part gives no evidence on is
    extrapolation error (of coefficients the data hardly separates), not a missing effect."""
    def supported(c: str) -> bool:
        visible = before.train_by_channel[c] - 1.0 >= MIN_TRAIN_EXCESS
        return visible or n_train * (before.train_by_channel[c] - after.train_by_channel[c]) >= MIN_TRAIN_EVIDENCE
    gains = [(before.held_out_by_channel[c] - after.held_out_by_channel[c]) / (before.held_out_by_channel[c] - 1.0)
             for c in before.held_out_by_channel if before.held_out_by_channel[c] - 1.0 >= MIN_EXCESS and supported(c)]
    return max(gains, default=0.0)


def identified(sim: Simulation) -> bool:
    """True for a model identified as `fit --model lumped` identifies it (filter gains, a map whose ridge
    weight forward validation chose); False for an open-loop simulation fitted by least squares."""
    return sim.displacement.ridge_weight is not None


def refit(train: list[Series], effects, warm: Simulation, polish: bool = False) -> Simulation:
    """`warm` refitted with these effects on the training parts: as a nested extension of an identified
    model (physics/identified_effects.py), or as the open-loop simulation (physics/simulation.py, one run)."""
    if identified(warm):
        return identified_effects.extend(train, effects, warm, polish)
    if len(train) != 1:
        raise ValueError("the open-loop simulation is fitted on one run")
    return sim_.fit(train[0], effects, warm=warm, polish=polish)


def held_out_evidence(before: dict, after: dict, parts: Parts) -> float:
    """Twice the log-likelihood gain on the held-out rows the training part has seen the like of (`seen_rows`),
    each channel's counted over the effective rows of the residual the candidate leaves there: the parameters
    come from the training part, so this is evidence the fit never saw. On an identified model a missing heat
    shows as larger one-step innovations of a sensor (the filter takes it for process noise), not as a window
    of slow misfit: this is its judge."""
    seen = parts.seen_held_out()
    total = 0.0
    for c, r in after.items():
        new, old = measured(r[parts.n_train:][seen]), measured(before[c][parts.n_train:][seen])
        if len(new):
            total += effective_rows(new) * np.log(max(float(old @ old), 1e-300) / max(float(new @ new), 1e-300))
    return float(total)


def held_out_threshold(added_parameters: int, held_rows: int) -> float:
    """The held-out evidence an identified model's extension needs: what the BIC would charge for its
    parameters on the held-out rows, plus the margin."""
    return added_parameters * float(np.log(max(held_rows, 2))) + BIC_MARGIN
