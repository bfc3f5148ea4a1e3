"""Fitting the probe fusion on held-out runs (`fit --probe`).

The static model's held-out predictions (each run predicted by a fit that never saw it, or the held-out
part of one recording) are replayed through the fusion with the probings a user would take: the probed
target's own measurements, or one every N calls on a target measured at every call. The gain of the offset,
whether a drift rate is added (the steady-state alpha-beta pair) and whether the offset decays between
probings are chosen on those runs. The gate is not chosen on them: clean held-out runs reward the widest gate,
which then takes a chip on the probe in full. It comes from what the drift did between two probings on those runs
(`gate_of`: the chosen fusion's innovations, gate open, each run's first probing left out since the block takes
that one anyway), or from the engineer (`fit --probe-gate-um`). The evidence is nested: each run's figures come
from the choice made on the other runs.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from itertools import product

import numpy as np

from thermoplc.base.binary32 import round_f32
from thermoplc.base.errors import UserError
from thermoplc.models.probing import Fusion, fuse, probings, rising

GAINS = (0.1, 0.2, 0.3, 0.5, 0.7, 0.85, 1.0)
HALF_LIVES_H = (None, 2.0, 8.0)  # None: the offset is held between probings
# the gate: GATE_RMS times the innovations' RMS, at least GATE_LARGEST times the largest the runs showed (the drift's
# own fastest move between two probings is taken, with room: at 1.5 x, mlr on FL_THERMAL's 6 h runs probed every
# 15 min lost 10 % held out, refusing real moves; at 2 x nothing changed), at least GATE_FLOOR_UM (a probe's
# repeatability); a real move beyond it costs one probing: the second in a row beyond the gate is taken
# (models/probing.REJOIN)
GATE_RMS = 4.0
GATE_LARGEST = 2.0
GATE_FLOOR_UM = 0.5
MARGIN = 0.03  # a choice beyond the plain one (the offset reset) must lower the objective by 3 %: a few
# dozen probings cannot tell smaller differences from chance (measured: the nested choice lost to the reset)
PLAIN = (1.0, False, None)  # gain, rate, half-life of the plain offset reset
SCHEDULES_MIN = (15, 30, 60, 120)
OPEN = 1.0e6  # gate, limit and clamp while the gains are chosen: nothing refused
REFITTED = "refitted for the change since the last probing"  # metrics.probing.static when the slopes were refitted


@dataclass(frozen=True)
class ProbeRun:
    """One held-out run: the static model's prediction, the measured target (NaN where not measured), and the
    rows whose errors count (the held-out part of a single recording)."""
    label: str
    static: np.ndarray
    target: np.ndarray
    scored: np.ndarray


@dataclass(frozen=True)
class Choice:
    gain: float
    rate: bool
    half_life_h: float | None


def _alpha_beta(alpha: float) -> float:
    """The rate gain of the steady-state Kalman filter of an offset with a random drift rate (Kalata)."""
    return 2 * (2 - alpha) - 4 * math.sqrt(1 - alpha)


def _fusion(choice: Choice, every: float, dt: float, gate: float = OPEN, limit: float = OPEN) -> Fusion:
    """The fusion of `choice` with `gate` (open while the gains are chosen), probings beyond +-`limit` refused."""
    rate_gain = _alpha_beta(choice.gain) / every if choice.rate else None
    decay = 0.5 ** (dt / (choice.half_life_h * 3600)) if choice.half_life_h else None
    return Fusion.of(choice.gain, min(gate, limit), limit, limit, rate_gain,
                     limit / max(every, 1.0) / 4 if choice.rate else None, decay)


def gate_of(innovations: np.ndarray, limit: float) -> tuple[float, str]:
    """The gate from what the drift did between two probings on the held-out runs, and the rule in words: GATE_RMS
    times the innovations' RMS, at least GATE_LARGEST times the largest of them and GATE_FLOOR_UM, at most the
    limit."""
    if not len(innovations):
        return limit, "the limit: no innovation after a run's first probing to judge by"
    rms, largest = float(np.sqrt(np.mean(innovations ** 2))), float(np.max(np.abs(innovations)))
    gate = min(max(GATE_RMS * rms, GATE_LARGEST * largest, GATE_FLOOR_UM), limit)
    return gate, (f"{GATE_RMS:g} x RMS {rms:.3g} um, at least {GATE_LARGEST:g} x largest {largest:.3g} um of "
                  f"{len(innovations)} held-out innovations (each run's first probing left out)")


def _replay(fusion: Fusion, run: ProbeRun, every: int | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(fused prediction, prediction just before each call's probing, the calls with a probing)."""
    value, new = probings(run.target, every)
    fused = fuse(fusion, run.static, value, new, "f64")
    return fused["fused"], fused["before"], rising(new)


@dataclass(frozen=True)
class Errors:
    """Sums of squares and counts over the scored rows: every measured row, and the probings (just before)."""
    sse: float
    rows: int
    sse_before: float
    probings: int

    def __add__(self, other: "Errors") -> "Errors":
        return Errors(self.sse + other.sse, self.rows + other.rows, self.sse_before + other.sse_before,
                      self.probings + other.probings)

    def rmse(self) -> float:
        return math.sqrt(self.sse / self.rows) if self.rows else math.nan

    def rmse_before(self) -> float:
        return math.sqrt(self.sse_before / self.probings) if self.probings else math.nan


def _errors(predicted: np.ndarray, before: np.ndarray, edges: np.ndarray, run: ProbeRun) -> Errors:
    measured = run.scored & np.isfinite(run.target)
    at = measured & edges
    e, b = (predicted - run.target)[measured], (before - run.target)[at]
    return Errors(float(e @ e), int(measured.sum()), float(b @ b), int(at.sum()))


def _objective(errors: Errors, full_rate: bool) -> float:
    """What the choice minimises: every row's error where the target is measured at every call, else the
    error just before each probing (the only rows a probed target measures besides the probings)."""
    return errors.sse if full_rate else errors.sse_before


def _schedule(runs: list[ProbeRun], minutes: float | None, dt: float) -> tuple[int | None, float]:
    """(every N calls or None for the target's own probings, calls between probings)."""
    if minutes is not None:
        every = max(int(round(minutes * 60 / dt)), 1)
        return every, float(every)
    gaps = [np.diff(np.flatnonzero(np.isfinite(r.target))) for r in runs]
    gaps = np.concatenate([g for g in gaps if len(g)]) if any(len(g) for g in gaps) else np.array([1])
    return None, float(np.median(gaps))


def _table(runs: list[ProbeRun], choices: list[Choice], every: int | None, interval: float,
           dt: float) -> dict[Choice, list[Errors]]:
    """Each candidate's errors on each run, gate open (the gate multiple is judged apart)."""
    out = {}
    for choice in choices:
        fusion = _fusion(choice, interval, dt)
        out[choice] = [_errors(*_replay(fusion, run, every), run) for run in runs]
    return out


def _best(table: dict[Choice, list[Errors]], runs: list[int], full_rate: bool) -> Choice:
    """The candidate with the lowest objective on `runs`, unless it beats the plain offset reset by less than
    the margin."""
    score = {c: _objective(sum((table[c][k] for k in runs), Errors(0, 0, 0, 0)), full_rate) for c in table}
    best = min(score, key=score.get)
    plain = next(c for c in table if (c.gain, c.rate, c.half_life_h) == PLAIN)
    return best if score[best] < (1 - MARGIN) * score[plain] else plain


def _innovations(choice: Choice, runs: list[ProbeRun], every, interval, dt) -> np.ndarray:
    """The chosen fusion's innovations over the runs (gate open), each run's first probing left out: the block
    takes that one whatever it reads (nothing learnt yet), and it holds the static model's start error, not the
    drift's move since a probing."""
    innovations = []
    for run in runs:
        _, before, edges = _replay(_fusion(choice, interval, dt), run, every)
        at = np.flatnonzero(edges & run.scored & np.isfinite(run.target))
        innovations.append((run.target - before)[at[1:]])
    return np.concatenate(innovations) if innovations else np.zeros(0)


def choose(runs: list[ProbeRun], minutes: float | None, dt: float, limit: float,
           held_out: ProbeRun | None = None, gate_um: float | None = None, plain_only: bool = False
           ) -> tuple[Fusion, dict]:
    """The fusion for `minutes` between probings (None: the target's own probings), chosen on every run, and
    the nested evidence: each run replayed with the fusion chosen on the other runs (with `held_out`, the one
    recording's part the choice never saw, replayed with the fusion chosen on `runs`, its training part). The
    gate is `gate_um` when given, else gate_of the innovations on the runs the fusion is chosen on. `plain_only`:
    the plain offset reset, only its gate chosen."""
    every, interval = _schedule(runs, minutes, dt)
    full_rate = every is not None
    candidates = [Choice(g, r, h) for g, r, h in product(GAINS, (False, True), HALF_LIVES_H)
                  if not plain_only or (g, r, h) == PLAIN]
    table = _table(runs, candidates, every, interval, dt)
    everyone = list(range(len(runs)))

    def finished(chosen: Choice, on: list[int]) -> tuple[Fusion, str]:
        gate, rule = (gate_um, "set by --probe-gate-um") if gate_um is not None else \
            gate_of(_innovations(chosen, [runs[k] for k in on], every, interval, dt), limit)
        return _fusion(chosen, interval, dt, gate, limit), rule

    final, rule = finished(_best(table, everyone, full_rate), everyone)
    if held_out is not None:  # one recording: chosen on its training part, judged on the part it never saw
        return final, _evidence([evaluate(final, held_out, every)], every, interval, full_rate, False, rule)
    per_run = []
    for k, run in enumerate(runs):
        others = [j for j in everyone if j != k] or everyone
        per_run.append(evaluate(finished(_best(table, others, full_rate), others)[0], run, every))
    return final, _evidence(per_run, every, interval, full_rate, len(runs) > 1, rule)


def _evidence(per_run: list[dict], every, interval: float, full_rate: bool, nested: bool, gate_rule: str) -> dict:
    return {"every_calls": every, "calls_between_probings": interval, "full_rate": full_rate, "runs": per_run,
            "nested": nested, "gate_rule": gate_rule}


def evaluate(fusion: Fusion, run: ProbeRun, every: int | None) -> dict:
    """One run's errors with `fusion`, with the plain offset reset (gain 1), the static model and none."""
    fused = _errors(*_replay(fusion, run, every), run)
    reset_prediction, reset_before, edges = _replay(Fusion.of(1.0, OPEN, OPEN, OPEN), run, every)
    reset = _errors(reset_prediction, reset_before, edges, run)
    zero = np.zeros_like(run.static)
    return {"run": run.label, "fused": fused, "reset": reset, "static": _errors(run.static, run.static, edges, run),
            "none": _errors(zero, zero, edges, run)}


def summarise(evidence: dict) -> dict:
    """Per run and pooled RMSE (all measured rows and just before each probing), for the model file."""
    methods = ("none", "static", "reset", "fused")
    every_row = evidence["full_rate"]  # a probed target is measured only at its probings

    def figures(errors: dict) -> dict:
        return {**{f"{m}_rmse_um": _finite(errors[m].rmse()) if every_row else None for m in methods},
                **{f"{m}_before_um": _finite(errors[m].rmse_before()) for m in methods},
                "probings": errors["fused"].probings}

    pooled = {m: sum((e[m] for e in evidence["runs"]), Errors(0, 0, 0, 0)) for m in methods}
    return {"every_calls": evidence["every_calls"], "calls_between_probings": evidence["calls_between_probings"],
            "full_rate": evidence["full_rate"], "nested": evidence["nested"], "pooled": figures(pooled),
            "runs": [{"run": entry["run"], **figures(entry)} for entry in evidence["runs"]]}


def _finite(x: float) -> float | None:
    return None if not math.isfinite(x) else round(x, 6)


def limit_of(runs: list[ProbeRun]) -> float:
    """The largest plausible probing: twice the largest measured target, at least 10 um, within the check."""
    largest = max((float(np.nanmax(np.abs(r.target))) for r in runs if np.isfinite(r.target).any()), default=0.0)
    if not math.isfinite(largest):
        raise UserError("the target has no finite measurement to fit the probe fusion on")
    return min(max(2 * largest, 10.0), 1e5)


def probe_runs(model, tables: list, predictions: dict) -> tuple[list[ProbeRun], ProbeRun | None]:
    """The runs the fusion is chosen on: each run's held-out static prediction (a fit on the other runs), or
    for one recording its training part, with its held-out part apart."""
    from thermoplc.recordings.campaign import run_labels
    from thermoplc.fitting.probe_refit import trained_calls
    from thermoplc.models.reference import model_inputs, predict
    column = model.target.column
    if predictions:
        labels = run_labels([t.path for t in tables])
        return [ProbeRun(label, np.asarray(predictions[t.path], float), t.column(column), np.ones(t.rows, bool))
                for label, t in zip(labels, tables)], None
    if len(tables) != 1:
        raise UserError("--probe on a campaign chooses the fusion on runs held out: give --folds K or --group-by")
    table = tables[0]
    static = np.asarray(predict(model, model_inputs(model, table), "f64")[model.target.name], float)
    trained = trained_calls(model)
    if trained >= table.rows:
        raise UserError("--probe chooses the fusion on rows the static fit never saw: give --train-until or "
                        "--train-rows with held-out rows after them, or --folds on a campaign")
    rows = np.arange(table.rows)
    label = run_labels([table.path])[0]
    return ([ProbeRun(f"{label} (training part)", static, table.column(column), rows < trained)],
            ProbeRun(f"{label} (held out)", static, table.column(column), rows >= trained))


def fit_probe(model, tables: list, predictions: dict, every: int | None, held: bool, gate_um: float | None = None):
    """`model` with the probe fusion chosen on held-out runs and its evidence in metrics.probing: the model's
    own schedule (the probed target's probings, or one every `every` calls), and on a target measured at every
    call the same for probings every 15, 30, 60 and 120 min. A linear kind's slopes are refitted for the change
    since the last probing (fitting/probe_refit.py) where that lowers the fused error on the held-out runs and the
    refitted static part alone still passes the acceptance gate (a block whose probings stop is a static block)."""
    from dataclasses import replace
    from thermoplc.models.probing import needs_schedule
    from thermoplc.recordings.campaign import run_labels
    refused = {run["run"] for run in model.metrics.get("refused_runs", [])}  # fitting/broken_runs.py
    tables = [t for t, label in zip(tables, run_labels([t.path for t in tables])) if label not in refused]
    runs, held_out = probe_runs(model, tables, predictions)
    full_rate = all(needs_schedule(r.target) for r in runs)
    if full_rate and every is None:
        raise UserError(f"--probe: the target {model.target.column!r} is measured at every call, so the data holds no "
                        f"probing schedule; give --probe-every N (a probing every N calls) to simulate one")
    if not full_rate and every is not None:
        raise UserError(f"--probe-every {every}: the target {model.target.column!r} is probed (empty between its "
                        f"measurements), and its measured rows are the probings; leave --probe-every out")
    dt = model.sample_period_s
    if not any(probings(r.target, every)[1].any() for r in runs):
        schedule = f"a probing every {every} calls" if every else "its own probings"
        raise UserError(f"--probe: no probing falls in the runs the fusion is chosen on ({schedule}; the longest run "
                        f"has {max(len(r.target) for r in runs)} calls); give a shorter --probe-every")
    limit = limit_of([*runs, *([held_out] if held_out else [])])
    plain = (runs, held_out)
    if gate_um is not None and gate_um > limit:
        raise UserError(f"--probe-gate-um {gate_um:g}: wider than the limit {limit:.4g} um (twice the largest drift "
                        f"measured), where every probing beyond is refused anyway; give at most {limit:.4g}")
    chosen, evidence = _fused(model, tables, plain, every, dt, limit, full_rate, gate_um)
    replaced = _worse_than_reset(evidence, full_rate) if evidence["nested"] else None  # one recording: its held-out
    # part is the evidence, not a choice
    if replaced:  # the fused block's nested evidence lost to the plain reset it holds as a candidate: the reset
        fusion, evidence = choose(runs, _minutes(every, dt), dt, limit, held_out, gate_um, True)
        chosen = Variant(model, runs, held_out, fusion, evidence)
    probing = {**summarise(evidence), "held": held,
               "chosen": {**_described(chosen.fusion, dt), "gate_rule": evidence["gate_rule"],
                          **({"replaced_by_reset": replaced} if replaced else {})},
               "static": REFITTED if chosen.model is not model else "as fitted"}
    if full_rate:  # the model's own schedule is among them more often than not: its evidence is not computed again
        calls = {minutes: max(int(round(minutes * 60 / dt)), 1) for minutes in SCHEDULES_MIN}
        found = {every: evidence}
        for n in calls.values():
            if n not in found:
                found[n] = _fused(model, tables, plain, n, dt, limit, True, gate_um)[1]
        probing["schedules"] = [{"minutes": m, **summarise(found[calls[m]])["pooled"]} for m in SCHEDULES_MIN]
    fusion = replace(chosen.fusion, min_calls=(float(m := min_calls(runs, held_out, every)), round_f32(m)))
    probing["chosen"]["flood_calls"] = m
    screening = {k: model.metrics[k] for k in ("refused_runs", "run_screening") if k in model.metrics}
    fused = replace(chosen.model, probe=fusion, metrics={**chosen.model.metrics, **screening, "probing": probing})
    return _offset_only(model, fused, tables, runs, held_out, every, dt, limit, gate_um, held) or fused


def _offset_only(model, fused, tables: list, runs: list[ProbeRun], held_out: ProbeRun | None, every: int | None,
                 dt: float, limit: float, gate_um: float | None, held: bool):
    """The offset-only block (fitting/offset_only.py) where the static part as fitted fails generate's rule and the
    fusion over 0 passes it; None otherwise."""
    from dataclasses import replace
    from thermoplc.fitting.acceptance import fails_to_compensate, problem
    from thermoplc.fitting.fit import evaluate
    from thermoplc.fitting.offset_only import OFFSET_ONLY, as_none, zero_static, zeroed
    from thermoplc.models.kinds import kind_of
    static_problem = fails_to_compensate(model)
    if static_problem is None or kind_of(model.kind).increments is None:
        return None
    fusion, evidence = choose([zero_static(r) for r in runs], _minutes(every, dt), dt, limit,
                              zero_static(held_out), gate_um)
    fusion = replace(fusion, min_calls=fused.probe.min_calls)
    probing = {**summarise(evidence), "held": held,
               "chosen": {**_described(fusion, dt), "gate_rule": evidence["gate_rule"],
                          "flood_calls": fused.metrics["probing"]["chosen"]["flood_calls"],
                          "offset_only": f"the static part fails generate's rule ({static_problem}): the block "
                                         f"predicts 0 and learns only from its probings"},
               "static": OFFSET_ONLY}
    zero = zeroed(model)
    batches = model.training.get("batches", [model.training])
    train = evaluate(zero, tables, [b["rows"] for b in batches])["train"] if len(batches) == len(tables) else {}
    metrics = {**as_none(fused.metrics), **({"train": train} if train else {}), "probing": probing}
    candidate = replace(zero, probe=fusion, metrics=metrics)
    return candidate if problem(candidate) is None else None


def _minutes(every: int | None, dt: float) -> float | None:
    """Minutes between probings of a probing every `every` calls; None for the target's own probings."""
    return every * dt / 60 if every else None


def _worse_than_reset(evidence: dict, full_rate: bool) -> str | None:
    """Why the chosen fusion gives way to the plain offset reset: its nested error over the runs (each run
    replayed with the fusion chosen on the others) above the reset's on the same runs; None when it is not."""
    fused = _objective(sum((run["fused"] for run in evidence["runs"]), Errors(0, 0, 0, 0)), full_rate)
    reset = _objective(sum((run["reset"] for run in evidence["runs"]), Errors(0, 0, 0, 0)), full_rate)
    if fused <= reset:
        return None
    where = "over every measured call" if full_rate else "just before each probing"
    return (f"the fusion chosen was {math.sqrt(fused / reset):.3g} x the plain offset reset's error {where} on "
            f"the held-out runs: the plain reset written")


def min_calls(runs: list[ProbeRun], held_out: ProbeRun | None, every: int | None) -> int:
    """Half the shortest gap between two probings of the schedule the fusion was fitted for (at least one call): a
    probing sooner than that after the last is a flooding probe, and none of the fitted runs' probings is one."""
    fitted = [*runs, *([held_out] if held_out else [])]
    gaps = [np.diff(np.flatnonzero(rising(probings(r.target, every)[1]))) for r in fitted]
    shortest = min((int(g.min()) for g in gaps if len(g)), default=2)
    return max(1, shortest // 2)


def _fused(model, tables: list, plain: tuple, every: int | None, dt: float, limit: float,
           full_rate: bool, gate_um: float | None = None) -> tuple["Variant", dict]:
    """The fusion for a probing every `every` calls (None: the target's own) on the static part as fitted and, for a
    linear kind, refitted for that schedule where its static part alone passes the acceptance gate (probings may
    stop); the better of the two by the margin, with the nested evidence."""
    from thermoplc.fitting.acceptance import problem
    from thermoplc.fitting.probe_refit import refitted
    minutes = _minutes(every, dt)
    variants = [Variant(model, *plain, *choose(plain[0], minutes, dt, limit, plain[1], gate_um))]
    refit = refitted(model, tables, every)
    if refit is not None and problem(refit.model) is None:
        runs, held_out = probe_runs(refit.model, tables, refit.predictions)
        variants.append(Variant(refit.model, runs, held_out, *choose(runs, minutes, dt, limit, held_out, gate_um)))
    return _static_part(variants, every, full_rate)


@dataclass(frozen=True)
class Variant:
    """A static part (as fitted, or refitted) with its held-out runs, its chosen fusion and the nested evidence."""
    model: object
    runs: list[ProbeRun]
    held_out: ProbeRun | None
    fusion: Fusion
    evidence: dict


def _static_part(variants: list[Variant], every: int | None, full_rate: bool) -> tuple[Variant, dict]:
    """The variant whose fused objective is lower by the margin than the static part as fitted, and the nested
    evidence: each campaign run's fused figures from the variant chosen on the other runs, one recording's
    held-out part from the variant chosen on its training part. The static and reset figures stay those of the
    static part as fitted: the block without --probe, and the plain offset reset over it."""
    def pick(score) -> Variant:
        best = min(variants, key=score)
        return best if score(best) < (1 - MARGIN) * score(variants[0]) else variants[0]

    def beside_plain(k: int, variant: Variant) -> dict:
        return {**variant.evidence["runs"][k], **{m: variants[0].evidence["runs"][k][m] for m in ("static", "reset")}}

    if variants[0].held_out is not None:  # one recording: judged on its training part, in sample for both
        chosen = pick(lambda v: _objective(evaluate(v.fusion, v.runs[0], every)["fused"], full_rate))
        return chosen, {**chosen.evidence, "runs": [beside_plain(0, chosen)]}
    fused = lambda v, on: _objective(sum((v.evidence["runs"][k]["fused"] for k in on), Errors(0, 0, 0, 0)), full_rate)
    everyone = range(len(variants[0].runs))
    per_run = [beside_plain(k, pick(lambda v: fused(v, [j for j in everyone if j != k] or everyone))) for k in everyone]
    chosen = pick(lambda v: fused(v, everyone))
    return chosen, {**variants[0].evidence, "runs": per_run, "gate_rule": chosen.evidence["gate_rule"]}


def _described(fusion: Fusion, dt: float) -> dict:
    """The chosen fusion in engineering words, for the summary and the report."""
    decay = fusion.value("decay", "f64") if fusion.decay else None
    return {"gain": fusion.value("gain", "f64"), "rate": fusion.has_rate,
            "rate_gain_per_call": fusion.value("rate_gain", "f64") if fusion.has_rate else None,
            "half_life_h": round(dt * math.log(0.5) / math.log(decay) / 3600, 6) if decay else None,
            "gate_um": fusion.value("gate_um", "f64"), "limit_um": fusion.value("limit_um", "f64")}
