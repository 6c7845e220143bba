"""State estimation from sensor readings (docs/theory/estimation.md)."""
