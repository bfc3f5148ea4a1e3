"""Issue 14: the grey models are right, not only exact. GM(1,N) recovers the grey difference
equation that made its data and beats no compensation on a recording it was not fitted on."""
import json
from dataclasses import replace

import numpy as np
import pytest

from thermoplc.models.kinds import grey
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.reference import model_inputs, predict
from thermoplc.recordings.table import read_table, write_table
from thermoplc.machines.cascade import simulate
from thermoplc.models.kind import Part
from thermoplc.models.model import Coefficient


def _grey_difference_data(a: float, b: np.ndarray, rows: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Temperatures and an error that follow x(k) + a*(X(k) + X(k-1))/2 = sum_i b_i*S_i(k) exactly."""
    rng = np.random.default_rng(seed)
    temps = 20.0 + np.cumsum(rng.normal(0.0, 0.05, (rows, len(b))), axis=0)
    sums = np.cumsum(temps, axis=0)
    x = np.empty(rows)
    accumulated = 0.0
    x[0] = 3.0
    accumulated = x[0]
    for k in range(1, rows):
        x[k] = (sums[k] @ b - a * accumulated) / (1.0 + a / 2.0)
        accumulated += x[k]
    return temps, x


@pytest.mark.parametrize("a, b, seed", [(0.01, [0.004, -0.002], 1), (0.2, [0.05, 0.01, -0.03], 2),
                                         (0.0016, [0.0003, 0.0001], 3)])
def test_gm1n_recovers_the_equation_that_made_its_data(tmp_path, a, b, seed):
    temps, x = _grey_difference_data(a, np.array(b), 2000, seed)
    coefficients, settings, log = grey.fit_gm1n([Part(temps, x, np.empty((len(x), 0)), None, None)], [f"T_{i}" for i in range(len(b))], 10.0)
    assert log["least_squares_a"] == settings["a"]  # it settles within the training span: the paper's a is kept
    assert settings["a"] == pytest.approx(a, rel=1e-6)
    assert np.allclose(settings["b"], b, rtol=1e-5, atol=1e-12)
    columns = {"time_s": np.arange(len(x)) * 10.0, "E": x, **{f"T_{i}": temps[:, i] for i in range(len(b))}}
    (tmp_path / "made.csv").write_text(write_table(columns))
    data = read_table(tmp_path / "made.csv")
    model = fit([data], FitRequest("gm1n", "E", tuple(f"T_{i}" for i in range(len(b))), train_rows=1500))
    predicted = predict(model, model_inputs(model, data), "f64")["E"]
    assert np.max(np.abs(predicted - x)) < 1e-6 * max(1.0, np.max(np.abs(x)))


def test_gm1n_beats_no_compensation_on_held_out_twin_data(tmp_path):
    (tmp_path / "twin.csv").write_text(write_table(simulate(48, seed=3)))
    data = read_table(tmp_path / "twin.csv")
    split = data.rows // 2
    model = fit([data], FitRequest("gm1n", "E_z_um", ("T_motor", "T_bearing"), train_rows=split))
    measured = data.columns["E_z_um"]
    residual = predict(model, model_inputs(model, data), "f32")["E_z_um"] - measured
    rms = lambda r: float(np.sqrt(np.mean(r ** 2)))
    assert rms(residual[:split]) < 0.5 * rms(measured[:split] - measured[:split].mean())
    assert rms(residual[split:]) < rms(measured[split:])


@pytest.mark.parametrize("kind", ["gm0n", "gm1n"])
def test_grey_blocks_stay_on_their_model_over_a_simulated_year(tmp_path, kind):
    """Issue 37 item 8: a year of calls every 10 s (3.2 million) with the temperatures swinging daily;
    the binary32 block (its reference, proved bit-exact elsewhere) stays within 0.01 um of the float64
    model, and its distance does not grow: the last day's is that of the second (the constants' rounding
    through a settled filter), where running sums would have grown by the year's sum of temperatures
    (binary32 steps of 0.25 and more once a sum passes 4e6)."""
    path = tmp_path / "twin.csv"
    path.write_text(write_table(simulate(24.0, seed=3)))
    table = read_table(path)
    request = FitRequest(kind=kind, target="E_z_um", temps=("T_motor", "T_bearing"), train_rows=table.rows)
    model = fit([table], request)
    calls = 365 * 24 * 360
    t = np.arange(calls) * 10.0
    day = np.sin(2 * np.pi * t / 86400.0)
    inputs = {"T_motor": 30.0 + 8.0 * day, "T_bearing": 27.0 + 5.0 * np.roll(day, 500)}
    block = predict(model, inputs, "f32")["E_z_um"].astype(np.float64)
    ideal = predict(model, inputs, "f64")["E_z_um"]
    assert np.all(np.isfinite(block))
    distance = np.abs(block - ideal)
    day = 86400 // 10
    assert float(np.max(distance)) < 0.01
    assert float(np.max(distance[-day:])) <= 1.5 * float(np.max(distance[day:2 * day])) + 1e-6


EVERY_FL_SENSOR = tuple(f"t{i}_C" for i in range(1, 17) if i != 6)  # t6 is the ambient


@pytest.mark.parametrize("kind, target, probe_minutes, temps, before", [
    ("gm0n", "ch5_um", 30.0, EVERY_FL_SENSOR, 1.63), ("gm1n", "ch3_um", 0.0, EVERY_FL_SENSOR, 1.87),
    ("gm0n", "ch5_um", 0.0, ("t8_C", "t4_C", "t5_C", "t11_C"), None),
    ("gm1n", "ch5_um", 0.0, ("t8_C", "t4_C", "t5_C", "t11_C"), None)])
def test_on_a_real_campaign_the_grey_kinds_stay_near_a_ridge_on_their_own_sensors(kind, target, probe_minutes, temps,
                                                                                   before):
    """Issue 62: on FL_THERMAL cut into 6 h runs each run predicted from the others, every kind within 1.25 x a
    ridge on the same sensors' rises. Before the unit sequence, the rises on every campaign and the one-standard-
    error rule, GM(0,N) on ch5 probed every 30 min and GM(1,N) on ch3 (every sensor) were the `before` multiple
    (the readings won seven runs and missed the eighth by 12.6 um); with four sensors both were within 1.1 x."""
    import math
    from benchmarks.campaign import fl_thermal_runs
    from thermoplc.fitting.crossval import fit_held_out
    runs = fl_thermal_runs(target, 6.0, probe_minutes)
    model = fit_held_out(runs, FitRequest(kind=kind, target=target, temps=temps, train_until=math.inf), len(runs))
    held = model.metrics["held_out"]
    assert held["rmse_um"] <= (1.25 if before else 1.1) * held["ridge_rmse_um"], held
    assert f"leaving out each of {len(runs)} runs" in json.dumps(model.fit)
    assert model.settings["rises"] is True


@pytest.mark.parametrize("kind", ["gm0n", "gm1n"])
def test_a_sensor_that_never_rises_within_a_run_is_refused_by_name_on_a_campaign(kind):
    """Its readings differ from run to run but its rises, the sequences a campaign is fitted on, are all 0
    (found by a review: GM(1,N) checked the readings and fitted b = 0 where GM(0,N) refused)."""
    import math
    from thermoplc.base.errors import UserError
    from thermoplc.recordings.table import Table
    from benchmarks.campaign import fl_thermal_runs
    runs = [Table(r.path, {**r.columns, "t1_C": np.full(len(r.columns["t1_C"]), 20.0 + k)}, r.sha256, r.lines)
            for k, r in enumerate(fl_thermal_runs("ch5_um", 6.0, 0)[:3])]
    with pytest.raises(UserError, match="t1_C"):
        fit(runs, FitRequest(kind=kind, target="ch5_um", temps=("t8_C", "t1_C"), train_until=math.inf), "time_s")


@pytest.mark.parametrize("kind", ["gm0n", "gm1n"])
def test_a_campaign_block_with_its_unit_sequence_is_bit_exact_and_every_coefficient_is_checked(kind, tmp_path):
    """The unit sequence's coefficient b_0 enters the block first (and twice at GM(1,N)'s second call, where its
    running sum is 2): the block reproduces the reference, and b_0 or any b_i moved one ULP fails verify by name."""
    import math
    from benchmarks.campaign import fl_thermal_runs
    from tests.test_bayes import _constant_mutants
    from thermoplc.generator.lower import lower
    from thermoplc.generator.printer import render
    from thermoplc.verifier.replays.replay import verify_against_model
    runs = fl_thermal_runs("ch5_um", 6.0, 0)[:4]
    model = fit(runs, FitRequest(kind=kind, target="ch5_um", temps=("t8_C", "t4_C", "t5_C", "t11_C"),
                                 train_until=math.inf), "time_s")
    assert "b_0" in model.coefficients and model.coef("b_0") != 0.0
    model_path = tmp_path / "grey.json"
    model_path.write_text(model.to_json())
    text = render(lower(model))
    (tmp_path / "grey.scl").write_text(text)
    assert verify_against_model(str(tmp_path / "grey.scl"), model, str(model_path), runs[1]).ok
    mutants = list(_constant_mutants(text, "b"))
    assert [name for name, _ in mutants] == [f"c_b_{i}" for i in range(5)]
    for name, mutant in mutants:
        (tmp_path / "mutant.scl").write_text(mutant)
        report = verify_against_model(str(tmp_path / "mutant.scl"), model, str(model_path), runs[1])
        assert not report.ok and any(e.startswith(name) for e in report.constant_errors), name


def test_the_unit_sequence_enters_the_block_as_the_fit_modelled_it():
    """GM(1,N)'s output with b_0 (float64 reference) equals the output the campaign fit scored: the grey
    recursion of the unit sequence's running sums (2 at the second call), not only of its steps."""
    import math
    from benchmarks.campaign import fl_thermal_runs
    runs = fl_thermal_runs("ch5_um", 6.0, 0)[:4]
    temps = ("t8_C", "t4_C", "t5_C", "t11_C")
    fitted = fit(runs, FitRequest(kind="gm1n", target="ch5_um", temps=temps, train_until=math.inf), "time_s")
    # an offset of 5 um (the fit's is a few nm on these rises): a b_0 counted once at the second call moves it 5 um
    model = replace(fitted, coefficients={**fitted.coefficients, "b_0": Coefficient.of(5.0)})
    a, first = model.settings["a"], model.coef("X1")
    b = np.array([model.coef(f"b_{i}") for i in range(5)])
    table = runs[2]
    part = Part(np.column_stack([table.columns[c] for c in temps]), table.columns["ch5_um"],
                np.empty((len(table.columns["ch5_um"]), 0)), None, None)
    design, offset = grey._output_pieces(grey.accumulate(grey.sequences(part, True, True)), first, a)
    modelled = np.r_[first, design @ b + offset]
    reference = predict(model, model_inputs(model, table), "f64")["ch5_um"]
    assert np.max(np.abs(reference - modelled)) < 1e-3  # Keep and In stored, a not: 2e-5 um apart


# Two short runs whose own least-squares a is in (0, 2) each (1.98, 1.67) but 2.016 on both: the paper's estimate
# wins leaving out each run, yet its fit on every run never settles (found by a review; a traceback before).
PAPER_UNSETTLED_ON_BOTH = ('time_s,t1_C,y_um\n0,16.132936360555384,-0.5861190276832553\n15,15.999658860049518,-9.347726603410903\n30,16.028333321472598,-5.887444975658146\n45,16.386418715992818,-5.648987938149848\n60,15.567628472594842,-4.701784889997382\n75,15.369956670092293,-4.450274906896559\n90,15.246011383482173,-4.95139575094581\n105,14.912449798982891,-4.467031641658046\n120,14.23400031926728,-4.305512272582255\n135,14.052875134894261,-4.510798416259749\n150,13.807432557713334,-4.489982573080263\n165,12.88277131777258,-4.182049750820774\n180,12.502808202095446,-4.340458125517801\n195,12.340039960939947,-4.1502699986083735\n', 'time_s,t1_C,y_um\n0,7.876112568424784,-2.175472499858349\n15,7.68002742818975,-2.723222470434208\n30,7.856206106234676,-2.8065689095614967\n45,7.576179315789658,-1.7838134127692418\n60,7.150497682257555,-2.5935571591775766\n75,7.477677139636688,-1.9810785691041142\n90,7.7151712678795565,-2.3221198825281935\n105,7.887355612089409,-2.6799998862978702\n120,7.597871710520735,-2.3947996725103113\n135,7.7484013322249154,-2.6412811564028504\n150,7.4072995327804705,-2.5426556602507\n165,7.756653493167139,-2.7376351302257893\n180,7.65780194660649,-2.2716225412554607\n195,7.058336707884374,-1.9861232491442224\n210,6.936097673741272,-2.3643524642435896\n225,7.233595034123738,-2.0867827712626976\n240,6.2668060570114905,-2.1211575354901386\n255,6.092626213060475,-2.186650030406917\n270,6.19675973111269,-2.0922539102656175\n285,6.320127614562291,-1.8621767888029888\n300,6.492736902847081,-2.147106776299645\n315,6.477342864982918,-1.611377568397332\n330,6.24775861939796,-1.7838126844367779\n345,6.337348726359204,-2.0725350787960353\n360,6.55866243344078,-2.108784823055006\n375,6.694555408325394,-2.0372517046330127\n390,6.494123798299897,-2.243380761613364\n405,6.129283434495997,-1.5655407780348298\n420,6.005666754871724,-2.063430548440681\n')


def test_a_paper_estimate_that_does_not_settle_on_every_run_gives_way_to_the_next(tmp_path):
    from tests.cli_runner import thermoplc
    (tmp_path / "runs").mkdir()
    for k, text in enumerate(PAPER_UNSETTLED_ON_BOTH, start=1):
        (tmp_path / "runs" / f"run{k}.csv").write_text(text)
    thermoplc("fit", "--data", "runs", "--model", "gm1n", "--target", "y_um", "--temps", "t1_C", "--folds", 2,
              "-o", "m.json", cwd=tmp_path)
    model = json.loads((tmp_path / "m.json").read_text())
    assert 0 < model["settings"]["a"] <= 2  # 2: no memory, the shrunk linear fit
    assert "the paper's" not in model["fit"]["method"]


def test_the_grid_of_time_constants_spans_the_longest_run_not_the_shortest(tmp_path):
    """An aborted 11-row run beside three of 6 h once capped every time constant at 165 s (found by a review)."""
    import math
    from benchmarks.campaign import fl_thermal_runs
    from thermoplc.fitting.fit import fit
    from thermoplc.recordings.table import Table
    runs = fl_thermal_runs("ch5_um", 6.0, 0)[:4]
    runs[3] = Table(runs[3].path, {c: v[:11] for c, v in runs[3].columns.items()}, runs[3].sha256, runs[3].lines[:11])
    model = fit(runs, FitRequest(kind="gm1n", target="ch5_um", temps=("t8_C", "t4_C", "t5_C", "t11_C"),
                                 train_until=math.inf), "time_s")
    assert model.settings["time_constant_s"] > 600.0
