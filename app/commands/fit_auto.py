"""`fit --model auto`: the candidates of fitting/auto.py ranked, each with the cost of its block on the PLC."""
from __future__ import annotations

from typing import Callable

from thermoplc.base.errors import UserError
from thermoplc.commands.terminal import end_progress

AUTO_TOLERANCE = 0.1  # a cheaper model within this share of the best held-out RMSE is named beside it


def fit_auto(tables: list, request, folds: int | None, time_column: str,
             progress: Callable[[str], None] | None, groups: dict | None = None, remote=None, probing=None):
    """The ranking printed with each candidate's PLC cost; the best model returned. With `probing`
    (fitting/auto.Probing) each candidate is fused and ranked by its held-out error with its probings."""
    from thermoplc.generator.lower import lower_model
    from thermoplc.generator.stats import block_stats
    from thermoplc.fitting.auto import candidates_of, rank
    from thermoplc.models.kinds import kind_of
    ranked = rank(tables, request, folds, time_column, say=progress, groups=groups, remote=remote, probing=probing)
    end_progress()
    fitted = [c for c in ranked if c.model is not None]
    if not fitted:
        raise UserError("--model auto: no kind could be fitted: " + "; ".join(f"{c.kind} ({c.refused})" for c in ranked))
    cost = {id(c): block_stats(lower_model(c.model))["arithmetic_per_call"] for c in fitted}
    none = fitted[0].model.metrics["held_out"].get("zero_rmse_um")
    campaign = len(tables) > 1 or groups is not None
    chose = any("sensor_choice" in c.model.fit for c in fitted)  # each kind chose its own sensors in the folds
    print(f"auto: {len(ranked)} candidates ranked by held-out RMSE" + (" with their probings (fused)" if probing else "")
          + (f" (no compensation {none:.3f} um)" if none is not None else "")
          + (f", {fitted[0].model.metrics['held_out']['protocol']}" if campaign else ""))
    if chose:
        choosing = lambda c: not c.options and (c.model is None or "sensor_choice" in c.model.fit)
        most = ", ".join(f"{c.kind} {kind_of(c.kind).auto_sensors}" for c in ranked if choosing(c))
        every = " and ".join(c.kind + c.given for c in ranked if not choosing(c))
        print(f"  each kind chose its sensors among --temps itself, again inside every fold (at most: {most}): the "
              f"error ranked is the written model's held-out evidence (the sensors shown: chosen on every run)"
              + (f"; {every} also on every sensor, ridge-shrunk" if every else ""))
    print(f"  {'rank':<6}{'kind':<8}{'sensors':<32}{'RMSE um':>9}{'max um':>9}{'ops/call':>10}"
          + (f"{'fused um':>10}" if probing else ""))
    for k, c in enumerate(ranked, start=1):
        if c.model is None:
            print(f"  {'-':<6}{c.kind:<8}{c.label:<32}  refused: {c.refused}")
            continue
        held = c.model.metrics["held_out"]
        print(f"  {k:<6}{c.kind:<8}{c.label:<32}{held['rmse_um']:>9.3f}{held['max_abs_um']:>9.3f}"
              f"{cost[id(c)]:>10}" + (f"{c.rmse:>10.3f}" if probing else "")
              + (f"  generate refuses: {c.not_accepted}" if c.not_accepted else ""))
    best = fitted[0]
    cheaper = min((c for c in fitted if c.rmse <= (1 + AUTO_TOLERANCE) * best.rmse and
                   (c.not_accepted is None) == (best.not_accepted is None)), key=lambda c: cost[id(c)])
    if cheaper is not best:
        kind = kind_of(cheaper.kind)
        again = (f"--temps {','.join(candidates_of(kind, request))} --choose-sensors {kind.auto_sensors}"
                 if "sensor_choice" in cheaper.model.fit else f"--temps {cheaper.label}") + (" --probe" if probing else "") \
            + (f" --probe-every {probing.every}" if probing and probing.every else "")
        print(f"  cheapest within {AUTO_TOLERANCE:.0%} of the best: {cheaper.kind} on {cheaper.label}, "
              f"{cheaper.rmse:.3f} um, {cost[id(cheaper)]} operations per call (fit it with --model {cheaper.kind} "
              f"{again})")
    print(f"  writing the best: {best.kind} on {best.label}")
    from thermoplc.models.modelfile import Model
    ranking = [{"kind": c.kind, "sensors": list(c.sensors), **_options(c), "refused": c.refused} if c.model is None else
               {"kind": c.kind, "sensors": list(c.sensors), **_options(c), "rmse_um": c.model.metrics["held_out"]["rmse_um"],
                "max_abs_um": c.model.metrics["held_out"]["max_abs_um"], "operations_per_call": cost[id(c)],
                "generate_refuses": c.not_accepted, **({"fused_rmse_um": c.rmse} if probing else {})} for c in ranked]
    model = best.model
    return Model(**{**model.__dict__, "metrics": {**model.metrics, "auto_ranking": ranking}})


def _options(candidate) -> dict:
    """A ranking entry's options beside the request's (`--parents ridge`), where it has any."""
    return {"options": {flag: value for flag, value in candidate.options}} if candidate.options else {}
