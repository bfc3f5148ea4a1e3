"""The offset-only block is offered only where the static part fails to compensate, and only its own evidence makes a
zero block one (fitting/offset_only.py)."""
from __future__ import annotations

from dataclasses import replace

from tests.cli_runner import thermoplc
from thermoplc.fitting.offset_only import is_offset_only, zeroed
from thermoplc.models.model import Coefficient
from thermoplc.models.modelfile import load_model


def test_a_model_that_compensates_on_too_few_rows_keeps_its_static_part(tmp_path):
    thermoplc("twin", "--runs", 6, "--hours", 4, "--dt", 60, "--seed", 5, "--probe-minutes", 30, "-o", "runs",
              cwd=tmp_path)
    out = thermoplc("fit", "--data", "runs", "--model", "dlag", "--target", "E_z_um", "--temps",
                    "T_motor,T_bearing,T_struct", "--held-target", "--folds", 6, "--probe", "-o", "dp.json",
                    cwd=tmp_path)
    model = load_model(str(tmp_path / "dp.json"))
    assert "OFFSET-ONLY" not in out.stdout and "fewer than 100 held-out rows" in out.stderr
    assert any(c.f64 != 0.0 for c in model.coefficients.values()) and not is_offset_only(model)
    hand_zeroed = zeroed(model)
    assert not is_offset_only(hand_zeroed)  # its evidence is the fitted model's, not a zero block's
    assert not is_offset_only(replace(hand_zeroed, coefficients={**hand_zeroed.coefficients,
                                                                 "beta0": Coefficient(1.0, 1.0)}))
