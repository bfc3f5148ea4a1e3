"""The release, written into model files and block headers (below the packages that print it)."""

__version__ = "0.1.0"
