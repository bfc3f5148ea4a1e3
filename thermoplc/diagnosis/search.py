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
windows are still left, none of them is named either. The judges' thresholds are in
diagnosis/judges.py, the physics rules' in diagnosis/rules.py.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable, NamedTuple

import numpy as np

from thermoplc.diagnosis import sufficiency
from thermoplc.diagnosis.judges import (BIC_MARGIN, HELD_OUT_SHARE, MIN_TRAIN_EXCESS, Score, channels_of,
                                        effective_delta_bic, effective_rows, held_out_evidence, held_out_gain,
                                        held_out_threshold, identified, refit, score, simulate)
from thermoplc.diagnosis.parts import Parts, single
from thermoplc.diagnosis.rules import (candidates, describe, each_run, follows_running, implausible,
                                       not_the_named_physics, showing_runs, too_small, worsens_own_sensor)
from thermoplc.diagnosis.windows import Window, find_windows, noise_sigma, rms, settling_s
from thermoplc.physics import identified_effects, identify
from thermoplc.physics.effects import definition_of
from thermoplc.physics.fitted import Simulation
from thermoplc.physics.identified_effects import ROUTINES
from thermoplc.physics.primitives import Series

# the search's own steps; the judges and physics rules it applies are diagnosis/judges.py's and diagnosis/rules.py's
__all__ = ["Attempt", "Diagnosis", "Trial", "attempt", "completed", "diagnose", "diagnose_runs", "polish"]

AMBIGUOUS_BIC_SHARE = 0.02  # another effect within this share of the winner's BIC gain: no name
MIN_STAND_INS = 2  # this many effects added with windows still left: none is named
POLISH_ROUNDS = 3
# the diagnosis refits an identified model's map by least squares, the likelihood its criteria assume: a ridge
# weight held from forward validation biases the training fit, and a candidate would be credited with removing
# that bias (the cascade twin at one speed: weight 0.03 leaves 0.54 um on the training part, least squares 0.50,
# and a slow structure took the difference); on FL_THERMAL forward validation chooses 0 anyway
LEAST_SQUARES = 0.0
MIN_POLISH_GAIN = 1.0  # BIC; a refit that gains less has converged


@dataclass(frozen=True)
class Trial:
    name: str
    sensor: str | None
    delta_bic: float
    held_out_gain: float  # largest share of a channel's excess above noise removed on the held-out part
    accepted: bool
    rejected_because: str | None = None
    held_out_evidence: float = 0.0  # log-likelihood ratio on the held-out rows (effective rows), channels summed
    held_out_needed: float | None = None  # the evidence it needs there (an identified baseline; else a share is judged)


@dataclass(kw_only=True)  # 21 fields: built by name only
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
        return "; ".join(notes) or None  # what could not be tested is said once, under not_tested


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


class Credible(NamedTuple):
    """A candidate the information criteria credit and no physics rule refuses, with what it fitted."""
    trial: Simulation
    score: Score
    residual: dict
    simulated: tuple  # (simulated, residual as shown): simulate's output
    index: int  # its row in the round's trials
    name: str


def _choose(passed: list[Credible]) -> Credible:
    """Among the candidates both judges support, the one the information criterion prefers: the
    training part is the larger and its evidence grows with the data, while a held-out gain can be
    cut by speeds the training part never separated (a gear threshold between two of them)."""
    return min(passed, key=lambda p: p.score.bic)


def _main_channel(before: Score, after: Score) -> str:
    """The channel whose training fit a candidate improves most (log-likelihood per channel)."""
    return max(before.rmse_train, key=lambda c: np.log(max(before.rmse_train[c], 1e-300) /
                                                       max(after.rmse_train[c], 1e-300)))


def _rivals(credible: list[Credible], best: Credible, before: Score) -> list[Credible]:
    """Other plausible effects that the BIC prefers or barely separates from its choice, gaining most on the
    same channel (slow structure and lagged ambient look alike when the temperatures follow the air): naming
    either would be a coin toss, whichever the held-out part prefers, so a rival need not pass the held-out
    judge. The same effect on another sensor is no rival, nor one that explains another channel (a heat
    the sensors' innovations show beside a lag the displacement shows: both may be missing, and the next
    round tests the other)."""
    best_gain = abs(best.score.bic - before.bic)
    channel = _main_channel(before, best.score)
    return [p for p in credible if p.name != best.name
            and p.score.bic - best.score.bic < AMBIGUOUS_BIC_SHARE * best_gain
            and _main_channel(before, p.score) == channel]


def _label(p: Credible, series: Series) -> str:
    sensor = p.trial.sensor_of(p.name)
    return p.name + (f" on {series.names[sensor]}" if sensor is not None else "")


def polish(sim: Simulation, sim_score: Score, parts: Parts, channels, sigma: dict) -> tuple[Simulation, Score]:
    """Refit with the same effects, from where the last fit stopped, while the BIC falls. Time
    constants, gear threshold, exponent, relay thresholds and standstill factors are searched with
    the others held, so one fit stops short of its optimum; without this the next candidate's
    refit would be credited with what refitting alone gains, and an effect of no size (a gear
    ratio of 1.00) named."""
    for _ in range(POLISH_ROUNDS):
        again = refit(parts.train, sim.effects, sim, polish=True)
        again_score = score(again, simulate(again, parts, channels)[1], sigma, parts.n_train)
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
    shown_by = {"shown_by_runs": runs} if (runs := showing_runs(parts, name)) else {}
    return {"name": name, "parameters": describe(trial, name, parts.joined()), **shown_by, "evidence": {
        "held_out_size_um": rms(change),
        "held_out_error_removed": 1.0 - (after / before) ** 2 if before else None,
        "bic_before": current_score.bic, "bic_after": s.bic, "delta_bic": s.bic - current_score.bic,
        "delta_bic_white": effective_delta_bic(residual, res, trial.parameter_count() - current.parameter_count(),
                                               n_train),
        "held_out_rmse_before": current_score.rmse_held_out, "held_out_rmse_after": s.rmse_held_out,
        "held_out_excess_removed": excess_removed,
        "held_out_evidence": held_out_evidence(residual, res, parts),
        "windows": _window_change(parts, windows0, shown, res_shown)}}


def _unsupported(credible: Credible, trials: list[Trial], parts: Parts, current: Simulation,
                 current_score: Score, residual: dict, shown: dict, windows0) -> dict:
    """A candidate the last round's training part supported and the held-out part did not, as a findings entry
    with the same evidence a named effect carries."""
    trial, s, res, (_, res_shown), index, name = credible
    entry = _named(name, parts, current, current_score, residual, shown, trial, s, res, res_shown,
                   trials[index].held_out_gain, windows0)
    gain, needed = trials[index].held_out_gain, trials[index].held_out_needed
    if needed is not None:
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
    sim_out, res = simulate(trial, parts, channels)
    s = score(trial, res, sigma, n_train)
    gain = held_out_gain(current_score, s, n_train)
    delta = s.bic - current_score.bic
    effective = effective_delta_bic(residual, res, trial.parameter_count() - current.parameter_count(), n_train)
    by_bic = delta < -BIC_MARGIN and effective < -BIC_MARGIN
    why = (not_the_named_physics(trial, name, parts, train, channels, sigma, current_score, s, by_bic, current)
           or each_run(parts, train, lambda run: definition_of(name).after_fit(trial, run, ROUTINES)))
    if why is None and delta < -BIC_MARGIN and not effective < -BIC_MARGIN:
        why = (f"the residual it leaves is still a slow misfit, not noise: counted over its effective rows "
               f"(lag-1 autocorrelation) the BIC changes by {effective:+.1f}, not below -{BIC_MARGIN:g}")
    evidence, needed = held_out_evidence(residual, res, parts), None
    if identified(current):
        needed = held_out_threshold(trial.parameter_count() - current.parameter_count(),
                                    int(np.count_nonzero(parts.seen_held_out())))
        judged = by_bic and evidence >= needed  # the likelihood over every channel, not the rows' plain sum
    else:
        judged = by_bic and gain >= HELD_OUT_SHARE and s.held_out < current_score.held_out
    alike = (each_run(parts, train, lambda run: definition_of(name).alike_after(current, trial, run, ROUTINES))
             if judged else None)
    row = Trial(name, None if sensor is None else train.names[sensor], float(delta), float(gain), False, why,
                evidence, needed)
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
    channels = channels_of(parts.runs[0], target_name)
    residual = simulate(current, parts, channels)[1]
    current_score = score(current, residual, sigma, parts.n_train)
    row, fitted, judged, alike = _try(parts, parts.joined().head(parts.n_train), channels, sigma, current,
                                      current_score, residual, name, sensor)
    return Attempt(row, fitted[0] if fitted is not None else None, judged, alike)


def completed(found: Attempt, parts: Parts, target_name: str, sigma: dict) -> tuple:
    """`_try`'s answer from an attempt: the fitted model's residuals simulated again (the same bits)."""
    fitted = None
    if found.trial is not None:
        sim_out, res = simulate(found.trial, parts, channels_of(parts.runs[0], target_name))
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
    channels = channels_of(series, target_name)
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
    (simulated0, shown0), residual0 = simulate(base, parts, channels)
    sigma = {c: noise_sigma(r) for c, r in residual0.items()}
    shown_sigma = {c: noise_sigma(r) for c, r in shown0.items()}  # the readings' own noise, open loop
    before = score(base, residual0, sigma, n_train)
    insufficient = insufficient or sufficiency.worse_than_none(before.rmse_held_out[channels[-1]],
                                                               sufficiency.no_compensation_rmse(parts))
    windows0 = all_windows(base, shown0, shown_sigma, parts)
    if windows0 and not insufficient and (baseline is None or identified(base)):  # no candidate credited with the refit
        base, before = polish(base, before, parts, channels, sigma)
        (simulated0, shown0), residual0 = simulate(base, parts, channels)
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
                credible.append(Credible(*fitted, len(trials) - 1, name))
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
        alike = sufficiency.look_alike(train, best.name)
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
        (simulated, shown), residual = (sim_out, res) if current is trial else simulate(current, parts, channels)
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
    return Diagnosis(channels=channels, sigma=sigma, baseline=base, final=current, before=before,
                     after=current_score, windows_before=windows0, windows_after=windows, residual_before=shown0,
                     residual_after=shown, simulated_before=simulated0, simulated_after=simulated, added=added,
                     rounds=rounds, not_tested=skipped, insufficient=insufficient, unseen=unseen, ambiguous=ambiguous,
                     ambiguity=ambiguity, unsupported=unsupported, parts=parts)
