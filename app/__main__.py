"""`python -m thermoplc`: the same command as `thermoplc`, for environments without the script on PATH."""
import sys

from thermoplc.cli import main

sys.exit(main())
