"""Scenario files (docs/reference/scenario.md): the schema, safe YAML loading, and the built-in scenarios.

- :mod:`.schema`: the pydantic model of a whole lift, units in the key names;
- :mod:`.types`: strict, bounded numbers and names; :mod:`.file`: reading an untrusted file;
  :mod:`.messages`: one-line error messages.

``load_scenario("tanker")`` or ``load_scenario("my-wreck.yaml")`` gives a validated
:class:`Scenario`.
"""

from flexlift.scenario.schema import (
    ControlMode,
    Scenario,
    builtin_names,
    load_scenario,
    parse_scenario,
)

__all__ = ["ControlMode", "Scenario", "builtin_names", "load_scenario", "parse_scenario"]
