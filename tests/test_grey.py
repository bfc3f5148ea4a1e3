"""Issue 14: the grey models are right, not only exact. GM(1,N) recovers the grey difference
equation that made its data and beats no compensation on a recording it was not fitted on."""
import json

import numpy as np
import pytest

from thermoplc.models import grey
from thermoplc.fitting.fit import FitRequest, fit
from thermoplc.models.reference import model_inputs, predict
from thermoplc.recordings.table import read_table, write_table
from thermoplc.machines.cascade import simulate
from thermoplc.models.kind import Part


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


@pytest.mark.parametrize("kind", ["gm0n", "gm1n"])
def test_on_a_real_campaign_the_grey_kinds_beat_a_ridge_on_their_own_sensors(kind):
    """Issue 62: on FL_THERMAL cut into 6 h runs, the paper's estimate (one split choosing readings or rises,
    a chosen within each run) was 6.31 (gm0n) and 7.40 um (gm1n) held out where a ridge on the same four
    sensors' rises gives 5.95; chosen leaving out each run, each estimate is judged on runs it did not fit."""
    import math
    from benchmarks.campaign import fl_thermal_runs
    from thermoplc.fitting.crossval import fit_held_out
    runs = fl_thermal_runs("ch5_um", 6.0, 0)
    model = fit_held_out(runs, FitRequest(kind=kind, target="ch5_um", temps=("t8_C", "t4_C", "t5_C", "t11_C"),
                                          train_until=math.inf), len(runs))
    held = model.metrics["held_out"]
    assert held["rmse_um"] < held["ridge_rmse_um"]
    assert f"leaving out each of {len(runs)} runs" in json.dumps(model.fit)


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
    assert 0 < model["settings"]["a"] < 2
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
