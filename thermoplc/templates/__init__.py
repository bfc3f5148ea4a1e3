"""Jinja2 skeletons of the emitted blocks, one per dialect."""
