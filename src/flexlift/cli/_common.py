"""Arguments and output helpers shared by the sub-commands."""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import re
import sys
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from flexlift.loads.scenario import load_scenario
from flexlift.output import output_folder
from flexlift.scenario import Scenario


def add_scenario_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "scenario",
        nargs="?",
        default="tanker",
        help="a built-in scenario name or a YAML file (default: the built-in tanker)",
    )


def add_out_arg(p: argparse.ArgumentParser, what: str) -> None:
    p.add_argument("--out", type=Path, default=None, help=f"folder for {what} (default: none)")


def add_json_arg(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="print a JSON summary on stdout")


def scenario_from(args: argparse.Namespace) -> Scenario:
    """The scenario named on the command line, a user's hull given its default bag
    (loads/clusters.py: the largest standard size whose clusters fit), as the library's
    :func:`~flexlift.load_scenario` loads it."""
    scenario = load_scenario(args.scenario)
    check_fault_bags(scenario)
    return scenario


def check_fault_bags(scenario: Scenario) -> None:
    """InputError (one line) for a fault naming a bag the lift plan does not hold, before any
    stage runs (the names come from the plan: ``bag_N`` on a hull, ``B01`` .. on a pipe)."""
    if not getattr(scenario, "faults", None):  # none: nothing to check
        return
    from flexlift.ascent.faults import check_faults
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    plan = plan_lift(scenario, hull_from_scenario(scenario))
    check_faults(scenario, [b.name for b in plan.bags])


def _field(key: str):
    """The type (with its range) of the scenario key ``key`` ("hull.elements")."""
    from typing import Annotated

    from pydantic import BaseModel

    model, *path, last = [Scenario, *key.split(".")]
    for part in path:
        model = model.model_fields[part].annotation
        if not (isinstance(model, type) and issubclass(model, BaseModel)):  # Optional[Section]
            model = next(a for a in getattr(model, "__args__", ()) if isinstance(a, type)
                         and issubclass(a, BaseModel))
    info = model.model_fields[last]
    return Annotated[(info.annotation, *info.metadata)] if info.metadata else info.annotation


def _number(text: str):
    """A number as YAML would read it: a whole number stays whole."""
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            continue
    return text.replace("``", "")


def checked(option: str, kind, also: str = ""):
    """argparse type: the option's value checked by the pydantic type ``kind`` (a range of
    :mod:`flexlift.scenario.types`), with its message: ``--workers 100000: Input should be
    less than or equal to 64``."""
    from pydantic import TypeAdapter, ValidationError

    from flexlift.errors import brief

    adapter = TypeAdapter(kind)

    def parse(text: str):
        value = _number(text)
        if isinstance(value, str):
            raise argparse.ArgumentTypeError(f"{brief(text)}: a number is needed here")
        try:
            return adapter.validate_python(value)
        except ValidationError as exc:
            msg = exc.errors(include_url=False)[0]["msg"].removeprefix("Value error, ")
            raise argparse.ArgumentTypeError(f"{brief(value)}: {msg}{also}") from None

    return parse


def key_option(option: str, key: str):
    """argparse type: an option that is a scenario key (``--elements`` is ``hull.elements``):
    the same range and the same message as in a scenario file."""
    return checked(option, _field(key), f" (the range of {key} in a scenario file)")


def with_options(scenario: Scenario, options: dict[str, tuple[str, object]]) -> Scenario:
    """``scenario`` with the options that are its keys applied and validated as the file's
    keys are, checks across keys included (``--duration`` against ``time_step_s``):
    ``options`` maps an option to (its key, its value or None)."""
    from flexlift.errors import InputError

    changes = {key: v for key, v in options.values() if v is not None}
    if not changes:
        return scenario
    try:
        return scenario.with_changes(**changes)
    except InputError as exc:
        named = ", ".join(o for o, (k, v) in options.items() if v is not None)
        line = str(exc).removeprefix(f"{scenario.name} (modified): ")
        raise InputError.from_line(f"{named}: {line}") from None


def positive_int(name: str):
    """argparse type: an integer >= 1, with a one-line error naming the option."""

    def parse(text: str) -> int:
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a whole number, got {text!r}") from None
        if v < 1:
            raise argparse.ArgumentTypeError(f"{name} must be at least 1, got {v}")
        return v

    return parse


def positive_float(name: str):
    """argparse type: a finite number > 0."""

    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{name} must be a number, got {text!r}") from None
        if not math.isfinite(v) or v <= 0:
            raise argparse.ArgumentTypeError(f"{name} must be a positive number, got {text}")
        return v

    return parse


def _jsonable(o):
    if isinstance(o, np.generic):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


def to_json(obj) -> str:
    return json.dumps(obj, default=_jsonable, allow_nan=False)


def emit_json(obj) -> None:
    """Print one JSON object on stdout."""
    sys.stdout.write(to_json(obj) + "\n")


@contextlib.contextmanager
def writing(out: Path | None, command: str) -> Iterator[Path | None]:
    """The folder a command writes into: None without ``--out``, else a temporary folder that
    :func:`flexlift.output.output_folder` swaps in for ``out`` when the block succeeds."""
    if out is None:
        yield None
        return
    with output_folder(out, command) as tmp:
        yield tmp


_ROLE = re.compile(r":[a-z]+:`~?([^`]+)`")


def help_text(doc: str | None) -> str:
    """A module docstring as terminal text for ``--help``: reST's ``code`` and :role:`name`
    marks dropped (``flexlift run`` -> flexlift run)."""
    text = _ROLE.sub(lambda m: m.group(1).rsplit(".", 1)[-1], doc or "")
    return text.replace("``", "")
