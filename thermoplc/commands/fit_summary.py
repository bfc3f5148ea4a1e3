"""What `thermoplc fit` prints about the model it wrote: the errors on the rows it was fitted on and on
the rows it never saw, beside compensating nothing."""
from __future__ import annotations

from thermoplc.base.identifiers import renaming_note
from thermoplc.fitting.acceptance import refusal
from thermoplc.fitting.probe_fit import REFITTED
from thermoplc.models.plausibility import GATE_FLOOR_K, MARGIN, SWING_S


def _runs_named(batches: list[dict]) -> str:
    """The runs by file name; a campaign of many by its count, first and last."""
    if len(batches) <= 4:
        return ", ".join(t["file"] for t in batches)
    return f"{len(batches)} runs ({batches[0]['file']} .. {batches[-1]['file']})"


def format_fit(model, campaign=None) -> str:
    """The errors of a fitted model: training, held out (each fold, each run with cross-validation over
    runs), float32 vs float64; with a probed target, how many measurements each error used."""
    m = model.metrics
    batches = model.training.get("batches", [model.training])
    probed = "calls" in m["train"] or "calls" in m["held_out"]
    measured = lambda section: (f" ({section['rows']} probings of {section['calls']} calls)"
                                if "calls" in section else "")
    part = (f"until {batches[0]['until_s']:g} s" if len(batches) == 1 else
            "each run whole" if "cross_validation" in m else f"until {batches[0]['until_s']:g} s in each run")
    lines = [f"fitted {model.kind} on {_runs_named(batches)}: {m['train']['rows']} training rows"
             f"{measured(m['train'])} ({part}), "
             f"{m['held_out']['rows']} held out" + (" in cross-validation" if "cross_validation" in m else "")
             + measured(m["held_out"]),
             f"  {'':<22}{'RMSE um':>10}{'max |residual| um':>20}"]
    if "sensor_choice" in model.fit:
        lines.insert(1, format_choice(model.fit["sensor_choice"], m.get("cross_validation")))
    if probed:
        lines.insert(1, "  probed target: errors on the measured rows only, the temperatures at every call")
    if model.resample is not None:
        held = "".join(f", {c!r} its last value" for c in model.resample.hold)
        probings = ", each probing at the call that follows it" if probed else ""
        lines.insert(1, f"  resampled onto a cycle of {model.resample.period_s:g} s (temperatures linear{held}{probings})")
    held_label = "prediction (all folds)" if "cross_validation" in m else "prediction (held out)"
    for label, key in (("fit (training)", "train"), (held_label, "held_out")):
        if m[key]["rows"]:
            lines.append(f"  {label:<22}{m[key]['rmse_um']:>10.3f}{m[key]['max_abs_um']:>20.3f}")
    start = m.get("start") or {}
    if start.get("runs"):
        lines.append(f"  {'start (first call)':<22}{'':>10}{start['max_abs_um']:>20.3f}   "
                     f"worst of {start['runs']} run start{'s' if start['runs'] != 1 else ''}")
    if "cross_validation" in m:
        lines += _format_folds(m)
    if m.get("runs") and len(m["runs"]) != len(m["cross_validation"]):
        lines += _format_runs(m, campaign)
    lines += format_screening(m)
    if "probing" in m:
        lines += format_probing(m["probing"])
    lines.append(f"  float32 block vs float64 model: max {m['float32_vs_float64_max_um']:.3g} um")
    if model.plausibility is not None:
        relations = model.plausibility.relations
        if gates := ", ".join(f"{r.sensor} {r.gate_K[0]:g} K" for r in relations if r.gate_K is not None):
            lines.append(f"  SensorsDisagree when a temperature is further from what the others say than: {gates} "
                         f"({MARGIN:g} x the largest difference recorded, at least {GATE_FLOOR_K:g} K)")
        if model.plausibility.swings:
            swings = ", ".join(f"{r.sensor} {r.swing_K[0]:g} K" for r in relations)
            alone = [r.sensor for r in relations if not r.slopes]
            lines.append(f"  {'... or when that difference' if gates else 'SensorsDisagree when a reading'} leaves its "
                         f"{SWING_S / 60:g}-min mean by more than: {swings} ({MARGIN:g} x the largest swing recorded, "
                         f"at least {GATE_FLOOR_K:g} K)"
                         + (f"; {', '.join(alone)}: its reading against its own mean (no other machine temperature "
                            f"to tell it by; an ambient drives the machine through hours of lag)" if alone else ""))
    lines += [f"  {note}" for s in (*model.inputs, model.target) if (note := renaming_note(s.column, s.name))]
    if "one_step_rmse_K" in model.fit:  # an identified model: how far its temperatures are from the readings
        names = [s.name for s in model.signals("temperature")]
        each = lambda key: ", ".join(f"{n} {v:.3f}" for n, v in zip(names, model.fit[key]))
        gains = ", ".join(f"{n} {model.coef(f'KF_{i}', 'f64'):.3g}" if f"KF_{i}" in model.coefficients else f"{n} 0"
                          for i, n in enumerate(names, start=1))
        lines += [f"  temperatures (training), RMSE K: filtered one step ahead: {each('one_step_rmse_K')}; "
                  f"open loop: {each('open_loop_rmse_K')}",
                  f"  filter gain (share of the reading taken each call): {gains}"]
    return "\n".join(lines)


def format_choice(choice: dict, folds: list | None) -> str:
    """The sensors the fit chose from the candidates, the best set of each size with its error, and how many
    folds chose the same set."""
    sizes = "; ".join(f"{','.join(s['sensors'])} {s['rmse_um']:.2f}" for s in choice["best_of_each_size"])
    text = (f"  sensors chosen: {', '.join(choice['chosen'])} of {len(choice['candidates'])} candidates "
            f"(ridge error {choice['by']}, best set of each size, um: {sizes})")
    if folds:
        same = sum(set(f.get("sensors", ())) == set(choice["chosen"]) for f in folds)
        text += f"; {same} of {len(folds)} folds chose the same set on their own training rows"
    return text


METHODS = ("none", "static", "reset", "fused")


def format_probing(p: dict) -> list[str]:
    """The probe fusion chosen and its held-out evidence: each run and all runs, RMSE over every measured call
    (a target measured at every call) and just before each probing, beside no compensation, the static block
    and the plain offset reset (the last probing's residual, gain 1)."""
    c = p["chosen"]
    state = ", ".join([f"gain {c['gain']:g}", *(["drift rate"] if c["rate"] else []),
                       f"offset half-life {c['half_life_h']:g} h" if c["half_life_h"] else "offset held",
                       f"gate {c['gate_um']:.3g} um"])
    schedule = (f"a probing every {p['every_calls']} calls" if p["every_calls"] else
                f"the target's own probings (every {p['calls_between_probings']:g} calls, median)")
    how = ("each run replayed with the fusion chosen on the other runs" if p["nested"] else
           "chosen on the training part, replayed on the held-out part")
    groups = (("rmse", "RMSE all calls"), ("before", "before a probing")) if p["full_rate"] else (
        ("before", "RMSE before a probing, um"),)
    head = "".join(f"  {title:^30}" for _, title in groups)
    lines = [f"  probe fusion ({state}), {schedule}: {how}",
             *([f"  REPLACED: {c['replaced_by_reset']}"] if c.get("replaced_by_reset") else []),
             *([f"  OFFSET-ONLY: {c['offset_only']}"] if c.get("offset_only") else []),
             *([f"  static part refitted for the change since the last probing (it lowered the fused error where the fusion was chosen); "
                f"'static' and 'reset' are the block as fitted without --probe"] if p.get("static") == REFITTED else []),
             f"  {'run':<26}{'probings':>9}{head}".rstrip(),
             (f"  {'':<35}" + "".join("  " + "".join(f"{name:>7}" for name in METHODS) + "  " for _ in groups)).rstrip()]
    show = lambda v: f"{v:>7.3f}" if v is not None else f"{'-':>7}"
    for row in [*p["runs"], {**p["pooled"], "run": "all runs"}]:
        lines.append((f"  {row['run'][:25]:<26}{row['probings']:>9}" + "".join(
            "  " + "".join(show(row[f"{key}_{which}_um"]) for key in METHODS) + "  " for which, _ in groups)).rstrip())
    for schedule in p.get("schedules", ()):
        lines.append(f"  probings every {schedule['minutes']:>3} min, all runs: RMSE all calls fused "
                     f"{show(schedule['fused_rmse_um']).strip()} um (static {show(schedule['static_rmse_um']).strip()}, "
                     f"reset {show(schedule['reset_rmse_um']).strip()}); before a probing fused "
                     f"{show(schedule['fused_before_um']).strip()} um")
    return lines


def _format_folds(m: dict) -> list[str]:
    """Each fold's held-out errors beside no compensation, and the pooled line with the spread."""
    held = m["held_out"]
    lines = [f"  {held['protocol']}: each fold predicted by a fit that never saw it",
             f"  {'fold (rows predicted)':<26}{'fitted rows':>12}{'RMSE um':>10}{'max um':>9}{'none RMSE um':>14}{'none max um':>13}"]
    lines += [f"  {f['label']:<26}{f['train_rows']:>12}{f['rmse']:>10.3f}{f['max_abs']:>9.3f}{f['zero_rmse']:>14.3f}"
              f"{f['zero_max_abs']:>13.3f}" for f in m["cross_validation"]]
    low, high = held["fold_rmse_um"]
    pooled = f"all folds ({held['rows']} rows)"
    lines.append(f"  {pooled:<26}{'':>12}{held['rmse_um']:>10.3f}{held['max_abs_um']:>9.3f}"
                 f"{held['zero_rmse_um']:>14.3f}{held['zero_max_abs_um']:>13.3f}")
    lines.append(f"  spread: fold RMSE {low:.3f} to {high:.3f} um")
    if held.get("ridge_rmse_um"):
        lines.append(f"  a ridge on the same temperatures' rises, held out alike: {held['ridge_rmse_um']:.3f} um; this "
                     f"model {held['rmse_um'] / held['ridge_rmse_um']:.2f} x that (fitting/ridge_floor.py)")
    if "block_rmse_um" in held:
        flagged = held["block_flagged_runs"]
        kept = f"the {len(m['runs'])} runs kept for training" if m.get("refused_runs") else f"{len(m['runs'])} runs"
        faults = (f"; a fault or disagreement raised on {len(flagged)} of {kept}: {', '.join(flagged)}"
                  if flagged else f"; no fault raised on {kept}")
        lines.append(f"  as the PLC runs each fold's block (guards, fault hold and limits from its training runs): "
                     f"{held['block_rmse_um']:.3f} um RMSE, max {held['block_max_abs_um']:.3f} um{faults}")
    return lines


def _format_runs(m: dict, campaign) -> list[str]:
    """Each held-out run beside no compensation, when the folds hold several runs (grouped folds)."""
    lines = [f"  {'run (fold)':<34}{'rows':>8}{'RMSE um':>10}{'max um':>9}{'none RMSE um':>14}{'none max um':>13}"]
    lines += [f"  {r['run'] + ' (' + r['fold'] + ')':<34}{r['rows']:>8}{r['rmse']:>10.3f}{r['max_abs']:>9.3f}"
              f"{r['zero_rmse']:>14.3f}{r['zero_max_abs']:>13.3f}" for r in m["runs"]]
    return lines


def format_screening(m: dict) -> list[str]:
    """The runs refused for training (fitting/broken_runs.py), each with why and its error by the model written, the
    held-out figure with them; the runs whose sensors disagree but were kept."""
    screening = m.get("run_screening")
    if screening is None:
        return []
    lines = []
    for run in m.get("refused_runs", []):
        lines.append(f"  REFUSED for training: {run['run']}: {_disagreement(run)}: a broken sensor, or an effect the "
                     f"other runs did not have; {_target(run)}; the model written predicts it {run['rmse']:.3f} um "
                     f"RMSE (none {run['zero_rmse']:.3f}){_as_the_block_runs(run)}")
    if "with_refused_runs" in m["held_out"]:
        with_them = m["held_out"]["with_refused_runs"]
        guarded = (f"; every block's guards acting: {with_them['block_rmse_um']:.3f} um"
                   if with_them.get("block_rmse_um") is not None else "")
        lines.append(f"  held out with the refused runs: {with_them['rmse_um']:.3f} um RMSE, max {with_them['max_abs_um']:.3f} "
                     f"um over {with_them['rows']} rows (without: {m['held_out']['rmse_um']:.3f}{guarded}); "
                     f"--keep-every-run trains on them")
    for run in screening["named"]:
        lines.append(f"  kept for training: {run['run']}: {_disagreement(run)}, but {_target(run)}")
    return lines


def _disagreement(run: dict) -> str:
    return (f"{run['sensor']} {run['difference_K']:.3g} K from what the other temperatures say (gate "
            f"{run['gate_K']:.3g} K from the other runs)")


def _target(run: dict) -> str:
    return (f"a ridge on the other runs predicts it {run['ratio']:.2g} x their median error, and they are "
            f"{run.get('influence', 1.0):.2g} x worse with it among them")


def _as_the_block_runs(run: dict) -> str:
    """A refused run's errors with the block's guards acting (fitting/crossval.guarded_errors)."""
    if run.get("block_rmse") is None:
        return ""
    raised = (f"a fault bit or SensorsDisagree from call {run['block_flagged_from_call']}"
              if run.get("block_flagged_from_call") else "no fault bit raised")
    return f"; its block, guards acting, {run['block_rmse']:.3f} um ({raised})"


def fit_document(model, path: str) -> dict:
    """`fit --json`: the model file written, its signals and the errors format_fit prints."""
    signal = lambda s: {"name": s.name, "column": s.column, "role": s.role, "unit": s.unit}
    return {"format": "thermoplc-fit", "version": 1, "model_file": path, "kind": model.kind,
            "fingerprint": model.fingerprint(), "block_name": model.block_name,
            "inputs": [signal(s) for s in model.inputs], "target": signal(model.target),
            "metrics": model.metrics, "generate_refuses": refusal(model),
            **({"sensor_choice": model.fit["sensor_choice"]} if "sensor_choice" in model.fit else {})}
