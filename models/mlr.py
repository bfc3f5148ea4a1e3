"""Plain regression (paper 000 eq. 10-11, 16): E = beta0 + sum_i beta_i * (T_i - T_i[first call])."""
from __future__ import annotations

import numpy as np

from thermoplc.errors import UserError
from thermoplc.models.modelfile import Model


# Above this condition number of the standardised columns, binary32 (about 7 digits) cannot
# resolve the slopes: they come out large, of opposite sign, and cancel in the block.
CONDITION_LIMIT = 1e6


def refuse_flat(features: np.ndarray, names: list[str]) -> None:
    """A column that does not move on the training rows has no slope to fit: refuse it by name."""
    spread = (features - features.mean(axis=0)).std(axis=0)
    flat = [names[i] for i in np.nonzero(spread <= 1e-12 * np.maximum(np.abs(features).max(axis=0), 1.0))[0]]
    if flat:
        raise UserError(f"{', '.join(flat)} does not change on the training rows: its slope cannot be fitted; "
                        f"drop it or train on data where it moves")


def least_squares(features: np.ndarray, target: np.ndarray, names: list[str]) -> np.ndarray:
    """Intercept + slopes by least squares; refuses constant or collinear columns, naming them,
    instead of returning huge slopes (the papers' multicollinearity problem)."""
    features = np.asarray(features, float).reshape(len(target), -1)
    refuse_flat(features, names)
    centred = features - features.mean(axis=0)
    spread = centred.std(axis=0)
    if features.shape[1] > 1:
        _, singular, vt = np.linalg.svd(centred / spread, full_matrices=False)
        condition = singular[0] / max(singular[-1], 1e-300)
        if condition > CONDITION_LIMIT:
            weights = np.abs(vt[-1])
            involved = [names[i] for i in np.nonzero(weights >= 0.25 * weights.max())[0]]
            raise UserError(f"{', '.join(involved)} are collinear on the training rows (condition number "
                            f"{condition:.3g} > {CONDITION_LIMIT:.0e}, more than binary32 resolves): their slopes "
                            f"would be huge and cancel; keep one of them (select-sensors groups such sensors)")
    design = np.column_stack([np.ones(len(target)), features])
    return np.linalg.lstsq(design, target, rcond=None)[0]


def fit_mlr(temps: np.ndarray, target: np.ndarray, names: list[str]) -> dict[str, float]:
    """temps: (rows, sensors) training rows; ΔT is taken from the first training row, as the block does."""
    beta = least_squares(temps - temps[0], target, names)
    return {"beta0": beta[0], **{f"beta_{i + 1}": b for i, b in enumerate(beta[1:])}}


def predict(model: Model, inputs: dict, precision: str) -> dict:
    """Reference: the block's arithmetic in binary32 ('f32') or the ideal float64 model ('f64').

    Order as in the block: ((beta0 + beta_1*(T_1 - T0_1)) + beta_2*(T_2 - T0_2)) + ...
    """
    dtype = np.float32 if precision == "f32" else np.float64
    temps = model.signals("temperature")
    rows = len(inputs[temps[0].name])
    out = np.full(rows, model.coef("beta0", precision), dtype)
    for i, s in enumerate(temps, start=1):
        x = np.asarray(inputs[s.name], dtype)
        out = out + dtype(model.coef(f"beta_{i}", precision)) * (x - x[0])
    return {model.target.name: out}
