"""One record per effect: the registry, the parameters each record declares, and the generic code
that reads the records instead of naming effects."""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from thermoplc.base.errors import UserError
from thermoplc.models.effects import NAMES, Effect, registry
from thermoplc.models.simulation import DisplacementParams, SensorParams, Shared, Simulation

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


@pytest.mark.parametrize("folder", ["diagnosis", "machines/random_effects.py"])
def test_the_diagnosis_and_the_random_draws_name_no_effect(folder):
    """Their rules live in the effect records; a name here is a branch the next effect would need."""
    pattern = re.compile("|".join(NAMES))
    path = ROOT / folder
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
