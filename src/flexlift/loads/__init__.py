"""Loads and strength (SPEC §3): the lift plan (bag count, layout) and the static shear force
and bending moment of the structure under it."""
