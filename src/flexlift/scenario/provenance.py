"""Where a scenario's value comes from (the design basis's sources, scenario/basis.py): "user"
(given), "paper" (the built-in tanker's value), "assumed" or "derived" (scenario/defaults.py),
or "default" (flexlift's generic default, also when a file gives that same value). Read by the
design basis and by the dump valve's precedence (scenario/valves.py), below both.
"""

from __future__ import annotations

from functools import lru_cache

from flexlift.scenario.defaults import own_structure, set_in
from flexlift.scenario.schema import Scenario, read_scenario

__all__ = ["source", "value_of", "tanker", "generic_defaults"]


@lru_cache(maxsize=1)
def tanker():
    """The built-in tanker (read only)."""
    return read_scenario("tanker")


@lru_cache(maxsize=1)
def generic_defaults():
    """Every key at its generic default (a scenario built without validation; read only)."""
    return Scenario.model_construct()


def value_of(model, dotted: str):
    """The value of key ``dotted`` ("gas.fill_rate_max_m3_s") in ``model``."""
    node = model
    for part in dotted.split("."):
        node = getattr(node, part)
    return node


def source(scenario, dotted: str) -> str:
    """Where the value of key ``dotted`` comes from (module docstring)."""
    how = (scenario.defaulted or {}).get(dotted)
    if how:
        return how
    if scenario.name == "tanker" or not own_structure(scenario):
        same = value_of(scenario, dotted) == value_of(tanker(), dotted)
        return "paper" if same else "user"
    given = value_of(scenario, dotted)
    if set_in(scenario, dotted) and given != value_of(generic_defaults(), dotted):
        return "user"
    return "default"
