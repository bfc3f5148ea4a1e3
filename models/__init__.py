"""Fitting, float32 references, the model file and the synthetic machine."""
