"""The scenario as every way in loads it: the file read (:func:`flexlift.scenario.
read_scenario`), then a user's hull without a bag choice given its default bag, which needs
the hull's lift plan and so this floor (docs/theory/factors.md#arrangement).

:func:`load_scenario` is what the library (``flexlift.load_scenario``), the command line and
a sweep's base call, so all three agree on a user's bag.
"""

from __future__ import annotations

from pathlib import Path

from flexlift.loads.clusters import default_bag
from flexlift.scenario import Scenario, read_scenario

__all__ = ["load_scenario", "with_default_bag"]


def load_scenario(name_or_path: str | Path | None = None) -> Scenario:
    """Load a built-in scenario by name (default ``tanker``) or a YAML file by path.

    The file is read as :func:`flexlift.scenario.read_scenario` reads it (defensively: a
    regular UTF-8 file of at most 1 MB, one YAML document; every key and its range in
    ``docs/reference/scenario.md``); a user's hull without a bag choice then gets the
    largest standard bag whose clusters fit on it (:func:`with_default_bag`).

    Parameters
    ----------
    name_or_path : str or path-like, optional
        A built-in name (``tanker``, ``pipeline``) or the path of a YAML file; a relative
        ``.fis`` path in it is relative to the file's folder. Default ``tanker``.

    Returns
    -------
    Scenario
        The validated scenario, every default filled in (units in the key names).

    Raises
    ------
    InputError
        One line naming the key, the value and what is allowed.

    Examples
    --------
    >>> from flexlift import load_scenario
    >>> tanker = load_scenario("tanker")
    >>> tanker.hull.length_m, tanker.lift.layout
    (78.02, 'mode_nodes')
    """
    return with_default_bag(read_scenario(name_or_path))


def with_default_bag(scenario: Scenario) -> Scenario:
    """``scenario`` with its default bag chosen on its lift plan
    (:func:`flexlift.loads.clusters.default_bag` with :func:`flexlift.loads.liftplan.
    plan_lift`) when flexlift derived it; any other scenario as it is."""
    if (scenario.defaulted or {}).get("lift.catalogue_bag") != "derived":
        return scenario
    # the hull and its plan (numba, scipy) only for a hull that needs them: a sweep's
    # coordinator reads a built-in base without either (tests/test_sweep_start.py)
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    return default_bag(scenario, lambda s: plan_lift(s, hull_from_scenario(s)))
