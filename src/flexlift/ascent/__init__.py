"""The time-domain ascent (docs/theory/loop.md#state): plants, the compiled loop, faults, noise, results.

:func:`simulate` is the entry point; :func:`~flexlift.ascent.plant.coupled_plant` and
:func:`~flexlift.ascent.paper.paper_plant` build the two plants it can run.
"""

from flexlift.ascent.loop import simulate
from flexlift.ascent.result import Result

__all__ = ["Result", "simulate"]
