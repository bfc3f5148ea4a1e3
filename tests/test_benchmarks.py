"""The papers' comparison script runs and fills every row (its numbers are in the README)."""
import numpy as np
import pytest
from benchmarks import papers


@pytest.mark.slow
def test_papers_benchmark_fills_its_table(capsys, monkeypatch):
    monkeypatch.setattr(papers, "PAPER_002_SEEDS", 2)  # the table's shape, not the medians
    papers.ROWS.clear()
    papers.main()
    assert [r[0] for r in papers.ROWS] == ["000"] * 6 + ["001"] * 2 + ["002"] * 2 + ["003"] * 3 + ["004"] * 3
    assert all(r[3] and "nan" not in r[3] for r in papers.ROWS)


def test_replay_benchmark_reports_every_block_and_engine_as_json(capsys, monkeypatch):
    import json
    import sys
    from benchmarks import replay
    monkeypatch.setattr(sys, "argv", ["replay.py", "--cycles", "20000", "--interp-cycles", "300", "--json"])
    replay.main()
    result = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert set(result) == {"mlr", "kalman", "piecewise", "dlag", "gm0n", "gm1n", "bayes", "bpnn", "lumped", "lumped_identified"}
    assert all(set(r) == {"interp", "fast", "c_plain", "reference"} and min(r.values()) > 0 for r in result.values())


def test_diagnose_benchmark_counts_outcomes_per_machine_length_and_noise():
    from benchmarks import diagnose
    base = {"machine": "portal", "hours": 72.0, "seed": 1, "parameters": {}, "reason": None, "channel": "E_z_um",
            "before": 2.0, "after": 0.5, "seconds": 3.0}
    runs = [{**base, "noise": 1.0, "effect": "sensor_offset", "verdict": "explained", "found": ["sensor_offset"]},
            {**base, "noise": 1.0, "effect": "sensor_offset", "verdict": "unexplained", "found": ["sensor_drift"]},
            {**base, "noise": 1.0, "effect": "none", "verdict": "no_missing_effect", "found": []},
            {**base, "noise": 2.0, "effect": "sensor_offset", "verdict": "explained",
             "found": ["sensor_offset", "stop_convection"]},
            {**base, "noise": 2.0, "effect": "sensor_offset", "verdict": "no_missing_effect", "found": [],
             "excess_inside_class": 0.5},
            {**base, "noise": 2.0, "effect": "sensor_offset", "verdict": "no_missing_effect", "found": [],
             "excess_inside_class": 0.02, "windows_inside_class": 0},
            {**base, "noise": 2.0, "effect": "sensor_offset", "verdict": "explained", "found": ["sensor_drift"],
             "excess_inside_class": 0.02, "windows_inside_class": 0},
            {**base, "noise": 2.0, "effect": "sensor_offset", "verdict": "explained", "found": ["sensor_offset"],
             "excess_inside_class": 0.02, "windows_inside_class": 0},
            {**base, "noise": 2.0, "effect": "sensor_offset", "verdict": "no_missing_effect", "found": [],
             "excess_inside_class": 0.02, "windows_inside_class": 1}]
    assert [diagnose.outcome(r) for r in runs] == ["right", "wrong", "right", "right+others", "missed",
                                                   "inside class", "wrong", "inside class", "missed"]
    rows = [line for line in diagnose.table(runs) if "`sensor_offset`" in line]
    assert rows == ["| portal | 72 | x1 | `sensor_offset` | 2 | 1 | 0 | 0 | 0 | 0 | 1 | 2.000 | 0.500 | 3.0 | 3.0 |",
                    "| portal | 72 | x2 | `sensor_offset` | 6 | 0 | 1 | 2 | 0 | 2 | 2 | 2.000 | 0.500 | 3.0 | 3.0 |"]
    first, second = diagnose.summary(runs)
    assert first.startswith("portal 72 h noise x1: clean reads no_missing_effect 1/1 (100 %)")
    assert "right name alone 1/2 (50 %)" in first and "a wrong name 1/3 (33 %) of all runs" in first
    assert second.startswith("portal 72 h noise x2") and "a wrong name 2/6 (33 %)" in second
    assert ("right name alone 0/4 (0 %) of the runs whose effect is outside the baseline's class "
            "(2 inside it left out, 1 of them named anyway)") in second


def test_diagnose_real_benchmark_counts_names_verdicts_and_visible_runs_per_channel():
    from benchmarks import diagnose_real
    from thermoplc.physics.effects import NAMES
    assert set(diagnose_real.LIBRARY) | set(diagnose_real.SKIPPED) == set(NAMES)
    base = {"channel": "ch3_um", "seed": 1, "parameters": {}, "reason": None, "before": 20.0, "after": 10.0,
            "seconds": 15.0}
    big, small = {"ch3_um": 5.0, "t5_C": 1.0}, {"ch3_um": 2.0}
    runs = [{**base, "effect": "sensor_drift", "verdict": "explained", "found": ["sensor_drift"], "size_sigmas": big},
            {**base, "effect": "sensor_drift", "verdict": "unexplained", "found": [], "size_sigmas": big},
            {**base, "effect": "sensor_drift", "verdict": "explained", "found": ["sensor_drift", "slow_structure"],
             "size_sigmas": big},
            {**base, "effect": "sensor_drift", "verdict": "explained", "found": ["sensor_drift"], "size_sigmas": small},
            {**base, "effect": "sensor_offset", "verdict": "no_missing_effect", "found": [],
             "size_sigmas": {"t5_C": 0.0}},
            {**base, "effect": "step", "verdict": "explained", "found": ["slow_structure"], "size_sigmas": big},
            {**base, "effect": "step", "verdict": "unexplained", "found": [], "size_sigmas": big},
            {**base, "effect": "none", "verdict": "unexplained", "found": ["sensor_drift"], "size_sigmas": {}},
            {**base, "channel": "ch5_um", "effect": "periodic", "verdict": "insufficient_data", "found": [],
             "size_sigmas": small}]
    assert [diagnose_real.visible(r) for r in runs] == [True, True, True, False, False, True, True, False, False]
    assert [diagnose_real.wrong_name(r) for r in runs] == [False, False, True, False, False, True, False, True, False]
    assert [line for line in diagnose_real.table(runs) if "`" in line] == [
        "| ch3_um | `sensor_offset` | 1 | 0 | 0 | 0 | 0 | 1 | 0 | 0 | 0 | 20.000 | 10.000 | 15.0 | 15.0 |",
        "| ch3_um | `sensor_drift` | 4 | 3 | 2 | 1 | 1 | 0 | 3 | 1 | 0 | 20.000 | 10.000 | 15.0 | 15.0 |",
        "| ch3_um | `step` | 2 | 2 | 0 | 0 | 1 | 0 | 1 | 1 | 0 | 20.000 | 10.000 | 15.0 | 15.0 |",
        "| ch3_um | `none` | 1 | 0 | 0 | 0 | 1 | 0 | 0 | 1 | 0 | 20.000 | 10.000 | 15.0 | 15.0 |",
        "| ch5_um | `periodic` | 1 | 0 | 0 | 0 | 0 | 0 | 0 | 0 | 1 | 20.000 | 10.000 | 15.0 | 15.0 |"]
    ch3, ch5 = diagnose_real.summary(runs)
    assert ch3.startswith("ch3_um: right name alone 1/3 (33 %) of the library runs whose effect exceeds 3 noise sigmas")
    assert "1 of them a name the clean recording gives too (2/5 (40 %) of all library runs)" in ch3
    assert "a wrong name 3/8 (38 %) of all runs" in ch3
    assert ch3.endswith("clean recording: unexplained naming sensor_drift; step: explained naming slow_structure; "
                        "unexplained; periodic: not run")
    assert ch5.startswith("ch5_um: right name alone 0/0 (0 %)") and ch5.endswith("periodic: insufficient_data")


def test_evidence_bound_credits_a_shape_in_white_noise_not_in_a_slow_misfit_and_names_only_past_clean():
    from benchmarks import evidence_real
    rng = np.random.default_rng(5)
    rows = 4000
    shape = np.sin(np.linspace(0.0, 12.0, rows))
    white = 0.5 * rng.standard_normal(rows)
    walk = np.cumsum(0.05 * rng.standard_normal(rows))
    assert evidence_real._lr(white + 0.2 * shape, shape) > 100.0
    assert evidence_real._lr(white, shape) < 10.0
    assert evidence_real._lr(walk + 0.2 * shape, shape) < 20.0  # a few effective rows, however many samples
    bar = evidence_real.penalty(rows)
    assert bar == pytest.approx(np.log(rows) + 10.0)
    run = {"rows": rows, "injected": {"levels": bar + 1, "innovations": bar + 1, "temperatures": 0.0},
           "clean": {"levels": 0.0, "innovations": bar + 5, "temperatures": 0.0}}
    assert evidence_real.nameable(run) == "levels"


def test_real_injections_scale_to_multiples_of_the_channels_spread_and_the_oracle_row_says_the_baseline():
    """Issue 39 items 4-5: --size draws the displacement's peak in multiples of the channel's standard deviation;
    the oracle's rows give the identified baseline's held-out RMSE beside none (the training mean)."""
    from benchmarks import diagnose_real, evidence_real
    data = diagnose_real.columns()
    spread = float(np.std(data["ch3_um"]))
    for name in ("slow_structure", "ambient_coupling", "gear_ratio_switch"):
        changes, _ = diagnose_real.inject(name, data, "ch3_um", 2, (0.6, 1.0))
        assert 0.6 * spread <= np.max(np.abs(changes["ch3_um"])) <= 1.0 * spread
        default, _ = diagnose_real.inject(name, data, "ch3_um", 2)
        assert 4.0 <= np.max(np.abs(default["ch3_um"])) <= 8.0
    row = evidence_real.one(("ch3_um", "ambient_coupling", 1, (0.6, 1.0), None, False, False))
    assert row["baseline_held_out_um"] < row["none_held_out_um"] and row["peak_um"] >= 0.6 * spread
    assert "| not run |" in evidence_real.table([row])[-1]


def test_campaign_benchmark_counts_right_wrong_and_clean_campaigns():
    """Issue 39 item 5: twin campaigns, the effect in every run: right alone, beside others, not named, wrong."""
    from benchmarks import diagnose_campaign
    base = {"machine": "cascade", "seed": 1, "runs": 6, "hours": 12.0, "some": False, "parameters": {},
            "reason": None, "before": 2.0, "after": 1.0, "seconds": 10.0, "added": []}
    runs = [{**base, "effect": "gear_ratio_switch", "verdict": "explained", "found": ["gear_ratio_switch"]},
            {**base, "effect": "gear_ratio_switch", "verdict": "unexplained", "found": []},
            {**base, "effect": "gear_ratio_switch", "verdict": "explained",
             "found": ["gear_ratio_switch", "slow_structure"]},
            {**base, "effect": "gear_ratio_switch", "verdict": "explained", "found": ["coolant_switching"]},
            {**base, "effect": "none", "verdict": "no_missing_effect", "found": []}]
    assert [diagnose_campaign.outcome(r) for r in runs] == ["right", "not named", "right+others", "wrong", "right"]
    assert [line for line in diagnose_campaign.table(runs) if "`gear_ratio_switch`" in line] == [
        "| cascade | `gear_ratio_switch` | 4 | 1 | 1 | 1 | 2 | explained 3, unexplained 1 | 2.00 | 1.00 | 10.0 |"]
    (line,) = diagnose_campaign.summary(runs)
    assert line.startswith("cascade: right name alone 1/4 (25 %)") and "a wrong name 2/5 (40 %)" in line
    assert "clean campaigns naming nothing 1/1 (100 %)" in line


def test_the_oracle_summary_puts_diagnose_beside_it_on_the_runs_it_can_name():
    from benchmarks import evidence_real
    strong = {"levels": 100.0, "innovations": 0.0, "temperatures": 0.0}
    weak = {"levels": 1.0, "innovations": 0.0, "temperatures": 0.0}
    base = {"channel": "ch3_um", "seed": 1, "rows": 5760, "peak_um": 20.0, "baseline_held_out_um": 7.0}
    runs = [{**base, "effect": "slow_structure", "injected": strong, "clean": weak, "diagnose_found": ["slow_structure"],
             "diagnose": "explained naming slow_structure"},
            {**base, "effect": "gear_ratio_switch", "injected": strong, "clean": weak, "diagnose": "unexplained naming "
             "coolant_switching"},
            {**base, "effect": "ambient_coupling", "injected": weak, "clean": weak, "peak_um": 10.0,
             "diagnose": "unexplained"},
            {**base, "effect": "none", "injected": weak, "clean": weak, "diagnose": "unexplained"}]
    first, second = evidence_real.summary(runs)
    assert first.startswith("ch3_um: an oracle that knows the injected shape could name 2 of 3 library runs")
    assert "right name alone 1/2 (50 %) of the runs the oracle can name" in second
    assert "1/2 (50 %) of the runs whose peak is at least twice" in second and "oracle's count, 2]" in second
    assert "a wrong name 1/4 (25 %) of all runs" in second and "clean recording: unexplained" in second
