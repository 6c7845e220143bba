"""Loads and strength (docs/theory/strength.md): the lift plan (bag count, layout) and the static shear force
and bending moment of the structure under it."""
