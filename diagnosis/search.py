"""Find the missing effect (docs/diagnosis.md): fit, compare, test each named effect, keep what is supported.

An effect is kept only when both judges agree: the information criterion on the training part
(BIC, Gaussian with one variance per channel, falls by more than `BIC_MARGIN`, also with each
channel counted over the effective rows of the residual the candidate leaves) and the held-out
part (the noise-normalised squared error falls by at least `HELD_OUT_SHARE` of what is left
above the noise), on a channel that is off on the held-out part by more than `MIN_EXCESS` and on
the training part by more than `MIN_TRAIN_EXCESS` (or that the candidate fits better on the training
part by `MIN_TRAIN_EVIDENCE` noise variances), so leftovers at the noise level and held-out
extrapolation errors are never named. Of the supported candidates the one with the lowest BIC is
added, unless another plausible one gains nearly as much BIC (then the data cannot tell them
apart, whichever the held-out part prefers); the model is refitted until its BIC stops falling,
and the search repeats until no disagreement window is left or no candidate passes; what is left
unexplained is reported as windows, never named, and when several effects were needed and
windows are still left, none of them is named either.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from thermoplc.diagnosis import sufficiency
from thermoplc.diagnosis.parts import Parts, single
from thermoplc.diagnosis.windows import Window, find_windows, measured, noise_sigma, rms, settling_s
from thermoplc.physics import identified_effects, identify
from thermoplc.physics import simulation as sim_
from thermoplc.physics.effects import NAMES, definition_of
from thermoplc.physics.model import Simulation
from thermoplc.physics.primitives import Series

BIC_MARGIN = 10.0
AMBIGUOUS_BIC_SHARE = 0.02  # another effect within this share of the winner's BIC gain: no name
HELD_OUT_SHARE = 0.2
MIN_SENSOR_ERROR_SIGMAS = 1.5  # an offset or a drift over the recording smaller than this many noise sigmas is noise
MIN_DISPLACEMENT_TERM_SIGMAS = 3.0  # a displacement term moving less than this many noise sigmas is noise
MIN_TRAIN_EXCESS = 0.05  # ... and its training MSE by this share
MIN_TRAIN_EVIDENCE = 100.0  # or a candidate cuts its training squared error by this many noise variances
MIN_EXCESS = 0.1  # a channel counts as off when its held-out MSE exceeds its noise variance by this share
MIN_STAND_INS = 2  # this many effects added with windows still left: none is named
POLISH_ROUNDS = 3
# the diagnosis refits an identified model's map by least squares, the likelihood its criteria assume: a ridge
# weight held from forward validation biases the training fit, and a candidate would be credited with removing
# that bias (the cascade twin at one speed: weight 0.03 leaves 0.54 um on the training part, least squares 0.50,
# and a slow structure took the difference); on FL_THERMAL forward validation chooses 0 anyway
LEAST_SQUARES = 0.0
MIN_POLISH_GAIN = 1.0  # BIC; a refit that gains less has converged


@dataclass(frozen=True)
class Score:
    rmse_train: dict  # channel -> RMSE on the training rows
    rmse_held_out: dict
    max_abs_held_out: dict
    bic: float
    held_out: float  # sum over channels of held-out MSE / noise variance
    held_out_by_channel: dict
    train_by_channel: dict  # channel -> training MSE / noise variance


@dataclass(frozen=True)
class Trial:
    name: str
    sensor: str | None
    delta_bic: float
    held_out_gain: float  # largest share of a channel's excess above noise removed on the held-out part
    accepted: bool
    rejected_because: str | None = None
    held_out_evidence: float = 0.0  # log-likelihood ratio on the held-out rows (effective rows), channels summed


@dataclass
class Diagnosis:
    channels: tuple[str, ...]  # temperature columns, then the target column
    sigma: dict
    baseline: Simulation
    final: Simulation
    before: Score
    after: Score
    windows_before: list[Window]
    windows_after: list[Window]
    residual_before: dict  # channel -> residual over all rows
    residual_after: dict
    simulated_before: dict
    simulated_after: dict
    added: list[dict] = field(default_factory=list)  # {name, parameters, evidence} in the order added
    rounds: list[list[Trial]] = field(default_factory=list)
    not_tested: dict = field(default_factory=dict)  # name -> why
    insufficient: str | None = None  # why the data cannot support a diagnosis at all
    unseen: dict = field(default_factory=dict)  # remaining window index -> why training cannot judge it
    ambiguous: tuple[str, ...] = ()  # supported effects the data cannot separate, none named
    ambiguity: str = ""  # why they cannot be separated
    # effects the training part supports (BIC, physics) that the held-out part does not, with their size: listed
    # against the misfit left, never named
    unsupported: list[dict] = field(default_factory=list)
    parts: Parts | None = None  # the runs and their training rows; residuals are pooled in its order

    @property
    def verdict(self) -> str:
        if self.insufficient:
            return "insufficient_data"
        if not self.windows_before and not self.added:
            return "no_missing_effect"
        return "unexplained" if self.windows_after else "explained"

    @property
    def names_effects(self) -> bool:
        """False when several effects were added and windows are still left: they bent the model
        toward the data, but may stand in for what the library lacks, so none is named."""
        return not (self.verdict == "unexplained" and len(self.added) >= MIN_STAND_INS)

    @property
    def doubtful(self) -> set[str]:
        """Names of the effects the data cannot tell apart ("sensor_offset on T_motor" -> sensor_offset)."""
        return {label.split()[0] for label in self.ambiguous}

    @property
    def named(self) -> list[dict]:
        if not self.names_effects:
            return []
        return [e for e in self.added if e["name"] not in self.doubtful]

    @property
    def reason(self) -> str | None:
        """Why the verdict is not a plain yes or no: what the data lacks."""
        if self.insufficient:
            return self.insufficient
        if self.verdict != "unexplained":
            return None
        grouped: dict[str, list[int]] = {}
        for k, text in self.unseen.items():
            grouped.setdefault(text, []).append(k + 1)
        notes = [("window " if len(ks) == 1 else "windows ") + ", ".join(map(str, ks)) + f": {text}"
                 for text, ks in grouped.items()]
        if not self.names_effects:
            notes.insert(0, f"{len(self.added)} effects were added ({', '.join(e['name'] for e in self.added)}) and "
                            "disagreements are still left: they may stand in for what is missing, so none is named")
        if self.ambiguous:
            notes.insert(0, "the data cannot tell " + " from ".join(self.ambiguous) + f" ({self.ambiguity})")
        untested = {k: v for k, v in self.not_tested.items() if k not in self.doubtful}  # the ambiguity says why
        if untested:
            notes.append("not testable on this data: " + "; ".join(f"{k} ({v})" for k, v in untested.items()))
        return "; ".join(notes) or None


def _channels(series: Series, target_name: str) -> tuple[str, ...]:
    return (*series.names, target_name)


def _simulate(sim: Simulation, parts: Parts, channels) -> tuple[tuple[dict, dict], dict]:
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


def each_run(parts: Parts, train: Series, rule: Callable[[Series], object]):
    """A physics rule's objection: on the training part of a recording, or on each training run of a campaign,
    the first run's objection (a rule that simulates or counts must not read the runs glued together: a jump
    from one run's hall air to the next is no coolant switch, and two half standstills no standstill)."""
    if not parts.campaign:
        return rule(train)
    return next((why for run in parts.train if (why := rule(run))), None)


def _untestable(parts: Parts, train: Series, name: str) -> str | None:
    """Why the training part cannot show effect `name`: the training rows pooled must show it, and in a campaign
    one training run alone too (a daily cycle, two standstills, speeds on both sides of a threshold lie within
    one run; eight-hour runs glued together are no day)."""
    why = sufficiency.untestable(train, name)
    if why or not parts.campaign:
        return why
    reasons = [sufficiency.untestable(run, name) for run in parts.train]
    return None if not all(reasons) else f"no training run alone shows it ({reasons[0]})"


ONE_RUN_ONLY = ("an error of one sensor's reading is fitted on one run: each run of a campaign may start with its "
                "own offset, and a drift restarts nowhere")


def candidates(parts: Parts, present: Simulation, train: Series) -> tuple[list[tuple[str, int | None]], dict]:
    """Every named effect not in the model yet that the training part can show; per-sensor effects
    once per sensor. The others with the reason they were not tested."""
    found, skipped = [], {}
    series = parts.runs[0]
    for name in NAMES:
        if present.has(name):
            continue
        why = _untestable(parts, train, name) or (
            ONE_RUN_ONLY if parts.campaign and definition_of(name).part == "reading" else None)
        if why:
            skipped[name] = why
            continue
        if definition_of(name).per_sensor:
            found += [(name, i) for i in range(len(series.names))]
        else:
            found.append((name, None))
    return found, skipped


def describe(sim: Simulation, name: str, series: Series) -> dict:
    """The fitted parameters of one effect, in engineering units."""
    return definition_of(name).describe(sim, series)


def implausible(sim: Simulation, name: str, train: Series) -> str | None:
    """Why a fitted effect is not the named physics (a parameter at its search bound or with the
    wrong sign, of no size, or a slow structure that is a lag of the air), or None. Such a fit only
    soaks up a mismatch; naming it would be made up. Each effect's record holds its rule."""
    return definition_of(name).implausible(sim, train)


def too_small(sim: Simulation, name: str, parts: Parts, sigma: dict, target: str) -> str | None:
    """A sensor offset or drift, or a displacement term, that moves less than a few noise sigmas over
    the recording (the run it moves most in) only soaks up the refit."""
    definition = definition_of(name)
    series = parts.runs[0]
    if definition.part == "displacement":
        size = max(float(np.ptp(sim_.displacement_term(sim, run, name))) for run in parts.runs)
        noise = sigma[target]
        if size < MIN_DISPLACEMENT_TERM_SIGMAS * noise:
            return (f"it moves the displacement {size:.3g} over the recording, under {MIN_DISPLACEMENT_TERM_SIGMAS:g} times "
                    f"its noise ({noise:.3g})")
        return None
    if definition.part != "reading":
        return None
    i = sim.sensor_of(name)
    size = max(definition.reading_size_K(sim.sensors[i], run) for run in parts.runs)
    noise = sigma[series.names[i]]
    if size < MIN_SENSOR_ERROR_SIGMAS * noise:
        return f"{size:.3g} K over the recording, under {MIN_SENSOR_ERROR_SIGMAS:g} times the sensor noise ({noise:.3g} K)"
    return None


def follows_running(trial: Simulation, trial_score: Score, parts: Parts, channels, sigma: dict) -> str | None:
    """Why a fitted feed-axis heat is a lag of the spindle's running rather than of the feed, or
    None: refitted with the feed replaced by its mean while the spindle runs, the model must lose
    more than `BIC_MARGIN`. Otherwise the feed only marks when the machine runs, and the lag stands
    in for a slow structure or the air (which a training part under a day cannot test)."""
    running = [~sim_.stopped(run, trial.shared) for run in parts.runs]
    feed = np.concatenate([run.feed[:k][on[:k]] for run, k, on in zip(parts.runs, parts.train_rows, running)])
    level = float(np.mean(feed)) if len(feed) else 0.0
    plain = replace(parts, runs=tuple(replace(run, feed=np.where(on, level, 0.0)) for run, on in zip(parts.runs, running)))
    again = refit(plain.train, trial.effects, trial)
    as_running = score(again, _simulate(again, plain, channels)[1], sigma, parts.n_train)
    if as_running.bic < trial_score.bic + BIC_MARGIN:
        return ("a lag of the spindle's running fits as well (the feed rate replaced by its mean while running): "
                "it does not follow the feed")
    return None


def worsens_own_sensor(trial: Simulation, name: str, series: Series, before: Score, after: Score) -> str | None:
    """Why a fitted offset or drift is not an error of its sensor, or None: a real one makes that
    sensor's reading fit better, so one that leaves its held-out part off by more than before
    (by `MIN_EXCESS` of the noise variance) only bends the displacement through the sensor."""
    if definition_of(name).part != "reading":
        return None
    channel = series.names[trial.sensor_of(name)]
    was, now = before.held_out_by_channel.get(channel), after.held_out_by_channel.get(channel)
    if was is not None and now - was > MIN_EXCESS:
        return (f"it makes {channel}'s own held-out error worse ({was:.3g} -> {now:.3g} noise variances): "
                "not an error of that sensor")
    return None


def not_the_named_physics(trial: Simulation, name: str, parts: Parts, train: Series, channels, sigma: dict,
                          before: Score, after: Score, by_bic: bool) -> str | None:
    """Why the fitted effect is not the physics its name says, or None: implausible parameters, no
    size, an offset or drift that makes its own sensor worse, or (checked only when the BIC
    supports it, as it costs a refit) a feed lag that merely marks when the spindle runs."""
    why = (each_run(parts, train, lambda run: implausible(trial, name, run)) or too_small(trial, name, parts, sigma, channels[-1])
           or worsens_own_sensor(trial, name, parts.runs[0], before, after))
    if why is None and by_bic and definition_of(name).driven_by == "feed":
        why = follows_running(trial, after, parts, channels, sigma)
    return why


def window_rms(parts: Parts, w: Window, residual: dict) -> float:
    """RMS of a pooled residual inside window `w` (rows of its run)."""
    return rms(parts.unpool(residual[w.channel])[w.run][w.start:w.stop])


def _window_change(parts: Parts, windows: list[Window], before: dict, after: dict) -> list[dict]:
    return [{"channel": w.channel, **({"run": parts.labels[w.run]} if parts.campaign else {}), "start_row": w.start,
             "rms_before": window_rms(parts, w, before), "rms_after": window_rms(parts, w, after)} for w in windows]


def all_windows(sim: Simulation, residual: dict, sigma: dict, parts: Parts) -> list[Window]:
    """Windows of every run, found in its own time order. Each sensor settles by its own time constant; the
    target, fed by every sensor, by the slowest."""
    settling = [settling_s(p.tau_s) for p in sim.sensors]
    per_run = {c: parts.unpool(r) for c, r in residual.items()}
    return [replace(w, run=k) for (c, runs), settle in zip(per_run.items(), [*settling, max(settling)])
            for k, (r, run) in enumerate(zip(runs, parts.runs))  # sensors, then target
            for w in find_windows(c, r, sigma[c], run.dt, settle)]


def _extrapolated(window: Window, final: Score, parts: Parts) -> str | None:
    """A held-out window on a channel the training part fits within the noise: no refit on the
    training part can be judged by it, so it says the model extrapolates, not which effect is missing."""
    if window.start >= parts.train_rows[window.run] and final.train_by_channel[window.channel] - 1.0 < MIN_TRAIN_EXCESS:
        return (f"held out, on {window.channel}, which the training part fits within the noise (the model "
                "extrapolates there; the training part cannot tell which effect is missing)")
    return None


def _choose(passed: list[tuple]) -> tuple:
    """Among the candidates both judges support, the one the information criterion prefers: the
    training part is the larger and its evidence grows with the data, while a held-out gain can be
    cut by speeds the training part never separated (a gear threshold between two of them)."""
    return min(passed, key=lambda p: p[1].bic)


def _main_channel(before: Score, after: Score) -> str:
    """The channel whose training fit a candidate improves most (log-likelihood per channel)."""
    return max(before.rmse_train, key=lambda c: np.log(max(before.rmse_train[c], 1e-300) /
                                                       max(after.rmse_train[c], 1e-300)))


def _rivals(credible: list[tuple], best: tuple, before: Score) -> list[tuple]:
    """Other plausible effects that the BIC prefers or barely separates from its choice, gaining most on the
    same channel (slow structure and lagged ambient look alike when the temperatures follow the air): naming
    either would be a coin toss, whichever the held-out part prefers, so a rival need not pass the held-out
    judge. The same effect on another sensor is no rival, nor one that explains another channel (a heat
    the sensors' innovations show beside a lag the displacement shows: both may be missing, and the next
    round tests the other)."""
    best_gain = abs(best[1].bic - before.bic)
    channel = _main_channel(before, best[1])
    return [p for p in credible if p[5] != best[5] and p[1].bic - best[1].bic < AMBIGUOUS_BIC_SHARE * best_gain
            and _main_channel(before, p[1]) == channel]


def _label(p: tuple, series: Series) -> str:
    trial, name = p[0], p[5]
    sensor = trial.sensor_of(name)
    return name + (f" on {series.names[sensor]}" if sensor is not None else "")


def polish(sim: Simulation, sim_score: Score, parts: Parts, channels, sigma: dict) -> tuple[Simulation, Score]:
    """Refit with the same effects, from where the last fit stopped, while the BIC falls. Time
    constants, gear threshold, exponent, relay thresholds and standstill factors are searched with
    the others held, so one fit stops short of its optimum; without this the next candidate's
    refit would be credited with what refitting alone gains, and an effect of no size (a gear
    ratio of 1.00) named."""
    for _ in range(POLISH_ROUNDS):
        again = refit(parts.train, sim.effects, sim, polish=True)
        again_score = score(again, _simulate(again, parts, channels)[1], sigma, parts.n_train)
        if again_score.bic > sim_score.bic - MIN_POLISH_GAIN:
            break
        sim, sim_score = again, again_score
    return sim, sim_score


def _named(name: str, parts: Parts, current: Simulation, current_score, residual: dict, shown: dict,
           trial: Simulation, s, res: dict, res_shown: dict, excess_removed: float, windows0) -> dict:
    """An accepted effect's entry of the findings: its parameters and the evidence that named it, with
    what it changes in the held-out prediction of the target (um) and the share of the held-out squared
    error of the target it removes."""
    target, n_train = next(reversed(residual)), parts.n_train
    change = residual[target][n_train:] - res[target][n_train:]
    before, after = current_score.rmse_held_out[target], s.rmse_held_out[target]
    return {"name": name, "parameters": describe(trial, name, parts.joined()), "evidence": {
        "held_out_size_um": rms(change),
        "held_out_error_removed": 1.0 - (after / before) ** 2 if before else None,
        "bic_before": current_score.bic, "bic_after": s.bic, "delta_bic": s.bic - current_score.bic,
        "delta_bic_white": effective_delta_bic(residual, res, trial.parameter_count() - current.parameter_count(),
                                               n_train),
        "held_out_rmse_before": current_score.rmse_held_out, "held_out_rmse_after": s.rmse_held_out,
        "held_out_excess_removed": excess_removed,
        "held_out_evidence": held_out_evidence(residual, res, parts),
        "windows": _window_change(parts, windows0, shown, res_shown)}}


def _unsupported(credible: tuple, trials: list[Trial], parts: Parts, current: Simulation,
                 current_score: Score, residual: dict, shown: dict, windows0) -> dict:
    """A candidate the last round's training part supported and the held-out part did not, as a findings entry
    with the same evidence a named effect carries."""
    trial, s, res, (_, res_shown), index, name = credible
    entry = _named(name, parts, current, current_score, residual, shown, trial, s, res, res_shown,
                   trials[index].held_out_gain, windows0)
    gain = trials[index].held_out_gain
    if identified(current):
        needed = held_out_threshold(trial.parameter_count() - current.parameter_count(),
                                    int(np.count_nonzero(parts.seen_held_out())))
        why = (f"the held-out part does not support it: log-likelihood evidence {trials[index].held_out_evidence:+.1f} "
               f"on the held-out rows, {needed:.1f} needed")
    else:
        effect = (f"it removes {gain:.0%} of a channel's held-out excess above noise" if gain >= 0 else
                  f"it adds {-gain:.0%} to a channel's held-out excess above noise")
        why = f"the held-out part does not support it: {effect}, {HELD_OUT_SHARE:.0%} removed needed"
    return {**entry, "sensor": trials[index].sensor, "why_not_named": why}


def matters(effect: dict, misfit_um: float | None) -> str:
    """Whether a named effect is larger on the held-out part than the misfit the final model leaves there:
    one below it is real evidence but moves the compensation less than what no effect explains."""
    size = effect["evidence"]["held_out_size_um"]
    if size is None or misfit_um is None:
        return "not measured (no held-out rows)"
    return "above the misfit" if size >= misfit_um else "below the misfit"


def _try(parts: Parts, train: Series, channels, sigma: dict, current: Simulation, current_score,
         residual: dict, name: str, sensor: int | None):
    """One candidate fitted on top of `current` and judged: its row of the round's table; (fit, score,
    residual, simulated) when the information criteria credit it and no physics rule objects, else None;
    whether it also passed the held-out test; and, if it passed, the effect added before that it cannot
    be told from (names, why) or None."""
    n_train = parts.n_train
    trial = refit(parts.train, (*current.effects, (name, sensor)), current)
    sim_out, res = _simulate(trial, parts, channels)
    s = score(trial, res, sigma, n_train)
    gain = held_out_gain(current_score, s, n_train)
    delta = s.bic - current_score.bic
    effective = effective_delta_bic(residual, res, trial.parameter_count() - current.parameter_count(), n_train)
    by_bic = delta < -BIC_MARGIN and effective < -BIC_MARGIN
    why = (not_the_named_physics(trial, name, parts, train, channels, sigma, current_score, s, by_bic)
           or each_run(parts, train, lambda run: definition_of(name).after_fit(trial, run)))
    if why is None and delta < -BIC_MARGIN and not effective < -BIC_MARGIN:
        why = (f"the residual it leaves is still a slow misfit, not noise: counted over its effective rows "
               f"(lag-1 autocorrelation) the BIC changes by {effective:+.1f}, not below -{BIC_MARGIN:g}")
    evidence = held_out_evidence(residual, res, parts)
    if identified(current):
        needed = held_out_threshold(trial.parameter_count() - current.parameter_count(),
                                    int(np.count_nonzero(parts.seen_held_out())))
        judged = by_bic and evidence >= needed  # the likelihood over every channel, not the rows' plain sum
    else:
        judged = by_bic and gain >= HELD_OUT_SHARE and s.held_out < current_score.held_out
    alike = each_run(parts, train, lambda run: definition_of(name).alike_after(current, trial, run)) if judged else None
    row = Trial(name, None if sensor is None else train.names[sensor], float(delta), float(gain), False, why,
                evidence)
    return row, (trial, s, res, sim_out) if by_bic and why is None else None, judged, alike


@dataclass(frozen=True)
class Attempt:
    """A candidate tried elsewhere (diagnosis/remote.py): `_try`'s answer with the fitted model alone in place
    of its residuals, which `completed` rebuilds from it."""
    row: Trial
    trial: Simulation | None  # the fit, when the information criteria credit it and no physics rule objects
    judged: bool
    alike: tuple | None


def attempt(parts: Parts, target_name: str, current: Simulation, sigma: dict, name: str,
            sensor: int | None) -> Attempt:
    """`_try` from the current model alone: its residual and score recomputed as the search computed them."""
    channels = _channels(parts.runs[0], target_name)
    residual = _simulate(current, parts, channels)[1]
    current_score = score(current, residual, sigma, parts.n_train)
    row, fitted, judged, alike = _try(parts, parts.joined().head(parts.n_train), channels, sigma, current,
                                      current_score, residual, name, sensor)
    return Attempt(row, fitted[0] if fitted is not None else None, judged, alike)


def completed(found: Attempt, parts: Parts, target_name: str, sigma: dict) -> tuple:
    """`_try`'s answer from an attempt: the fitted model's residuals simulated again (the same bits)."""
    fitted = None
    if found.trial is not None:
        sim_out, res = _simulate(found.trial, parts, _channels(parts.runs[0], target_name))
        fitted = (found.trial, score(found.trial, res, sigma, parts.n_train), res, sim_out)
    return found.row, fitted, found.judged, found.alike


def _tried(parts: Parts, train: Series, channels, sigma: dict, current: Simulation, current_score: Score,
           residual: dict, options: list, say: Callable[[str], None], tries: Callable | None):
    """Each candidate's `_try` answer, in the order of `options`: here one after the other, or from `tries`."""
    if tries is not None:
        yield from tries(parts, channels[-1], current, sigma, options, say)
        return
    for k, (name, sensor) in enumerate(options, start=1):
        say(f"testing {name}" + (f" on {train.names[sensor]}" if sensor is not None else "") + f" ({k}/{len(options)})")
        yield _try(parts, train, channels, sigma, current, current_score, residual, name, sensor)


def diagnose(series: Series, n_train: int, target_name: str, baseline: Simulation | None = None,
             progress: Callable[[str], None] | None = None, structure_lag: bool = True) -> Diagnosis:
    """Search for missing effects in one recording whose first `n_train` rows train (`diagnose_runs`)."""
    return diagnose_runs(single(series, n_train), target_name, baseline, progress, structure_lag)


def diagnose_runs(parts: Parts, target_name: str, baseline: Simulation | None = None,
                  progress: Callable[[str], None] | None = None, structure_lag: bool = True,
                  tries: Callable | None = None) -> Diagnosis:
    """Search for missing effects over the runs, evidence pooled; `structure_lag` keeps the displacement's
    structure lag in the identified baseline (paper 000's regression on the temperatures alone without it).
    `tries(parts, target, current, sigma, options, say)` tries a round's candidates elsewhere (a cluster,
    diagnosis/remote.py) and answers as `_try` does for each, in order; without it they are tried here."""
    say = progress or (lambda message: None)
    series = parts.joined()  # names, noise, speed groups, ranges: nothing that depends on the dynamics
    n_train = parts.n_train
    channels = _channels(series, target_name)
    train = series.head(n_train)
    insufficient = sufficiency.recording_problem(parts.train)
    say("identifying the baseline (filter gains, standstill loads, the map by forward validation)")
    base = baseline or identify.fit(parts.train, structure_lag=structure_lag)[0]
    if identified(base) and not insufficient and parts.rows > n_train and not parts.seen_held_out().any():
        insufficient = ("no held-out row runs at a speed the training part ran (standing, or within its running "
                        "speeds): the held-out part can judge no effect, only how the model extrapolates")
    if identified(base) and not insufficient:  # judged by the training likelihood every candidate is refitted by
        base = replace(base, displacement=replace(base.displacement, ridge_weight=LEAST_SQUARES))
        base = (identified_effects.reidentify(parts.train, base) if baseline is not None
                else identified_effects.refit_map(parts.train, base))
    (simulated0, shown0), residual0 = _simulate(base, parts, channels)
    sigma = {c: noise_sigma(r) for c, r in residual0.items()}
    shown_sigma = {c: noise_sigma(r) for c, r in shown0.items()}  # the readings' own noise, open loop
    before = score(base, residual0, sigma, n_train)
    insufficient = insufficient or sufficiency.worse_than_none(before.rmse_held_out[channels[-1]],
                                                               sufficiency.no_compensation_rmse(parts))
    windows0 = all_windows(base, shown0, shown_sigma, parts)
    if windows0 and not insufficient and (baseline is None or identified(base)):  # no candidate credited with the refit
        base, before = polish(base, before, parts, channels, sigma)
        (simulated0, shown0), residual0 = _simulate(base, parts, channels)
        windows0 = all_windows(base, shown0, shown_sigma, parts)
    current, current_score, residual, simulated, shown = base, before, residual0, simulated0, shown0
    windows = windows0
    added, rounds, unsupported = [], [], []
    skipped = {}
    ambiguous: tuple[str, ...] = ()
    ambiguity = ""
    while windows and not insufficient:
        trials, passed, credible = [], [], []
        undecided = None
        options, skipped = candidates(parts, current, train)
        tried = _tried(parts, train, channels, sigma, current, current_score, residual, options,
                       lambda m, r=len(rounds) + 1: say(f"round {r}: {m}"), tries)
        for (name, _), (row, fitted, judged, alike) in zip(options, tried, strict=True):
            undecided = alike or undecided
            trials.append(row)
            if fitted is not None:
                credible.append((*fitted, len(trials) - 1, name))
                if judged:
                    passed.append(credible[-1])
        if undecided:  # an effect added before leaves what this one still fits
            ambiguous, ambiguity = undecided
            rounds.append(trials)
            break
        if not passed:
            rounds.append(trials)
            unsupported = [_unsupported(c, trials, parts, current, current_score, residual, shown, windows0)
                           for c in credible]
            break
        best = _choose(passed)
        rivals = _rivals(credible, best, current_score)
        alike = sufficiency.look_alike(train, best[5])
        if rivals or alike:
            ambiguous = tuple(_label(p, series) for p in (best, *rivals)) if rivals else (_label(best, series), alike[0])
            ambiguity = ("the training part supports the others as well or better: information criteria lower "
                         f"or within {AMBIGUOUS_BIC_SHARE:.0%} of the gain"
                         if rivals else alike[1])
            rounds.append(trials)
            break
        trial, s, res, sim_out, index, name = best
        trials[index] = Trial(**{**trials[index].__dict__, "accepted": True})
        rounds.append(trials)
        added.append(_named(name, parts, current, current_score, residual, shown, trial, s, res, sim_out[1],
                            trials[index].held_out_gain, windows0))
        current, current_score = polish(trial, s, parts, channels, sigma)
        (simulated, shown), residual = (sim_out, res) if current is trial else _simulate(current, parts, channels)
        windows = all_windows(current, shown, shown_sigma, parts)
    for effect in added:  # later refits move them: the parameters are those of the final model
        effect["parameters"] = describe(current, effect["name"], series)
        effect["matters"] = matters(effect, current_score.rmse_held_out[channels[-1]])
    for effect in unsupported:
        effect["matters"] = matters(effect, current_score.rmse_held_out[channels[-1]])
    if not windows0 or insufficient:
        skipped = candidates(parts, base, train)[1]
    unseen = {k: text for k, w in enumerate(windows)
              if (text := sufficiency.unseen_conditions(train, parts.runs[w.run], parts.train_rows[w.run], w)
                  or _extrapolated(w, current_score, parts))}
    return Diagnosis(channels, sigma, base, current, before, current_score, windows0, windows, shown0, shown,
                     simulated0, simulated, added, rounds, skipped, insufficient, unseen, ambiguous, ambiguity,
                     unsupported, parts)
