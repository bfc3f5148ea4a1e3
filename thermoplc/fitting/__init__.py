"""Fitting a kind to a recording and judging the fit: held-out rows, folds, acceptance, auto, sensors."""
