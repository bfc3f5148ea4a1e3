"""The hall air of a designed ambient experiment: a climate chamber (or a hall's air handling) moved from
the air the machine soaked in to a run's set level, then held. A lag of hours in the structure shows beside
the sensors' own lags of about an hour only when the air moves by kelvins and stays there for hours: the
daily swing of a hall is the other way to see it (docs/diagnosis.md)."""
from __future__ import annotations

import numpy as np

REFERENCE_C = 20.0  # the air the machine soaks in before a run of the experiment
AIR_HANDLING_S = 1800.0  # the chamber air's own lag to a new set level


def stepped(t: np.ndarray, air: np.ndarray, level: float, at_s: float) -> np.ndarray:
    """`air` moved from its first value to `level` from time `at_s` on, through the air handling's lag."""
    moved = 1.0 - np.exp(-np.clip(t - at_s, 0.0, None) / AIR_HANDLING_S)
    return air + (level - air[0]) * moved
