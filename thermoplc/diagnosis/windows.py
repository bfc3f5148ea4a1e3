"""Where simulation and measurement disagree: residual windows outside the noise band.

A channel's noise is estimated from the residual's sample-to-sample differences (robust: the
model's slow mismatch barely changes from one sample to the next). The residual is averaged
over `SMOOTHING_S`; a window is where that average leaves the band for at least half that time.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SMOOTHING_S = 1800.0
BAND_SIGMAS = 6.0  # band on the smoothed residual, in standard errors of the mean over the smoothing time
BAND_FLOOR = 1.0  # ... and never below the noise itself: a systematic gap smaller than the sensor noise is not worth a name
MAD_TO_SIGMA = 1.4826
SETTLING_S = 3600.0  # the simulation starts from one noisy sample; its first hour is not judged ...
SETTLING_TIME_CONSTANTS = 1.2  # ... nor, on a slow sensor, the time a start 3.3 sigmas off takes to fall to 1
MAX_SETTLING_S = 3 * 3600.0


@dataclass(frozen=True)
class Window:
    channel: str
    start: int  # first row (of its run)
    stop: int  # one past the last row
    rms: float
    run: int = 0  # which run of a campaign


def noise_sigma(residual: np.ndarray) -> float:
    """White-noise standard deviation from first differences (median absolute deviation); of a probed target,
    from the differences between successive probings (NaN between them)."""
    d = np.diff(residual[np.isfinite(residual)])
    if len(d) == 0:
        return 0.0
    return float(MAD_TO_SIGMA * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0))


def smoothing_rows(dt: float) -> int:
    """Rows the residual is averaged over: `SMOOTHING_S` at the sample period `dt` (s), at least 3."""
    return max(3, int(round(SMOOTHING_S / dt)))


def measured_counts(residual: np.ndarray, width: int) -> np.ndarray:
    """How many measured (finite) samples the centred window of `width` rows around each row holds."""
    return np.convolve(np.isfinite(residual).astype(float), np.ones(width), mode="same")


def smooth(residual: np.ndarray, width: int) -> np.ndarray:
    """Centred moving average over the measured samples (a probed target is NaN between probings); at the ends
    over the samples that exist; NaN where the window holds none."""
    finite = np.isfinite(residual)
    total = np.convolve(np.where(finite, residual, 0.0), np.ones(width), mode="same")
    count = measured_counts(residual, width)
    return np.where(count > 0, total / np.maximum(count, 1.0), np.nan)


def band(sigma: float, width) -> float | np.ndarray:
    """Half-width of the band the smoothed residual must leave: `BAND_SIGMAS` standard errors of a mean over
    `width` samples (per row, for a probed target: the probings in its window), never below the noise `sigma`."""
    return np.maximum(BAND_SIGMAS * sigma / np.sqrt(np.maximum(width, 1.0)), BAND_FLOOR * sigma)


def settling_s(time_constant_s: float) -> float:
    """How long a simulation started from one noisy reading is not judged: an hour, or on a sensor
    slower than that the time its start error (a sample a few sigmas off) takes to decay into the
    band, at most `MAX_SETTLING_S`."""
    return float(np.clip(SETTLING_TIME_CONSTANTS * time_constant_s, SETTLING_S, MAX_SETTLING_S))


def find_windows(channel: str, residual: np.ndarray, sigma: float, dt: float, settling: float = SETTLING_S
                 ) -> list[Window]:
    """The runs where the smoothed residual leaves the noise band, none in the first `settling` s: runs less
    than a smoothing width apart merge, and runs shorter than half of one are dropped."""
    width = smoothing_rows(dt)
    probed = not np.isfinite(residual).all()
    with np.errstate(invalid="ignore"):
        outside = np.abs(smooth(residual, width)) > band(sigma, measured_counts(residual, width) if probed else width)
    outside[:int(round(settling / dt))] = False
    edges = np.flatnonzero(np.diff(np.r_[0, outside.astype(int), 0]))
    runs = list(zip(edges[::2], edges[1::2]))
    merged: list[list[int]] = []
    for start, stop in runs:  # a short dip back into the band does not split a window
        if merged and start - merged[-1][1] < width:
            merged[-1][1] = stop
        else:
            merged.append([start, stop])
    return [Window(channel, int(a), int(b), rms(residual[a:b])) for a, b in merged
            if b - a >= width // 2 and np.isfinite(residual[a:b]).any()]


def measured(x: np.ndarray) -> np.ndarray:
    """The measured samples of a residual: a probed target's are finite only at its probings."""
    return x[np.isfinite(x)]


def rms(x: np.ndarray) -> float | None:
    """RMS over the measured samples; None when there are none."""
    x = measured(x)
    return float(np.sqrt(np.mean(x ** 2))) if len(x) else None
