"""The rules that keep `diagnose` from naming what the data cannot show, each on data built for it.

A fit of no size, a slow structure that is a lag of the air, a gear switch through two speed
groups, slow lags from less than a day, and several stand-ins with disagreements left: each must
give no name (and say why), while the real thing still passes.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from thermoplc.diagnosis import findings, judges, rules, search, sufficiency, windows
from thermoplc.diagnosis.windows import Window
from thermoplc.diagnosis.parts import single
from thermoplc.machines import hall, machine
from thermoplc.machines.random_effects import draw
from thermoplc.physics import identified_effects, identify, primitives
from thermoplc.physics import simulation
from thermoplc.physics.effects import slow_structure
from thermoplc.physics.fitted import Simulation
from thermoplc.physics.primitives import DisplacementParams, SensorParams, Series, Shared

DT = 10.0
HOUR = 3600.0


def _series(hours: float, speeds=(800.0, 1600.0, 2400.0), seed: int = 0) -> Series:
    """Runs of an hour at the given speeds with stops between, a daily ambient sine."""
    rng = np.random.default_rng(seed)
    rows = int(hours * HOUR / DT) + 1
    t = np.arange(rows) * DT
    n = np.zeros(rows)
    for j, start in enumerate(range(0, rows, 720)):
        n[start:start + 360] = speeds[j % len(speeds)]
    te = 20.0 + np.sin(2 * np.pi * t / 86400.0)
    temps = np.column_stack([te, te]) + rng.normal(0, 0.05, (rows, 2))
    return Series(DT, t, n, te, temps, ("T_a", "T_b"), np.zeros(rows))


def _sim(effects=(), sensors=None, **displacement) -> Simulation:
    sensors = sensors or (SensorParams(3600.0, 2e-3), SensorParams(3600.0, 1e-3))
    base = dict(tau_struct_s=2 * HOUR, beta0=0.0, beta=(1.0, 1.0), gamma=(0.0, 0.0))
    return Simulation(tuple(effects), Shared(stopped_rpm=1.0, gear_rpm=1200.0, exponent=1.0, reference_rpm=1600.0,
                                             table_rpm=tuple(np.linspace(0, 3000, 17))),
                      sensors, DisplacementParams(**{**base, **displacement}))


def _hidden(machine_name: str, name: str | None, seed: int, hours: float = 24, noise: float = 1.0,
            feed: bool = False) -> tuple[Series, int, object]:
    """A recording with `name` hidden (parameters drawn as the benchmark draws them), its training
    rows and the effect; the feed column only when asked for (it adds a candidate)."""
    chosen = machine(machine_name)
    columns = chosen.simulate(hours, seed, noise=noise)
    rows = int(0.6 * len(columns["time_s"]))
    effect = None if name is None else draw(name, chosen, columns, rows, seed)
    if effect is not None:
        columns = chosen.simulate(hours, seed, effects=(effect,), noise=noise)
    temps = chosen.DIAGNOSED
    return Series(DT, columns["time_s"], columns["n_rpm"], columns["T_env"],
                  np.column_stack([columns[c] for c in temps]), temps, columns["E_z_um"],
                  columns["v_feed_mm_min"] if feed else None), rows, effect


def test_a_gear_switch_of_no_size_is_no_switch():
    train = _series(30)
    flat = (SensorParams(3600.0, 2e-3, gear_gain=4e-5), SensorParams(3600.0, 1e-3, gear_gain=-3e-5))
    assert "no switch" in rules.implausible(_sim([("gear_ratio_switch", None)], flat), "gear_ratio_switch", train)
    real = (SensorParams(3600.0, 2e-3, gear_gain=2e-3), SensorParams(3600.0, 1e-3, gear_gain=0.0))
    assert rules.implausible(_sim([("gear_ratio_switch", None)], real), "gear_ratio_switch", train) is None


@pytest.mark.parametrize("gear_gain, lag_s, refused", [(-1.5e-3, 1200.0, True), (-1.5e-3, 0.0, False),
                                                      (2e-3, 1200.0, False)])
def test_less_heat_above_the_threshold_through_a_lag_of_its_own_is_a_second_time_constant(gear_gain, lag_s, refused):
    """Issue 65: the gear heat enters through a lag of its own. A lagged part that takes heat away is the same
    heat's path, slower (FL_THERMAL's clean recording fits one at 1250 rpm, 20 min, a quarter of the heat per rpm
    above); added heat through its own lag is a switch, and so is less heat at once."""
    sensors = (SensorParams(3600.0, 2e-3, gear_gain=gear_gain), SensorParams(3600.0, 1e-3, gear_gain=0.0))
    sim = _sim([("gear_ratio_switch", None)], sensors)
    sim = dataclasses.replace(sim, shared=dataclasses.replace(sim.shared, gear_tau_s=lag_s))
    why = rules.implausible(sim, "gear_ratio_switch", _series(30))
    assert (why is not None and "second time constant" in why and "(20 min)" in why) == refused, why


def test_a_barely_heated_sensor_does_not_make_a_switch_of_no_size_count():
    """Gear gains are compared with the largest heat gain: a sensor that the spindle hardly heats
    (a hall sensor) must not turn a tiny gear gain into a large relative change."""
    train = _series(30)
    hall = (SensorParams(3600.0, 2e-3, gear_gain=2e-5), SensorParams(3600.0, 2.5e-7, gear_gain=1e-6))
    assert "no switch" in rules.implausible(_sim([("gear_ratio_switch", None)], hall), "gear_ratio_switch", train)


@pytest.mark.parametrize("exponent, linear", [(1.0, True), (1.04, True), (0.97, True), (1.3, False)])
def test_an_exponent_near_one_is_linear_heat(exponent, linear):
    sim = _sim([("nonlinear_speed_heat", None)])
    sim = dataclasses.replace(sim, shared=dataclasses.replace(sim.shared, exponent=exponent))
    why = rules.implausible(sim, "nonlinear_speed_heat", _series(30))
    assert (why is not None and "linear heat" in why) == linear


def test_a_slow_structure_that_cancels_the_heat_and_keeps_the_air_is_not_one():
    """Equal time constants, heat gains 2:1; weights (1, -2) cancel the heat exactly and keep a third
    of the ambient: a lag of the air. Weights of one sign keep both."""
    train = _series(30)
    cancelling = _sim([("slow_structure", None)], tau_slow_s=6 * HOUR, delta=(1.0, -2.0))
    heat_kept, ambient_kept = slow_structure.kept_shares(cancelling, train, identified_effects.ROUTINES)
    assert heat_kept < 1e-6 and ambient_kept == pytest.approx(1 / 3, rel=0.02)  # start values differ by the noise
    assert "lag of the air" in rules.implausible(cancelling, "slow_structure", train)
    adding = _sim([("slow_structure", None)], tau_slow_s=6 * HOUR, delta=(1.0, 2.0))
    assert slow_structure.kept_shares(adding, train, identified_effects.ROUTINES) == pytest.approx((1.0, 1.0))
    assert rules.implausible(adding, "slow_structure", train) is None


def test_a_displacement_term_under_the_noise_is_too_small():
    series = _series(30)
    sigma = {"T_a": 0.05, "T_b": 0.05, "E": 0.5}
    tiny = _sim([("ambient_coupling", None)], tau_ambient_s=3 * HOUR, alpha=0.3)  # 2 K of air: 0.6 um
    assert "under 3 times its noise" in rules.too_small(tiny, "ambient_coupling", single(series, series.rows), sigma, "E")
    real = _sim([("ambient_coupling", None)], tau_ambient_s=3 * HOUR, alpha=5.0)
    assert rules.too_small(real, "ambient_coupling", single(series, series.rows), sigma, "E") is None


def test_an_offset_of_a_few_noise_sigmas_is_an_offset():
    """Portal, 72 h, seed 48, noise x2: a hidden offset of 0.456 K on a 0.158 K sensor (2.9 sigmas,
    its own BIC gain -14800) was refused as too small under the old 3-sigma rule, and a gear switch
    was named in its place. A refit that soaks up noise moves a sensor by hundredths of a kelvin."""
    series = _series(30)
    sigma = {"T_a": 0.158, "T_b": 0.158, "E": 1.4}
    offset = lambda k: _sim([("sensor_offset", 0)], (SensorParams(3600.0, 2e-3, offset_K=k), SensorParams(3600.0, 1e-3)))
    assert rules.too_small(offset(-0.456), "sensor_offset", single(series, series.rows), sigma, "E") is None
    assert "under 1.5 times the sensor noise" in rules.too_small(offset(0.09), "sensor_offset", single(series, series.rows), sigma, "E")


def test_a_feed_that_never_changes_is_not_a_candidate():
    series = _series(30)
    still = dataclasses.replace(series, feed=np.zeros(series.rows))
    options, skipped = rules.candidates(single(still, still.rows), _sim(), still)
    assert "feed_axis_heat" not in [name for name, _ in options]
    assert skipped["feed_axis_heat"] == "the feed rate never changes in the training part"


@pytest.mark.parametrize("speeds, alike", [((1000.0, 2500.0), True), ((800.0, 1600.0, 2400.0), False)])
def test_through_two_speed_groups_a_switch_looks_like_a_curve(speeds, alike):
    found = sufficiency.look_alike(_series(30, speeds), "gear_ratio_switch")
    assert (found is not None) == alike
    if alike:
        assert found[0] == "nonlinear_speed_heat" and "2 speed groups" in found[1]
    assert sufficiency.look_alike(_series(30, speeds), "sensor_offset") is None


@pytest.mark.parametrize("rows, testable", [(5184, False), (8639, False), (8640, True), (15552, True)])
def test_slow_lags_need_a_whole_day(rows, testable):
    train = _series(50).head(rows)
    for name in ("slow_structure", "ambient_coupling"):
        why = sufficiency.untestable(train, name)
        assert (why is None) == testable, (rows, name, why)
        if why:
            assert "whole day" in why and f"covers {rows * DT / HOUR:.2f} h" in why
    assert sufficiency.untestable(train, "sensor_drift") is None


@pytest.mark.parametrize("step_at_h, level, testable", [(0.0, 33.0, True), (2.0, 33.0, True), (3.5, 33.0, False),
                                                       (0.0, 22.5, False), (0.0, 16.0, True)])
def test_an_air_moved_by_kelvins_and_recorded_for_hours_shows_an_ambient_coupling_within_a_day(step_at_h, level,
                                                                                              testable):
    """A climate chamber's step (or a hall's heating switched on) shows a lag of hours in six hours; a day is not
    needed. Its 30 min average must move 3 K with 3 h recorded after the move; a slow structure still needs a day."""
    plain = _series(6)
    train = dataclasses.replace(plain, te=hall.stepped(plain.t, np.full(plain.rows, 20.0), level, step_at_h * HOUR))
    why = sufficiency.untestable(train, "ambient_coupling")
    assert (why is None) == testable, why
    if why:
        assert "moved by at least 3 K with 3 h of recording after it" in why and "covers 6.00 h" in why
    assert "whole day" in sufficiency.untestable(train, "slow_structure")


@pytest.mark.parametrize("minutes", [0, 10])
def test_a_glitch_or_a_door_opened_for_minutes_moves_no_structure(minutes):
    """One reading 3.1 K off, or ten minutes 3.5 K off, is no air move a structure follows for hours."""
    plain = _series(6)
    air = np.full(plain.rows, 20.0)
    at = int(HOUR / DT)
    air[at:at + max(1, int(minutes * 60 / DT))] += 3.1 if minutes == 0 else 3.5
    assert "its air moves" in sufficiency.untestable(dataclasses.replace(plain, te=air), "ambient_coupling")


def test_a_constant_sensor_offset_is_not_testable_beside_a_standstill_heat_load():
    """The baseline fits a heat load per sensor; an offset on the reading is the same column."""
    why = sufficiency.untestable(_series(50), "sensor_offset")
    assert why is not None and "standstill heat load" in why


def test_several_effects_with_disagreements_left_are_not_named():
    series, rows, _ = _hidden("cascade", None, 1)
    d = search.diagnose(series, rows, "E_z_um")
    window = Window("E_z_um", 6000, 6500, 2.0)
    one = {"name": "sensor_offset", "parameters": {}, "evidence": {}}
    two = {"name": "stop_convection", "parameters": {}, "evidence": {}}
    left = dataclasses.replace(d, windows_before=[window], windows_after=[window], added=[one, two])
    assert left.verdict == "unexplained" and left.named == []
    assert "2 effects were added (sensor_offset, stop_convection)" in left.reason and "none is named" in left.reason
    assert dataclasses.replace(left, added=[one]).named == [one]
    assert dataclasses.replace(left, windows_after=[]).named == [one, two]
    air = {"name": "ambient_coupling", "parameters": {}, "evidence": {}}
    doubted = dataclasses.replace(left, added=[air], ambiguous=("ambient_coupling", "slow_structure"),
                                  ambiguity="after the ambient lag was added, ...")
    assert doubted.named == []
    assert "would fit, but the data cannot tell which" in findings.summary(doubted)


@pytest.mark.slow
def test_a_gear_switch_fitted_through_two_speed_groups_is_not_named():
    """Cascade, 24 h, seed 7: the training part runs at two speeds; the hidden nonlinear heat used to
    be named a gear switch. Now nothing is named: the reason says the two cannot be told apart, or
    (with the standstill heat load, which fits a third level at standstill) that the gaps are at
    speeds the training part never ran."""
    series, rows, _ = _hidden("cascade", "nonlinear_speed_heat", 7)
    d = search.diagnose(series, rows, "E_z_um")
    assert d.named == []
    assert ("cannot tell gear_ratio_switch from nonlinear_speed_heat" in d.reason
            or "ran at speeds outside the training part's 2000..3000 rpm: 500, 1000 rpm" in d.reason)


def test_polishing_never_raises_the_criterion():
    series, rows, _ = _hidden("cascade", "nonlinear_speed_heat", 5)
    train = series.head(rows)
    channels = (*series.names, "E_z_um")
    fitted = simulation.fit(train, [("nonlinear_speed_heat", None)], warm=simulation.fit(train))
    parts = single(series, rows)
    residual = judges.simulate(fitted, parts, channels)[1]
    sigma = {c: 1.0 for c in channels}
    first = judges.score(fitted, residual, sigma, rows)
    again, again_score = search.polish(fitted, first, parts, channels, sigma)
    assert again_score.bic <= first.bic
    plain = simulation.fit(train)
    plain_score = judges.score(plain, judges.simulate(plain, parts, channels)[1], sigma, rows)
    assert search.polish(plain, plain_score, parts, channels, sigma)[0] is plain


def _score(train: dict, held: dict) -> judges.Score:
    return judges.Score({}, {}, {}, 0.0, sum(held.values()), held, train)


def test_a_held_out_gain_counts_where_the_training_part_gives_evidence():
    """A channel fitted within the noise on the training part counts only when the candidate's refit
    cuts its training squared error by many noise variances: a slow structure whose held-out gap is
    large and whose training excess is 3 % (cut to 1 % over 15 552 rows) is real, an extrapolation
    that the training part does not move is not."""
    before = _score({"E": 1.03}, {"E": 30.0})
    fitted_better = _score({"E": 1.01}, {"E": 1.1})
    only_held_out = _score({"E": 1.0299}, {"E": 1.1})
    assert judges.held_out_gain(before, fitted_better, 15552) == pytest.approx((30.0 - 1.1) / 29.0)
    assert judges.held_out_gain(before, only_held_out, 15552) == 0.0
    visible = _score({"E": 1.2}, {"E": 30.0})
    assert judges.held_out_gain(visible, only_held_out, 15552) > 0.9


def _credible(name: str, bic: float, train: dict) -> search.Credible:
    """A candidate as the search keeps it; only the score and the name read."""
    return search.Credible(None, judges.Score(train, {}, {}, bic, 0.0, {}, {}), {}, None, 0, name)


def test_a_rival_the_held_out_part_rejects_still_makes_the_choice_a_coin_toss():
    """Portal, 72 h, seed 7 (on the 48 h structure-lag grid before issue 51): a hidden slow structure; slow
    structure and ambient lag gained the same BIC (-317 and -314) and only the held-out part preferred the
    ambient lag, which used to be named. Equal evidence on the training part is a coin toss, whichever the
    held-out part prefers: a rival need not pass the held-out judge, only gain within 2 % on the same channel."""
    before = _credible("baseline", 0.0, {"T_a": 1.0, "E_z_um": 2.0}).score
    best = _credible("ambient_coupling", -317.0, {"T_a": 1.0, "E_z_um": 1.0})
    alike = _credible("slow_structure", -314.0, {"T_a": 1.0, "E_z_um": 1.01})
    weaker = _credible("gear_ratio_switch", -250.0, {"T_a": 1.0, "E_z_um": 1.2})
    elsewhere = _credible("coolant_switching", -316.0, {"T_a": 0.5, "E_z_um": 2.0})
    assert search._rivals([best, alike, weaker, elsewhere], best, before) == [alike]


def test_a_noisy_switch_sensor_does_not_lose_the_relay_thresholds():
    """Portal, 72 h, seed 2, noise x2: the sensors used to be refitted with the relay switched by the
    raw reading while the thresholds were searched on the smoothed one; the chattering relay fitted
    no cooling and the thresholds drifted 0.7 K from the truth. Now both use the smoothed reading."""
    series, rows, effect = _hidden("portal", "coolant_switching", 2, hours=72, noise=2.0, feed=True)
    fitted = simulation.fit(series.head(rows), [("coolant_switching", 0)])
    _, on, off = fitted.shared.relay
    assert abs(on - effect.get("on_C")) < 0.15 and abs(off - effect.get("off_C")) < 0.15
    assert abs(fitted.sensors[0].cooling + effect.get("cooling_K")) < 0.25 * effect.get("cooling_K")


def test_a_slow_sensor_started_from_a_noisy_reading_settles_by_its_own_time_constant():
    """Portal, clean, seed 38: T_column (85 min) started 2.75 sigmas off; after the fixed hour its
    start error was still above the band and made a window on clean data."""
    sigma, tau = 0.08, 85 * 60.0
    t = np.arange(0, 12 * HOUR, DT)
    residual = 3.0 * sigma * np.exp(-t / tau) + np.random.default_rng(0).normal(0, sigma, t.size)
    assert windows.find_windows("T_column", residual, sigma, DT) != []
    assert windows.find_windows("T_column", residual, sigma, DT, windows.settling_s(tau)) == []
    assert windows.settling_s(600.0) == windows.SETTLING_S and windows.settling_s(30 * HOUR) == windows.MAX_SETTLING_S


def test_a_feed_lag_slower_than_a_ball_screw_is_a_stand_in():
    sim = _sim([("feed_axis_heat", None)], tau_feed_s=14.8 * HOUR, phi=2e-3)
    assert "slower than a feed axis heats" in rules.implausible(sim, "feed_axis_heat", _series(30))
    assert rules.implausible(dataclasses.replace(sim, displacement=dataclasses.replace(
        sim.displacement, tau_feed_s=1.5 * HOUR)), "feed_axis_heat", _series(30)) is None


def test_an_offset_or_drift_that_makes_its_own_sensor_worse_is_not_one():
    """Portal, 24 h, seed 4, standstill hidden: a drift on T_gearbox was named because it helped the
    displacement, while it made T_gearbox's own held-out error 14 times worse."""
    train = _series(30)
    sim = _sim([("sensor_drift", 1)])
    before = _score({}, {"T_a": 1.0, "T_b": 2.03})
    worse, better = _score({}, {"T_a": 1.0, "T_b": 28.1}), _score({}, {"T_a": 1.0, "T_b": 1.02})
    assert "T_b's own held-out error worse" in rules.worsens_own_sensor(sim, "sensor_drift", train, before, worse)
    assert rules.worsens_own_sensor(sim, "sensor_drift", train, before, better) is None
    assert rules.worsens_own_sensor(sim, "slow_structure", train, before, worse) is None


@pytest.mark.slow
def test_a_feed_lag_that_only_marks_the_running_is_not_named():
    """Cascade, 24 h, seed 1, a slow structure hidden (not testable under a day): a 0.7 h lag of the feed rate
    stood in for it on the 48 h structure-lag grid; on the bounded grid of issue 51 its lag fits at 20 h and is
    refused as slower than a feed axis. The rule itself: a feed that is one level while the spindle runs only
    marks the running, and a feed lag fitted on it is refused because the feed at its mean fits as well."""
    series, rows, _ = _hidden("cascade", "slow_structure", 1, feed=True)
    d = search.diagnose(series, rows, "E_z_um")
    assert d.named == []
    feed = [t for rnd in d.rounds for t in rnd if t.name == "feed_axis_heat"]
    assert feed and "stand-in" in feed[0].rejected_because
    marks = dataclasses.replace(series, feed=np.where(series.n > 0, 900.0, 0.0))
    parts = single(marks, rows)
    channels = (*marks.names, "E_z_um")
    base = identify.fit(parts.train)[0]
    trial = judges.refit(parts.train, (("feed_axis_heat", None),), base)
    sigma = {c: 1.0 for c in channels}
    trial_score = judges.score(trial, judges.simulate(trial, parts, channels)[1], sigma, rows)
    assert "does not follow the feed" in rules.follows_running(trial, trial_score, parts, channels, sigma)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 5), st.integers(1, 400), st.floats(0.0, 0.99999), st.integers(0, 2 ** 32 - 1))
def test_columns_lagged_together_have_the_bits_of_one_by_one(columns, rows, pole, seed):
    rng = np.random.default_rng(seed)
    x = rng.normal(0, 1e3, (rows, columns)) * 10.0 ** rng.integers(-30, 30, (rows, columns))
    y0 = rng.normal(0, 50, columns)
    together = primitives.lag_columns(x, pole, y0)
    for i in range(columns):
        alone = simulation.lag(x[:, i], pole, y0[i])
        assert together[:, i].view(np.uint64).tolist() == alone.view(np.uint64).tolist()


def test_a_white_residual_counts_every_row_and_a_slow_misfit_a_handful():
    rng = np.random.default_rng(11)
    white = rng.normal(0.0, 0.05, 5000)
    slow = 3.0 * np.sin(np.linspace(0.0, 3.0, 5000)) + white
    assert judges.effective_rows(white) > 0.9 * 5000
    assert judges.effective_rows(slow) < 5
    assert judges.effective_rows(np.zeros(10)) == 10.0


def test_an_effect_that_only_bends_toward_a_slow_misfit_earns_no_bic():
    """Halving a slow misfit (a real machine the model cannot follow) is worth a few units; leaving
    white noise behind is worth thousands, as the plain BIC says."""
    rng = np.random.default_rng(12)
    noise = rng.normal(0.0, 0.05, 4000)
    misfit = 2.0 * np.sin(np.linspace(0.0, 4.0, 4000))
    before = {"E": misfit + noise}
    bent = judges.effective_delta_bic(before, {"E": 0.5 * misfit + noise}, 2, 4000)
    explained = judges.effective_delta_bic(before, {"E": noise}, 2, 4000)
    assert bent > -judges.BIC_MARGIN
    assert explained < -1000.0
