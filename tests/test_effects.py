"""One record per effect: the registry, the parameters each record declares, and the generic code
that reads the records instead of naming effects."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from thermoplc.base.errors import UserError
from thermoplc.physics.effects import NAMES, Effect, registry
from thermoplc.physics.fitted import Simulation
from thermoplc.physics.primitives import DisplacementParams, SensorParams, Shared

ROOT = Path(__file__).resolve().parents[1]


def test_the_names_come_from_the_records_in_rank_order():
    assert NAMES == ("gear_ratio_switch", "coolant_switching", "nonlinear_speed_heat", "slow_structure",
                     "ambient_coupling", "sensor_offset", "sensor_drift", "feed_axis_heat", "stop_convection")
    assert [record.rank for record in registry().values()] == sorted(record.rank for record in registry().values())


@pytest.mark.parametrize("name", NAMES)
def test_every_record_parses_its_defaults_and_refuses_what_its_rules_refuse(name):
    record = registry()[name]
    assert Effect.parse(name) == Effect(name, record.defaults)
    for key in record.positive:
        with pytest.raises(UserError, match=f"{key} must be above 0"):
            Effect.parse(f"{name}:{key}=0")
    with pytest.raises(UserError, match="expected .* with keys"):
        Effect.parse(f"{name}:no_such_key=1")


def test_a_rule_across_parameters_is_the_records_own():
    with pytest.raises(UserError, match=r"on_C \(20\) must be above off_C \(24\)"):
        Effect.parse("coolant_switching:on_C=20,off_C=24")


@pytest.mark.parametrize("name", NAMES)
def test_the_parameter_count_grows_by_what_the_record_declares(name):
    sensors = tuple(SensorParams(600.0, 0.001) for _ in range(3))
    displacement = DisplacementParams(tau_struct_s=3600.0, beta0=0.0, beta=(0.0,) * 3, gamma=(0.0,) * 3)
    base = Simulation((), Shared(stopped_rpm=10.0), sensors, displacement)
    extended = Simulation(((name, 0 if registry()[name].per_sensor else None),), base.shared, sensors, displacement)
    assert base.parameter_count() == 3 * 3 + 1 + 3 + (1 + 3)
    assert extended.parameter_count() - base.parameter_count() == registry()[name].added_parameters(3) > 0


@pytest.mark.parametrize("folder", ["diagnosis", "machines/random_effects.py", "generator/lower_lumped.py",
                                    "generator/lumped_effects/lowering.py", "generator/lumped_effects/__init__.py"])
def test_the_diagnosis_and_the_random_draws_name_no_effect(folder):
    """Their rules live in the effect records; a name here is a branch the next effect would need."""
    pattern = re.compile("|".join(NAMES))
    path = ROOT / "thermoplc" / folder
    files = sorted(path.glob("*.py")) if path.is_dir() else [path]
    named = [f"{f.relative_to(ROOT)}:{i}" for f in files
             for i, line in enumerate(f.read_text("utf-8").splitlines(), 1)
             if pattern.search(line) and not line.lstrip().startswith(("#", '"""')) and '"' in line]
    assert named == []


def test_the_random_draw_is_the_records_and_is_seeded():
    from thermoplc.machines import machine
    from thermoplc.machines.random_effects import draw
    cascade = machine("cascade")
    clean = cascade.simulate(24.0, 3)
    first = [draw(name, cascade, clean, len(clean["time_s"]) // 2, 7) for name in NAMES]
    again = [draw(name, cascade, clean, len(clean["time_s"]) // 2, 7) for name in NAMES]
    assert first == again and [e.name for e in first] == list(NAMES)
    assert all(np.isfinite(v) for e in first for _, v in e.parameters if not isinstance(v, str))


@pytest.mark.parametrize("text, message", [
    ("gear_ratio_switch:ratio=1e308", "ratio must be within 0..100"),  # overflowed the twin into NaN before
    ("gear_ratio_switch:threshold_rpm=-5", "threshold_rpm must be within 0..100000"),
    ("sensor_drift:rate_K_per_h=1e300", "rate_K_per_h must be within -100..100"),
    ("ambient_coupling:um_per_K=1e30", "um_per_K must be within -10000..10000"),
    ("gear_ratio_switch:threshold_rpm=1,threshold_rpm=2", "threshold_rpm is given twice"),
])
def test_parameters_beyond_physics_or_given_twice_are_refused(text, message):
    with pytest.raises(UserError, match=message):
        Effect.parse(text)


@pytest.mark.parametrize("machine_name", ["cascade", "portal"])
@pytest.mark.parametrize("name", NAMES)
def test_the_bounds_keep_the_twin_finite(machine_name, name):
    from thermoplc.machines import machine
    record = registry()[name]
    extreme = ",".join(f"{key}={high if key != 'off_C' else low}" for key, low, high in record.bounds
                       if key != "on_C")
    if name == "coolant_switching":
        extreme = "cooling_K=-100,on_C=250,off_C=-50"
    twin = machine(machine_name)
    effect = Effect.parse(f"{name}:{extreme}", twin.COLUMN_DEFAULTS)
    data = twin.simulate(2.0, 1, effects=(effect,))
    assert all(np.all(np.isfinite(np.asarray(v, dtype=float))) for v in data.values())


def test_the_displacement_fit_and_the_model_file_read_each_displacement_term_from_its_record():
    """The columns, the search, the fitted fields and the block coefficients of a displacement effect
    (slow structure, ambient coupling, feed-axis heat) come from its record's DisplacementTerm."""
    import inspect
    from thermoplc.models.kinds import lumped_model
    from thermoplc.physics import displacement
    from thermoplc.physics import simulation
    from thermoplc.physics.effects import with_part
    assert with_part("displacement") == {"slow_structure", "ambient_coupling", "feed_axis_heat"}
    assert all(registry()[name].displacement for name in with_part("displacement"))
    functions = (displacement.displacement_columns, simulation.fit_displacement, displacement.fitted_taus,
                 simulation.displacement_term, simulation.run, displacement.term_columns,
                 lumped_model.coefficients, lumped_model.simulation_of)
    pattern = re.compile("|".join(with_part("displacement")) + r"|\b(A2|AAm|AF|delta|alpha|phi|tau_slow_s|tau_feed_s)\b")
    named = [f"{f.__name__}: {line.strip()}" for f in functions for line in inspect.getsource(f).splitlines()
             if pattern.search(line) and not line.lstrip().startswith("#")]
    assert named == []


@pytest.mark.parametrize("name", ["slow_structure", "ambient_coupling", "feed_axis_heat"])
def test_a_displacement_term_round_trips_through_the_model_file(name):
    """coefficients() writes the term's lag and weights under the record's names; simulation_of() reads them back."""
    from thermoplc.models.kinds import lumped_model
    from thermoplc.models.model import Model, Signal
    term = registry()[name].displacement
    sensors = tuple(SensorParams(600.0 * (i + 1), 0.001) for i in range(2))
    fields = {term.tau_field: 7200.0, term.weight_field: (1.5, -2.5) if term.per_sensor else 3.5}
    displacement = DisplacementParams(tau_struct_s=3600.0, beta0=0.5, beta=(1.0, 2.0), gamma=(3.0, 4.0), **fields)
    fitted = Simulation(((name, None),), Shared(stopped_rpm=10.0), sensors, displacement)
    coefficients, settings = lumped_model.coefficients(fitted, 10.0)
    names = [term.pole[0], term.pole[1], *([f"{term.weight}_1", f"{term.weight}_2"] if term.per_sensor else [term.weight])]
    assert all(n in coefficients for n in names)
    inputs = (Signal("T_1", "T_1", "temperature", "degC"), Signal("T_2", "T_2", "temperature", "degC"),
              Signal("n", "n", "speed", "rpm"), Signal("Te", "Te", "ambient", "degC"))
    model = Model("lumped", "B", inputs, Signal("E", "E", "target", "um"), "time_s", 10.0, coefficients, settings)
    back = lumped_model.simulation_of(model).displacement
    assert getattr(back, term.tau_field) == pytest.approx(7200.0, rel=1e-9)
    assert term.weights(back) == term.weights(displacement)


def test_each_effect_with_block_arithmetic_has_its_lowering_and_the_file_order_does_not_matter():
    """The lumped block takes each effect's statements from generator/lumped_effects/<name>.py, in rank
    order: the block of a model file listing its effects in another order is the same block."""
    import dataclasses
    from thermoplc.generator import lumped_effects
    from thermoplc.generator.lower import lower
    from thermoplc.models.modelfile import load_model
    from tests.golden_models import GOLDEN
    reading = {name for name, record in registry().items() if record.part == "reading"}
    assert set(lumped_effects.lowerings()) == set(NAMES) - reading
    assert list(lumped_effects.lowerings()) == [name for name in NAMES if name not in reading]
    model = load_model(GOLDEN / "lumped.json")
    effects = model.settings["effects"]
    assert len(effects) > 3
    reordered = dataclasses.replace(model, settings={**model.settings, "effects": effects[::-1]})
    first, second = lower(model), lower(reordered)
    assert (first.statics, first.constants, first.regions) == (second.statics, second.constants, second.regions)


@pytest.mark.parametrize("edit, message", [
    ("drop the effect", "settings\\.speed_table_segments'"), ("drop the table", "settings\\.speed_table_segments'"),
    ("drop the effect and the count", "coefficients': 16 node_ coefficients but no speed table"),
    ("one segment fewer", "settings\\.speed_table_segments': 15, but the file has 16 node_ coefficients")])
def test_a_speed_table_without_its_effect_or_the_effect_without_a_table_is_refused(tmp_path, edit, message):
    import json
    from thermoplc.models.modelfile import load_model
    from tests.golden_models import GOLDEN
    doc = json.loads((GOLDEN / "lumped.json").read_text())
    if edit.startswith("drop the effect"):
        doc["settings"]["effects"] = [e for e in doc["settings"]["effects"] if e["name"] != "nonlinear_speed_heat"]
    if edit in ("drop the table", "drop the effect and the count"):
        doc["settings"]["speed_table_segments"] = 0
    if edit == "one segment fewer":
        doc["settings"]["speed_table_segments"] = 15
    (tmp_path / "m.json").write_text(json.dumps(doc))
    with pytest.raises(UserError, match=r"m\.json: field '" + message):
        load_model(tmp_path / "m.json")


@pytest.mark.parametrize("edits, refused", [
    ({"A_1": 1.0}, r"A_1': 1\.0; expected a decay"), ({"A_2": 1.0000001}, r"A_2': 1\.0000001; expected a decay"),
    ({"As_1": -0.25}, r"As_1': -0\.25; expected a decay"), ({"Bs_2": 0.0}, r"Bs_2': 0\.0; expected the complement"),
    ({"B_1": 1.5}, r"B_1': 1\.5; expected the complement"), ({"AS": 1.0}, r"AS': 1\.0; expected a decay"),
    ({"BS": 0.0}, r"BS': 0\.0; expected the complement"), ({"AAm": 2.0}, r"AAm': 2\.0; expected a decay"),
    ({"B2": -1e-3}, r"B2': -0\.001; expected the complement"), ({"AF": 1.0}, r"AF': 1\.0; expected a decay"),
    ({"ACl": 1.0}, r"ACl': 1\.0; expected a decay"), ({"BCl": 0.0}, r"BCl': 0\.0; expected the complement"),
    ({"ACl": 0.5, "BCl": 0.9}, r"BCl': 0\.9, but 1 - ACl is 0\.5: a lag's decay and its complement add up to 1"),
    ({"A_2": 0.25}, r"B_2': [0-9.e-]+, but 1 - A_2 is 0\.75"),
    ({"A_1": 0.0, "B_1": 1.0}, None), ({"AAm": 0.999999, "BAm": 1 - 0.999999}, None)])
def test_every_lag_of_a_lumped_file_decays_and_its_pair_adds_up_to_1(tmp_path, edits, refused):
    """A decay per call of 1 or more integrates its input without bound (the block's state overflows after
    enough calls), a negative one rings, a pair that does not add up to 1 scales what it lags: refused by field
    before a block is built; 0 (no memory) and its complement 1 are a lag faster than the call and run."""
    import json
    from thermoplc.models.modelfile import load_model
    from tests.golden_models import GOLDEN
    doc = json.loads((GOLDEN / "lumped.json").read_text())
    for name, value in edits.items():
        assert name in doc["coefficients"]
        doc["coefficients"][name] = {"f64": value, "f32": "0x" + np.float32(value).tobytes()[::-1].hex().upper()}
    (tmp_path / "m.json").write_text(json.dumps(doc))
    if refused is None:
        assert {name: load_model(tmp_path / "m.json").coef(name, "f64") for name in edits} == edits
        return
    with pytest.raises(UserError, match=r"m\.json: field 'coefficients\." + refused):
        load_model(tmp_path / "m.json")


@pytest.mark.parametrize("edit, message", [
    ("BGr", "': AGr without BGr; the gear heat's lag needs both"),
    ("gear_ratio_switch", "': AGr and BGr without settings.effects listing gear_ratio_switch"),
    ("AGr=1", r"\.AGr': 1\.0; expected a decay per call exp\(-dt/tau\) in \[0, 1\)"),
    ("BGr=-0.5", r"\.BGr': -0\.5; expected the complement 1 - exp\(-dt/tau\) of a decay per call, in \(0, 1\]"),
    ("BCl", "': ACl without BCl; the cooling's lag needs both"),
    ("coolant_switching", "': ACl and BCl without settings.effects listing coolant_switching")])
def test_an_effects_own_lag_is_a_pair_of_that_effect(tmp_path, edit, message):
    """The golden block's gear heat and cooling enter through their lags (AGr, BGr; ACl, BCl); a file with half a
    pair, or a pair without its effect, is an edited file, refused by name before any block is written."""
    import json
    from thermoplc.models.modelfile import load_model
    from tests.golden_models import GOLDEN
    doc = json.loads((GOLDEN / "lumped.json").read_text())
    if edit in ("BGr", "BCl"):
        del doc["coefficients"][edit]
    elif "=" in edit:
        name, value = edit.split("=")
        doc["coefficients"][name] = {"f64": float(value), "f32": "0x" + np.float32(value).tobytes()[::-1].hex().upper()}
    else:
        doc["settings"]["effects"] = [e for e in doc["settings"]["effects"] if e["name"] != edit]
    (tmp_path / "m.json").write_text(json.dumps(doc))
    with pytest.raises(UserError, match=r"m\.json: field 'coefficients" + message):
        load_model(tmp_path / "m.json")


@pytest.mark.parametrize("machine_name", ["cascade", "portal"])
def test_the_twins_gear_heat_enters_through_its_lag(machine_name):
    """`--effect gear_ratio_switch:lag_min=M`: the heat above the threshold reaches the machine through a lag of M
    minutes; 0 is the switch at once, bit for bit the twin before the lag existed."""
    from thermoplc.machines import machine
    chosen = machine(machine_name)
    at_once, lagged, plain = (chosen.simulate(12, 3, effects=(Effect.parse(text),), noise=0.0) for text in (
        "gear_ratio_switch:threshold_rpm=750,ratio=2,lag_min=0", "gear_ratio_switch:threshold_rpm=750,ratio=2,lag_min=60",
        "gear_ratio_switch:threshold_rpm=750,ratio=2"))
    sensor = "T_motor" if machine_name == "cascade" else "T_gearbox"
    assert at_once[sensor].view(np.uint64).tolist() == plain[sensor].view(np.uint64).tolist()
    clean = chosen.simulate(12, 3, noise=0.0)[sensor]
    extra_at_once, extra_lagged = at_once[sensor] - clean, lagged[sensor] - clean
    assert np.max(np.abs(extra_lagged)) > 0.2 * np.max(np.abs(extra_at_once)) > 0  # the heat arrives, later
    first = int(np.argmax(np.abs(extra_at_once) > 0.05 * np.max(np.abs(extra_at_once))))
    assert abs(extra_lagged[first]) < abs(extra_at_once[first])


# sha256 of `thermoplc twin --machine M --hours 24 --seed 7 --effect coolant_switching` written by the code before the
# cooling had a lag (commit f1d5c67): the cooling at once is that twin, byte for byte
COOLANT_TWIN_BEFORE_THE_LAG = {"cascade": "3c965dd5dd51a74b5927e4ee7c5cd3a4c093af2cc23dcd90d61f5c3cf427cd67",
                               "portal": "a5513575adea33c31560f7fbac20ca6104a21ecf88800ce17b82f47069b16601"}


@pytest.mark.parametrize("machine_name", ["cascade", "portal"])
def test_the_twins_cooling_at_once_is_the_twin_before_the_lag(tmp_path, machine_name):
    import hashlib
    from thermoplc.cli import main
    assert main(["twin", "--machine", machine_name, "--hours", "24", "--seed", "7", "--effect",
                 "coolant_switching:lag_min=0", "-o", str(tmp_path / "t.csv")]) == 0
    digest = hashlib.sha256((tmp_path / "t.csv").read_bytes()).hexdigest()
    assert digest == COOLANT_TWIN_BEFORE_THE_LAG[machine_name]


@pytest.mark.parametrize("machine_name", ["cascade", "portal"])
def test_the_twins_cooling_enters_through_its_lag(machine_name):
    """`--effect coolant_switching:lag_min=M`: the relay's cooling reaches the machine through a lag of M minutes
    (the coolant loop's own thermal mass); 0 is the cooling at once, bit for bit the default."""
    from thermoplc.machines import machine
    chosen = machine(machine_name)
    at_once, lagged, plain = (chosen.simulate(24, 7, effects=(Effect.parse(text),), noise=0.0) for text in (
        "coolant_switching:lag_min=0", "coolant_switching:lag_min=30", "coolant_switching"))
    sensor = chosen.COOLANT_SENSOR
    assert at_once[sensor].view(np.uint64).tolist() == plain[sensor].view(np.uint64).tolist()
    clean = chosen.simulate(24, 7, noise=0.0)[sensor]
    cooled_at_once, cooled_lagged = clean - at_once[sensor], clean - lagged[sensor]
    first = int(np.argmax(cooled_at_once > 0.05 * np.max(cooled_at_once)))
    assert np.max(cooled_at_once) > 0.5 and 0 <= cooled_lagged[first] < cooled_at_once[first]  # the cooling, later
    assert np.max(cooled_lagged) > 0.3 * np.max(cooled_at_once)



def _running_then_a_cold_night(path: Path) -> None:
    """3 h at 3000 rpm, then 41 h stopped while the hall cools to 15 degC: the golden block's relay switches on
    while running and off in the night, and its lagged cooling decays to its floor and stays there."""
    dt, running, stopped = 10.0, 1080, 14760
    t = np.arange(running + stopped) * dt
    night = np.arange(stopped) * dt
    air = np.r_[np.full(running, 20.0), 15.0 + 5.0 * np.exp(-night / 7200.0)]
    heat = np.r_[8.0 * (1 - np.exp(-t[:running] / 3600.0)), 8.0 * (1 - np.exp(-3.0)) * np.exp(-night / 3600.0)]
    columns = {"time_s": t, "n_rpm": np.r_[np.full(running, 3000.0), np.zeros(stopped)], "v_feed_mm_min": 0.0 * t,
               "T_env": air, "T_motor": air + heat, "T_bearing": air + 0.6 * heat, "E_z_um": 2.0 * heat}
    rows = [",".join(columns)] + [",".join(f"{columns[c][j]:.6f}" for c in columns) for j in range(len(t))]
    path.write_text("\n".join(rows) + "\n")


@pytest.mark.parametrize("edit, proved", [
    (None, True),
    (("ELSE\n\t            #LC := #c_ACl * #LC;", "ELSE\n\t            #LC := #c_Zero;"), False),  # the relay's off branch
    (("IF #LC < #c_Cool_Floor THEN", "IF #LC < #c_Zero THEN"), False)])  # the floor made a no-op
def test_the_lagged_cooling_decays_to_its_floor_after_the_relay_is_off(tmp_path, edit, proved):
    """The golden twin's relay never switches off, so the golden replay never runs the lag's decay or its floor;
    a cold night after a run does: the block is proved on it, and an edit of either branch is caught."""
    from thermoplc.cli import main
    from tests.golden_models import GOLDEN, golden_block
    _running_then_a_cold_night(tmp_path / "night.csv")
    text = golden_block("lumped", "tia").read_text()
    if edit is not None:
        assert text.count(edit[0]) == 1
        text = text.replace(*edit)
    (tmp_path / "b.scl").write_text(text)
    code = main(["verify", str(tmp_path / "b.scl"), "--model", str(GOLDEN / "lumped.json"),
                 "--data", str(tmp_path / "night.csv")])
    assert (code == 0) == proved
