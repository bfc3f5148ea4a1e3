"""`python -m thermoplc`: the same command as `thermoplc`, for environments without the script on PATH."""
from thermoplc.cli import run

run()
