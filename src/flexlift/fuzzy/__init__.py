"""Fuzzy inference (docs/theory/control.md#supervisor): the Mamdani/Sugeno engine with MATLAB's semantics, lookup tables
of sampled maps, MATLAB ``.fis`` import and export, and the controllers' rule bases.

- :mod:`.system`: :class:`FIS`, :class:`Variable`, :class:`MF`, :class:`Rule` and evaluation;
  :mod:`.mf` the membership functions, :mod:`.engine` the vectorised evaluation,
  :mod:`.surface` interpolated surfaces;
- :mod:`.fis`, :mod:`.fis_parse`: ``.fis`` files as MATLAB reads and writes them;
- :mod:`.rulebase`: the built-in supervisor and SIFSMC fill map;
- :mod:`.tables`: lookup tables the compiled ascent reads.
"""

from flexlift.fuzzy.system import FIS, MF, Rule, Variable

__all__ = ["FIS", "MF", "Rule", "Variable"]
