"""thermoplc: thermal-error models for machine tools, compiled to bit-exact PLC function blocks."""
__version__ = "0.1.0"
