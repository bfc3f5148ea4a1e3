"""`fit --model auto`'s console: the candidates thermoplc/fit_pipeline.py ranked, each with the cost of its block on
the PLC."""
from __future__ import annotations

AUTO_TOLERANCE = 0.1  # a cheaper model within this share of the best held-out RMSE is named beside it


def print_ranking(fitted, request, probing, campaign: bool) -> None:
    """`fit --model auto`'s ranking (thermoplc/fit_pipeline.py) with each candidate's PLC cost, the cheapest model
    within AUTO_TOLERANCE of the best and how to fit it, and the one written."""
    from thermoplc.fitting.auto import candidates_of
    from thermoplc.models.kinds import kind_of
    ranked, cost = fitted.ranked, fitted.operations
    fitted_ = [(k, c) for k, c in enumerate(ranked) if c.model is not None]
    none = fitted_[0][1].model.metrics["held_out"].get("zero_rmse_um")
    chose = any("sensor_choice" in c.model.fit for _, c in fitted_)  # each kind chose its own sensors in the folds
    print(f"auto: {len(ranked)} candidates ranked by held-out RMSE" + (" with their probings (fused)" if probing else "")
          + (f" (no compensation {none:.3f} um)" if none is not None else "")
          + (f", {fitted_[0][1].model.metrics['held_out']['protocol']}" if campaign else ""))
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
              f"{cost[k - 1]:>10}" + (f"{c.rmse:>10.3f}" if probing else "")
              + (f"  generate refuses: {c.not_accepted}" if c.not_accepted else ""))
    best = fitted_[0][1]
    cheap_k, cheaper = min(((k, c) for k, c in fitted_ if c.rmse <= (1 + AUTO_TOLERANCE) * best.rmse and
                            (c.not_accepted is None) == (best.not_accepted is None)), key=lambda kc: cost[kc[0]])
    if cheaper is not best:
        kind = kind_of(cheaper.kind)
        again = (f"--temps {','.join(candidates_of(kind, request))} --choose-sensors {kind.auto_sensors}"
                 if "sensor_choice" in cheaper.model.fit else f"--temps {cheaper.label}") + (" --probe" if probing else "") \
            + (f" --probe-every {probing.every}" if probing and probing.every else "")
        print(f"  cheapest within {AUTO_TOLERANCE:.0%} of the best: {cheaper.kind} on {cheaper.label}, "
              f"{cheaper.rmse:.3f} um, {cost[cheap_k]} operations per call (fit it with --model {cheaper.kind} "
              f"{again})")
    print(f"  writing the best: {best.kind} on {best.label}")
