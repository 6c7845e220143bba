"""Scenario files (docs/reference/scenario.md): the schema, safe YAML loading, and the built-in scenarios.

- :mod:`.schema`: the pydantic model of a whole lift, units in the key names;
- :mod:`.types`: strict, bounded numbers and names; :mod:`.file`: reading an untrusted file;
  :mod:`.messages`: one-line error messages.

``read_scenario("tanker")`` or ``read_scenario("my-wreck.yaml")`` gives a validated
:class:`Scenario` as written; ``flexlift.load_scenario`` (what every way in calls) also
chooses a user's hull its default bag, on the lift plan (a floor above this one).
"""

from flexlift.scenario.schema import (
    ControlMode,
    Scenario,
    builtin_names,
    parse_scenario,
    read_scenario,
)

__all__ = ["ControlMode", "Scenario", "builtin_names", "parse_scenario", "read_scenario"]
