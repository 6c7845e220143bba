"""The dump valve each bag's purge takes in the run (docs/theory/gas.md#dump-valves).

An external bag's purge valve passes at most, by precedence: the user's
``gas.purge_rate_max_m3_s`` when the scenario gives it ("user"); else the catalogue bag's
``dump_valve_m3_s`` (its model's or the explicit field, "catalogue"); else the assumed
``gas.purge_rate_max_m3_s`` (2 m3/s: "assumed", or "paper" for the tanker's own value).
Internal bags (in the tanks) always take ``gas.purge_rate_max_m3_s``.

"Given" is read as the design basis reads it (:func:`flexlift.scenario.provenance.source`), so that a
run's own scenario.yaml, which writes every key, repeats the run: a structure of the user's own
gave the key when it is not among the scenario's ``defaulted`` keys; the tanker, or a scenario
based on it, when its value differs from the tanker's 2 m3/s.
"""

from __future__ import annotations

from typing import NamedTuple

from flexlift.scenario.provenance import source

__all__ = ["KEY", "VALVE_KEY", "Valve", "external_valve", "purge_given", "purge_source"]

#: the scenario's purge capacity per bag [m^3/s]
KEY = "gas.purge_rate_max_m3_s"
#: the catalogue bag's dump-valve capacity [m^3/s]
VALVE_KEY = "lift.catalogue_bag.dump_valve_m3_s"


class Valve(NamedTuple):
    """The external bags' dump valve in the run."""

    m3_s: float  # its largest flow at local pressure, fully open, bag full [m^3/s]
    source: str  # "user", "catalogue", "assumed" or "paper"
    key: str  # the scenario key that sets it (:data:`KEY` or :data:`VALVE_KEY`)


def purge_source(scenario) -> str:
    """Where ``gas.purge_rate_max_m3_s`` comes from: "user" (given, module docstring),
    "assumed" (a structure of the user's own that does not give it) or "paper" (the tanker's
    value)."""
    src = source(scenario, KEY)
    return "user" if src == "default" else src  # default: given, equal to the schema's


def purge_given(scenario) -> bool:
    """Whether the scenario gives ``gas.purge_rate_max_m3_s`` (module docstring)."""
    return purge_source(scenario) == "user"


def external_valve(scenario) -> Valve:
    """The dump valve of ``scenario``'s external (catalogue) bags, by the module's precedence."""
    gas, valve = scenario.gas.purge_rate_max_m3_s, scenario.lift.catalogue_bag.dump_valve_m3_s
    if purge_given(scenario):
        return Valve(float(gas), "user", KEY)
    if valve is not None:
        return Valve(float(valve), "catalogue", VALVE_KEY)
    return Valve(float(gas), purge_source(scenario), KEY)
