"""Paper 004's Bayesian network: discretisation, the block's lookup, and every table entry checked."""
import numpy as np

from tests.conftest import fit_small
from tests.test_piecewise import table_mutants
from thermoplc.generator.lower import lower
from thermoplc.generator.printer import render
from thermoplc.models.bayes import configuration, interval
from thermoplc.verifier.replay import verify_against_model


def test_intervals_and_configuration_index():
    edges = [1.0, 2.0, 3.0]
    assert interval(np.array([-5, 0.99, 1.0, 2.5, 3.0, 99]), edges).tolist() == [0, 0, 1, 2, 3, 3]
    assert configuration([np.array([1, 3]), np.array([2, 0])], [4, 5]).tolist() == [1 + 4 * 2, 3]


def test_every_table_entry_of_the_bayes_block_is_checked(twin_table, tmp_path):
    model = fit_small(twin_table, "bayes")
    model_path = tmp_path / "bayes.json"
    model_path.write_text(model.to_json())
    text = render(lower(model))
    (tmp_path / "bayes.scl").write_text(text)
    assert verify_against_model(str(tmp_path / "bayes.scl"), model, str(model_path), twin_table).ok
    entries = 0
    for entry, mutant in table_mutants(text):
        (tmp_path / "mutant.scl").write_text(mutant)
        report = verify_against_model(str(tmp_path / "mutant.scl"), model, str(model_path), twin_table)
        assert not report.ok, f"{entry} changed by one ULP went unnoticed"
        assert any(e.startswith(entry) for e in report.constant_errors)
        entries += 1
    expected = sum(k - 1 for k in model.settings["intervals"]) + model.settings["configurations"]
    assert entries == expected
