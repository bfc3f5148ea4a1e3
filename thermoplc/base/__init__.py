"""The bottom layer: user errors, binary32 arithmetic, identifier rules, atomic file I/O.

Imports nothing else of thermoplc, so every other package may import it."""
