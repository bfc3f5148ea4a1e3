"""A recording as the block sees it in a replay against its model: the model's targets may be empty between
measurements, and raw logger data are taken onto the block's cycle by the rule the model file records
(`fit --resample`) or `verify --resample` names (recordings/resample.py), before anything is compared."""
from __future__ import annotations

from dataclasses import replace

from thermoplc.base.errors import UserError
from thermoplc.contract.outputs import (CONTROL_INPUT_START, ENABLE_INPUT, PROBE_INPUTS, PROBE_NEW_INPUT, PROBE_VALUE_INPUT,
                                       RESET_INPUT)
from thermoplc.models.model import Model
from thermoplc.recordings.reading import Reading
from thermoplc.recordings.resample import Resampling, resample
from thermoplc.recordings.table import Table, read_table
from thermoplc.verifier.replays.control import control_column, control_inputs
from thermoplc.verifier.replays.mapping import known_overrides
from thermoplc.verifier.engines.typed import cells_as


def model_targets(model: Model) -> tuple[str, ...]:
    """The recording's columns that may be empty between measurements: those the model was fitted to (a probed
    target; a replay never reads them) and a fused block's ProbeValue (a probing cycle that gave nothing)."""
    probe = (PROBE_VALUE_INPUT,) if model.probe is not None else ()
    return (model.target.column, *(t["column"] for t in model.settings.get("targets", [])), *probe)


def resampling_for(model: Model, period_s: float | None) -> Resampling | None:
    """The rule a replay applies: the model file's, or `--resample` for a model fitted on data resampled before
    (its speed held at its last value); a period other than the block's cycle is refused."""
    if period_s is None:
        return model.resample
    if abs(period_s - model.sample_period_s) > 1e-9 * model.sample_period_s:
        raise UserError(f"--resample {period_s:g}: the block runs every {model.sample_period_s:g} s (sample_period_s of "
                        f"the model file); give --resample {model.sample_period_s:g}")
    return model.resample or Resampling.holding(period_s, tuple(s.column for s in model.signals("speed")))


def read_recording(path: str, model: Model, progress=None, reading: Reading | None = None,
                   period_s: float | None = None, overrides: dict | None = None, model_path: str = "model file"
                   ) -> Table:
    """The recording `path` read for a replay of `model`'s block, on the block's cycle: the speed (and feed) held
    under the columns they are read from (`--inputs` included), Enable and ProbeValue held, Reset and ProbeNew
    kept as pulses at the call that follows them. The text is read as `reading` says, by default as the model's
    data were."""
    probe_names = PROBE_INPUTS.values() if model.probe is not None else ()
    overrides = known_overrides(overrides, [*(s.name for s in model.inputs), *CONTROL_INPUT_START, *probe_names],
                                model_path)  # `reset=R` is `Reset=R`, here as in the replay
    column = lambda name: overrides.get(name, name)
    targets = (*model_targets(model), *((column(PROBE_VALUE_INPUT),) if probe_names else ()))  # mapped: also empty
    table = read_table(path, model.time_column, progress, model.reading if reading is None else reading,
                       sparse=targets)  # between probings
    rule = resampling_for(model, period_s)
    if rule is None:
        return table
    control_inputs(table, overrides)  # 0 or 1 on every raw row, as without resampling: a 2 or a 0.5 between two
    if column(PROBE_NEW_INPUT) in table.columns:  # calls must not become a reset or a probing
        cells_as(table, column(PROBE_NEW_INPUT), "BOOL", f"input {PROBE_NEW_INPUT}")
    enable, reset = (control_column(table, name, overrides) for name in (ENABLE_INPUT, RESET_INPUT))
    held_inputs = [overrides.get(s.name, s.column) for s in (*model.signals("speed"), *model.signals("feed"))]
    rule = replace(rule, hold=(*rule.hold, *held_inputs, enable, column(PROBE_VALUE_INPUT)),
                   pulses=(reset, column(PROBE_NEW_INPUT)),
                   pulse_values=((column(PROBE_VALUE_INPUT), column(PROBE_NEW_INPUT)),))
    held = bool(model.metrics.get("probing", {}).get("held"))
    return resample(table, model.time_column, rule, targets, held)
