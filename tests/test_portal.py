"""The portal machine: seeded, clean data inside paper 000's class, each effect where it belongs."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pytest

from thermoplc.base.errors import UserError
from thermoplc.machines import portal
from thermoplc.physics.effects import NAMES, Effect

TEMPS = portal.SENSORS
DT = 10.0


def run(*effects: str, hours: float = 24.0, seed: int = 5, **kwargs) -> dict:
    kwargs.setdefault("noise", 0.0)
    return portal.simulate(hours, seed, DT, effects=tuple(Effect.parse(e) for e in effects), **kwargs)


@pytest.fixture(scope="module")
def clean():
    return run(hours=72.0, seed=7)


@pytest.fixture(scope="module")
def base():
    return run()


def changed(a: dict, b: dict) -> set:
    return {k for k in a if not np.array_equal(a[k], b[k])}


def first_order(u: list, a, y0: float) -> np.ndarray:
    """y[j] = a·y[j-1] + (1 − a)·u[j], written out sample by sample; `a` one number or one per sample."""
    a = a if isinstance(a, list) else [a] * len(u)
    y = [y0]
    for k, x in zip(a[1:], u[1:]):
        y.append(k * y[-1] + (1.0 - k) * x)
    return np.array(y)


def test_columns_and_grid(base):
    assert list(base) == ["time_s", "n_rpm", "v_feed_mm_min", "T_env", *TEMPS, "E_z_um", "E_z_true_um"]
    assert np.array_equal(base["time_s"], np.arange(24 * 360 + 1) * DT)
    assert np.all(base["v_feed_mm_min"][base["n_rpm"] == 0] == 0)
    assert base["n_rpm"][0] == 0 and base["T_env"][0] == 20.0


def test_deterministic():
    a, b, c = (portal.simulate(12, s) for s in (3, 3, 4))
    assert not changed(a, b)
    assert changed(a, c) >= {"n_rpm", "T_env", *TEMPS, "E_z_um"}


def test_clean_data_is_a_first_order_lag_per_node(clean):
    env, n = clean["T_env"].tolist(), clean["n_rpm"].tolist()
    for node in portal.NODES:
        gain = node.rise_K / portal.SPEED_RANGE_RPM[1]
        expected = first_order([e + gain * s for e, s in zip(env, n)], math.exp(-DT / (node.tau_min * 60)), env[0])
        assert np.max(np.abs(clean[node.name] - expected)) < 1e-9, node.name
    mix = sum(node.ram_weight * clean[node.name] for node in portal.NODES)
    ram = first_order(mix.tolist(), math.exp(-DT / (portal.RAM_TAU_H * 3600)), mix[0])
    e = sum(node.um_per_K * (clean[node.name] - clean[node.name][0]) for node in portal.NODES)
    e = e + portal.RAM_UM_PER_K * (ram - ram[0])
    assert np.max(np.abs(clean["E_z_true_um"] - e)) < 1e-9
    assert np.array_equal(clean["E_z_um"], clean["E_z_true_um"])
    assert sum(node.ram_weight for node in portal.NODES) == pytest.approx(1.0)


def test_schedule_spans_the_gear_threshold_and_the_drift_is_tens_of_um(clean):
    speeds = set(clean["n_rpm"].tolist()) - {0.0}
    assert min(speeds) < 750 < max(speeds) and len(speeds) > 10
    assert all(200 <= s <= 4000 and s % 10 == 0 for s in speeds)
    assert 10 < np.ptp(clean["E_z_true_um"]) < 200
    assert 1 < np.ptp(clean["T_env"]) < 5


def test_noise_and_quantisation():
    noisy, quiet = run(noise=1.0), run()
    for k in ("T_env", *TEMPS):
        assert np.allclose(noisy[k], np.round(noisy[k], 2), atol=1e-9, rtol=0)
    assert 0.05 < np.std(noisy["T_spindle"] - quiet["T_spindle"]) < 0.12
    assert 0.5 < np.std(noisy["E_z_um"] - noisy["E_z_true_um"]) < 0.9
    assert np.array_equal(noisy["E_z_true_um"], quiet["E_z_true_um"])


def test_constant_speed():
    c = run(hours=6, constant_rpm=1200.0)
    assert np.all(c["n_rpm"] == 1200.0)
    assert c["T_spindle"][-1] - c["T_env"][-1] > 0.9 * 12.0 * 1200 / 4000


def test_sensor_offset_and_drift_touch_only_their_column(base):
    off = run("sensor_offset:column=T_column,offset_K=1.5")
    assert changed(base, off) == {"T_column"}
    assert np.allclose(off["T_column"] - base["T_column"], 1.5, atol=1e-9)
    drift = run("sensor_drift:column=T_spindle,rate_K_per_h=0.1")
    assert changed(base, drift) == {"T_spindle"}
    assert np.allclose(drift["T_spindle"] - base["T_spindle"], 0.1 * base["time_s"] / 3600, atol=1e-9)
    assert set(portal.COLUMN_DEFAULTS.values()) <= set(TEMPS)
    with pytest.raises(UserError, match="T_bearing"):
        run("sensor_offset")


def test_gear_switch(base):
    assert not changed(base, run("gear_ratio_switch:threshold_rpm=5000"))
    geared = run("gear_ratio_switch:threshold_rpm=750,ratio=1.6")
    assert changed(base, geared) == {"T_gearbox", "E_z_um", "E_z_true_um"}
    assert np.all(geared["T_gearbox"] >= base["T_gearbox"] - 1e-12)


def test_nonlinear_heat(base):
    linear = run("nonlinear_speed_heat:exponent=1,reference_rpm=1500")
    assert all(np.allclose(linear[k], base[k], atol=1e-9) for k in base)
    curved = run("nonlinear_speed_heat:exponent=1.6,reference_rpm=1500")
    assert changed(base, curved) == {*TEMPS, "E_z_um", "E_z_true_um"}


def test_coolant_relay_on_the_spindle(base):
    assert not changed(base, run("coolant_switching:on_C=60,off_C=50"))
    always = run("coolant_switching:on_C=5,off_C=4,cooling_K=3")   # on from the first step
    assert changed(base, always) == {"T_spindle", "E_z_um", "E_z_true_um"}
    env, n = base["T_env"].tolist(), base["n_rpm"].tolist()
    spindle = portal.NODES[0]
    expected = first_order([e + spindle.rise_K / 4000 * s - 3.0 for e, s in zip(env, n)],
                           math.exp(-DT / (spindle.tau_min * 60)), env[0])
    assert np.max(np.abs(always["T_spindle"] - expected)) < 1e-9
    relay = run("coolant_switching:on_C=24,off_C=22.5,cooling_K=3")
    cut = base["T_spindle"] - relay["T_spindle"]
    assert cut.max() > 2 and cut.min() > -1e-9
    assert relay["T_spindle"].max() < base["T_spindle"].max()


def test_structural_effects_move_only_the_displacement(base):
    for text in ("slow_structure", "ambient_coupling", "feed_axis_heat"):
        assert changed(base, run(text)) == {"E_z_um", "E_z_true_um"}, text
    assert not changed(run(ambient_swing=0.0), run("ambient_coupling", ambient_swing=0.0))
    feed = run("feed_axis_heat:tau_h=0.5,um_per_K=3")["E_z_true_um"] - base["E_z_true_um"]
    assert feed.min() > -1e-9 and 1 < feed.max() < 3 * 3.0


def test_stop_convection(base):
    assert not changed(base, run("stop_convection:factor=1"))
    slow = run("stop_convection:factor=2.5")
    assert changed(base, slow) == {*TEMPS, "E_z_um", "E_z_true_um"}
    env, n = base["T_env"].tolist(), base["n_rpm"].tolist()
    for node in portal.NODES:
        gain = node.rise_K / portal.SPEED_RANGE_RPM[1]
        a = [math.exp(-DT / (node.tau_min * 60 * (2.5 if s < 5 else 1.0))) for s in n]
        expected = first_order([e + gain * s for e, s in zip(env, n)], a, env[0])
        assert np.max(np.abs(slow[node.name] - expected)) < 1e-9, node.name


def test_every_effect_switches_on(base):
    suited = {"coolant_switching": "coolant_switching:on_C=24,off_C=22.5"}
    for name in NAMES:
        text = suited.get(name, name)
        if name in portal.COLUMN_DEFAULTS:
            text = f"{name}:column={portal.COLUMN_DEFAULTS[name]}"
        assert changed(base, run(text)), name


@dataclass(frozen=True)
class Step:
    column: str

    def error(self, t):
        return np.where(t > 3600, -2.0, 0.0)


def test_faults_land_on_their_column(base):
    faulty = run(faults=(Step("T_gearbox"),))
    assert changed(base, faulty) == {"T_gearbox"}
    with pytest.raises(UserError, match="T_motor"):
        run(faults=(Step("T_motor"),))


@pytest.mark.parametrize("kwargs", [dict(hours=0), dict(hours=-1), dict(dt=0), dict(noise=-0.1),
                                    dict(constant_rpm=-5.0)])
def test_bad_arguments(kwargs):
    args = dict(hours=1.0, seed=1, dt=10.0) | kwargs
    with pytest.raises(UserError):
        portal.simulate(**args)


@pytest.mark.parametrize("text", ["coolant_switching:on_C=20,off_C=22", "slow_structure:tau_h=0",
                                  "stop_convection:factor=-1", "sensor_drift:column=T_env"])
def test_bad_effect_parameters(text):
    with pytest.raises(UserError):
        run(text, hours=1)
