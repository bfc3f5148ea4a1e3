"""The versioned model file read back and checked: its JSON schema (from the kinds' records), its shape,
counts and coefficients; the record itself (Model, Signal, Coefficient) is models/model.py."""
from __future__ import annotations

import functools
from dataclasses import replace
import json
import math
from importlib import resources
from pathlib import Path

from thermoplc.base.identifiers import identifier_problem
from thermoplc.physics import effects as effect_library
from thermoplc.models.kinds import checked_temperatures, driving_temperatures, kind_of, registry
from thermoplc.models.model import COMBINED_ROLE, FORMAT, ROLES, SCHEMA_VERSION, Coefficient, Model, Signal
from thermoplc.models.probing import Fusion
from thermoplc.models.envelope import Envelope
from thermoplc.models.plausibility import Plausibility
from thermoplc.models.start import Start
from thermoplc.recordings.reading import Reading
from thermoplc.recordings.resample import Resampling
from thermoplc.base.binary32 import FLT_MAX, f32_hex, parse_f32_hex, ulp_distance
from thermoplc.base.errors import UserError, unreadable


MAX_MODEL_BYTES = 64 * 1024 * 1024  # far above the largest model (a bayes table of 4096 entries is ~1 MB)


class _DuplicateKey(ValueError):
    pass


def _refuse_duplicate_keys(pairs: list) -> dict:
    """A key given twice: JSON readers keep one or the other, so the file means two things."""
    keys = [k for k, _ in pairs]
    twice = next((k for k in keys if keys.count(k) > 1), None)
    if twice is not None:
        raise _DuplicateKey(twice)
    return dict(pairs)


def load_model(path: str | Path) -> Model:
    path = str(path)
    try:
        if Path(path).stat().st_size > MAX_MODEL_BYTES:
            raise UserError(f"{path}: {Path(path).stat().st_size:,} bytes; a model file is at most {MAX_MODEL_BYTES:,}")
        text = Path(path).read_text("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise unreadable(path, exc, "the model") from None
    try:
        doc = json.loads(text, object_pairs_hook=_refuse_duplicate_keys)
    except json.JSONDecodeError as exc:
        first = text.lstrip("\ufeff").split("\n", 1)[0]
        if exc.pos == 0 and ("," in first or ";" in first) and not first.lstrip().startswith(("{", "[")):
            raise UserError(f"{path}: a recording (CSV), not a thermoplc model; fit a model on it first (thermoplc fit "
                            f"--data {path} ... -o model.json) and give that model file") from None
        raise UserError(f"{path}:{exc.lineno}:{exc.colno}: malformed JSON: {exc.msg}") from None
    except RecursionError:
        raise UserError(f"{path}: JSON nested thousands of levels deep; not a thermoplc model file") from None
    except _DuplicateKey as exc:
        raise UserError(f"{path}: key {str(exc)!r} appears twice in one object; a model file gives each field once") from None
    except ValueError as exc:  # an integer of more than 4300 digits
        raise UserError(f"{path}: cannot read a number: {exc}") from None
    model = _parse(doc, path)  # the fields every kind has, with messages tuned for hand edits
    _check_schema(doc, path)
    _check_shape(model, path)
    if "plausibility" in doc:  # after the inputs are known good: it names them
        model = replace(model, plausibility=Plausibility.from_doc(doc["plausibility"], path,
                                                                  checked_temperatures(model),
                                                                  driving_temperatures(model)))
    return model


@functools.lru_cache(maxsize=1)
def _schema_validator():
    import jsonschema
    return jsonschema.Draft202012Validator(schema())


def schema() -> dict:
    """The model file's JSON Schema: the part every kind shares (model_schema_v1.json) with the
    kind enum and one settings schema per kind from the kinds' records."""
    doc = json.loads(resources.files("thermoplc.models").joinpath("model_schema_v1.json").read_text("utf-8"))
    doc["properties"]["kind"] = {"enum": list(registry())}
    for name, kind in registry().items():
        if kind.settings_schema is not None:
            doc["$defs"][name] = kind.settings_schema
            doc["allOf"].append({"if": {"properties": {"kind": {"const": name}}},
                                 "then": {"properties": {"settings": {"$ref": f"#/$defs/{name}"}}}})
    return doc


def _check_schema(doc, path: str) -> None:
    """The versioned JSON Schema shipped with the package (one settings schema per kind): the first
    problem, named by its field."""
    import jsonschema
    error = jsonschema.exceptions.best_match(_schema_validator().iter_errors(doc))
    if error is not None:
        where = "".join(f"[{p}]" if isinstance(p, int) else f".{p}" for p in error.absolute_path).lstrip(".")
        message = error.message if len(error.message) <= 200 else error.message[:200] + "..."
        raise UserError(f"{path}: " + (f"field {where!r}: " if where else "") + message)


def _check_shape(model: "Model", path: str) -> None:
    """What the schema cannot say: sizes that must agree between fields (the kind's own rules)."""
    if not model.signals("temperature"):
        raise UserError(f"{path}: field 'inputs': no input has the role temperature")
    kind_of(model.kind).check_settings(model, path)
    _check_counts(model, path)


MAX_RECORDED_ROWS = 10 ** 10  # a year at 300 Hz: far beyond any thermal recording (they are sampled at seconds)


def _count(value, path: str, where: str, most: int, bound: str) -> int:
    if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value <= most:
        raise UserError(f"{path}: field {where!r}: {value!r}; expected a whole number of rows from 0 to {most:,} "
                        f"({bound})")
    return value


def _check_counts(model: "Model", path: str) -> None:
    """Row counts are what generate and the acceptance gate quote ('accepted on N held-out rows'): each is
    bounded by the rows the training says were recorded, and those by a plausible recording."""
    batches = model.training.get("batches", [model.training])
    recorded, trained = 0, 0
    for k, batch in enumerate(batches if isinstance(batches, list) else []):
        where = f"training.batches[{k}]" if "batches" in model.training else "training"
        if not isinstance(batch, dict) or "total_rows" not in batch:
            recorded = None
            break
        total = _count(batch["total_rows"], path, f"{where}.total_rows", MAX_RECORDED_ROWS, "a plausible recording")
        if "rows" in batch:
            trained += _count(batch["rows"], path, f"{where}.rows", total, "at most the rows recorded")
        recorded += total
    most, bound = (MAX_RECORDED_ROWS, "a plausible recording") if not recorded else \
        (recorded, "at most the rows the training recorded")
    for section in ("train", "held_out"):
        counts = model.metrics.get(section)
        split = section == "held_out" and isinstance(counts, dict) and "protocol" not in counts and recorded
        limit, said = (recorded - trained, "the rows recorded after the training rows") if split else (most, bound)
        for key in ("rows", "calls"):
            if isinstance(counts, dict) and key in counts:
                _count(counts[key], path, f"metrics.{section}.{key}", limit, said)


MAX_FOLDING_ULP = 8  # f32 folded in binary32 (A*A) may sit a few ULP from f64 rounded; more is an edit


def _field(doc, key: str, kind, path: str, where: str = ""):
    name = f"{where}.{key}" if where else key
    if not isinstance(doc, dict) or key not in doc:
        raise UserError(f"{path}: field {name!r} is missing")
    value = doc[key]
    if kind is float and isinstance(value, int) and not isinstance(value, bool):
        value = float(value)
    if not isinstance(value, kind) or (kind is float and not math.isfinite(value)):
        raise UserError(f"{path}: field {name!r} must be {getattr(kind, '__name__', kind)}, found {value!r}")
    return value


def _identifier(name: str, path: str, where: str) -> str:
    """Names that reach the block are checked here too: a hand-edited model file is user input."""
    problem = identifier_problem(name)
    if problem:
        raise UserError(f"{path}: field {where!r}: {name!r} {problem}")
    return name


def _signal(doc, path: str, where: str) -> Signal:
    signal = Signal(*(_field(doc, k, str, path, where) for k in ("name", "column", "role", "unit")))
    _identifier(signal.name, path, f"{where}.name")
    return signal


def _check_effects(settings: dict, path: str) -> None:
    """Effect names reach the block's title: only the library's names are read."""
    effects = settings.get("effects", [])
    if not isinstance(effects, list):
        raise UserError(f"{path}: field 'settings.effects' must be a list, found {effects!r:.60}")
    known = tuple(effect_library.registry()) if effects else ()  # a model without effects loads no effect module
    for i, effect in enumerate(effects):
        name = effect.get("name") if isinstance(effect, dict) else None
        if name not in known:
            raise UserError(f"{path}: field 'settings.effects[{i}].name' must be one of "
                            f"{', '.join(effect_library.registry())}, found {name!r:.60}")


def _parse(doc, path: str) -> Model:
    if _field(doc, "format", str, path) != FORMAT:
        raise UserError(f"{path}: field 'format' must be {FORMAT!r}; this is not a thermoplc model file")
    version = _field(doc, "schema_version", int, path)
    if version != SCHEMA_VERSION:
        raise UserError(f"{path}: schema_version {version} is not supported; this thermoplc reads version {SCHEMA_VERSION}")
    kind = _field(doc, "kind", str, path)
    if kind not in registry():
        raise UserError(f"{path}: field 'kind' must be one of {', '.join(registry())}, found {kind!r}")
    inputs = tuple(_signal(s, path, f"inputs[{i}]") for i, s in enumerate(_field(doc, "inputs", list, path)))
    for i, s in enumerate(inputs):
        if not s.role or any(role not in ROLES for role in s.role.split(",")):
            raise UserError(f"{path}: field 'inputs[{i}].role' must be one of {', '.join(ROLES)}, found {s.role!r}")
        if "," in s.role and s.role != COMBINED_ROLE:
            roles = s.role.split(",")
            why = (f"names role {roles[0]!r} twice" if len(set(roles)) < len(roles) else
                   f"must be written {COMBINED_ROLE!r}" if set(roles) == set(COMBINED_ROLE.split(",")) else
                   "gives one signal two roles; only an ambient sensor that is also a regression temperature "
                   f"has two ({COMBINED_ROLE!r})")
            raise UserError(f"{path}: field 'inputs[{i}].role': {s.role!r} {why}")
        if s.role == COMBINED_ROLE and kind_of(kind).ambient_apart:
            raise UserError(f"{path}: field 'inputs[{i}].role': a {kind} model drives each temperature by the "
                            f"ambient and needs its ambient sensor apart, not {s.name!r} as both")
        same = next((j for j, other in enumerate(inputs[:i]) if other.column == s.column), None)
        if same is not None:
            raise UserError(f"{path}: fields 'inputs[{same}]' and 'inputs[{i}]' both read column {s.column!r}; one "
                            f"column holds one signal (an ambient sensor that is also a temperature is one input "
                            f"with role {COMBINED_ROLE!r})")
    present = {role for s in inputs for role in s.role.split(",")}
    for role in ("temperature", *kind_of(kind).roles) if inputs else ():  # none at all: the schema says so
        if role not in present:
            raise UserError(f"{path}: kind {kind!r} reads an input of role {role!r}, and field 'inputs' has none "
                            f"(roles {', '.join(sorted(present))}); is 'kind' right?")
    coefficients = {}
    for name, entry in _field(doc, "coefficients", dict, path).items():
        where = f"coefficients.{name}"
        f64 = _field(entry, "f64", float, path, where)
        try:
            f32 = parse_f32_hex(_field(entry, "f32", str, path, where))
        except ValueError as exc:
            raise UserError(f"{path}: field '{where}.f32': {exc}") from None
        if not math.isfinite(f32) or abs(f64) > FLT_MAX:
            raise UserError(f"{path}: field {where!r} must be a finite binary32 value (|x| <= {FLT_MAX:.7g}), "
                            f"found f32 {f32!r}, f64 {f64!r}")
        if ulp_distance(f32, f64) > MAX_FOLDING_ULP:  # the block runs f32, the float64 check uses f64: one value
            raise UserError(f"{path}: field {where!r}: f32 {f32_hex(f32)} is {ulp_distance(f32, f64)} ULP from f64 "
                            f"{f64!r} rounded to binary32 ({f32_hex(f64)}); edit f64 and let thermoplc write f32")
        coefficients[name] = Coefficient(f64, f32)
    settings = _field(doc, "settings", dict, path)
    _check_effects(settings, path)
    sample_period = _field(doc, "sample_period_s", float, path)
    model = Model(
        kind=kind,
        block_name=_identifier(_field(doc, "block_name", str, path), path, "block_name"),
        inputs=inputs,
        target=_signal(_field(doc, "target", dict, path), path, "target"),
        time_column=_field(doc, "time_column", str, path),
        sample_period_s=sample_period,
        coefficients=coefficients,
        settings=settings,
        training=_field(doc, "training", dict, path),
        metrics=_field(doc, "metrics", dict, path),
        fit=_field(doc, "fit", dict, path),
        probe=Fusion.from_doc(doc["probe"], path) if "probe" in doc else None,
        start=Start.from_doc(doc["start"], path) if "start" in doc else None,
        envelope=Envelope.from_doc(doc["envelope"], path) if "envelope" in doc else None,
        resample=_resampling(doc, path, sample_period),
        reading=_reading(doc, path),
    )
    return model


def _reading(doc: dict, path: str) -> Reading:
    """How the model's data were read (fit --decimal, --gaps, --time-format), checked as the options are."""
    found = doc.get("reading", {})
    if not isinstance(found, dict) or set(found) - {"decimal", "gaps", "time_format"}:
        raise UserError(f"{path}: field 'reading': expected an object of decimal, gaps and time_format, found {found!r}")
    try:
        return Reading.from_doc(found)
    except UserError as exc:
        raise UserError(f"{path}: field 'reading': {str(exc).split(': ', 1)[1]}") from None


def _resampling(doc: dict, path: str, sample_period: float) -> Resampling | None:
    """The recorded resampling, checked before it is built (the schema runs after): an object with a finite
    positive period equal to the block's cycle and a list of column names to hold."""
    if "resample" not in doc:
        return None
    found = doc["resample"]
    if not isinstance(found, dict):
        raise UserError(f"{path}: field 'resample': expected an object with period_s and hold, found {found!r}")
    period = found.get("period_s")
    if isinstance(period, bool) or not isinstance(period, (int, float)) or not math.isfinite(period) or period <= 0:
        raise UserError(f"{path}: field 'resample.period_s': expected a finite number of seconds above 0, "
                        f"found {period!r}")
    hold = found.get("hold", [])
    if not isinstance(hold, list) or not all(isinstance(c, str) and c for c in hold):
        raise UserError(f"{path}: field 'resample.hold': expected a list of column names, found {hold!r}")
    if abs(period - sample_period) > 1e-9 * sample_period:
        raise UserError(f"{path}: field 'resample.period_s': {period:g} s, but the block's cycle "
                        f"(sample_period_s) is {sample_period:g} s")
    return Resampling.from_doc(found)
