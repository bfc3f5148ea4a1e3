"""Parse emitted Structured Text, interpret it in binary32 and replay recorded data through it."""
