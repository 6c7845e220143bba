"""The physical laws of the lift, each written once (docs/theory/index.md).

- :mod:`.gas`: lift-bag gas (isothermal ideal gas, volume at local pressure, capacity, spill
  and relief, fill, the purge orifice, buoyancy, expansion);
- :mod:`.surface`: a bag at the surface (its gas below the waterline, the body's volume from
  its top);
- :mod:`.seabed`: the holding force (held and released) and seabed contact;
- :mod:`.hydro`: drag and added mass.

Every law is a compiled function (:func:`flexlift._jit.jit`) that works on floats and on
NumPy arrays alike (element by element), with its units in the docstring. The simulation's compiled loop, the
static strength of the results, the paper's uncoupled plant and the lift-plan checks all call
these functions; nothing else writes these formulas.
"""
