"""The dotted keys a sweep may set or vary, found by walking the scenario's pydantic models.

``seabed.breakout_time_s`` names a field of a section (an optional section too:
``pipe.wall_thickness_m``); a key stops at the first field that is not itself a section (so
``lift.bags`` is one key holding a whole list). Each key carries what
the schema allows: its kind (a real or whole number, a choice among names, a flag, or any other
value such as a list) and, for numbers, its closed range, which the distributions of a Monte
Carlo must respect (:mod:`flexlift.sweep.distributions`).
"""

from __future__ import annotations

import difflib
import math
import types
import typing
from dataclasses import dataclass
from functools import cache

import annotated_types as at
from pydantic import BaseModel

from flexlift.errors import InputError, clean
from flexlift.scenario import Scenario


@dataclass(frozen=True)
class Key:
    """One dotted key of the scenario.

    name : the dotted key, e.g. ``seabed.breakout_time_s``
    kind : ``real``, ``whole``, ``choice`` (names of a ``Literal``), ``flag`` or ``other``
    low, high : the allowed closed range of a number (``-inf`` / ``inf`` when open), in the
        key's own unit
    choices : the allowed names of a ``choice`` key
    optional : the key may be null (its default is computed, e.g. ``control.breakout_pull_t``)
    """

    name: str
    kind: str
    low: float = -math.inf
    high: float = math.inf
    choices: tuple = ()
    optional: bool = False


def _section(annotation) -> type[BaseModel] | None:
    """The section a field holds: a model, or an optional one (``pipe: Pipe | None``)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        models = [a for a in typing.get_args(annotation) if a is not type(None)]
        if len(models) == 1 and isinstance(models[0], type) and issubclass(models[0], BaseModel):
            return models[0]
    return None


def _leaves(annotation) -> list:
    """The non-None alternatives of a union, Annotated wrappers kept."""
    if typing.get_origin(annotation) in (typing.Union, types.UnionType):
        return [a for a in typing.get_args(annotation) if a is not type(None)]
    return [annotation]


def _bounds(annotation) -> tuple[type | None, float, float]:
    """(base type, low, high) of a possibly Annotated number type, from its ge/le metadata."""
    low, high, base = -math.inf, math.inf, annotation
    while typing.get_origin(base) is typing.Annotated:
        args = typing.get_args(base)
        base = args[0]
        for meta in args[1:]:
            for m in getattr(meta, "metadata", [meta]):
                if isinstance(m, at.Ge | at.Gt):
                    low = max(low, float(getattr(m, "ge", getattr(m, "gt", -math.inf))))
                elif isinstance(m, at.Le | at.Lt):
                    high = min(high, float(getattr(m, "le", getattr(m, "lt", math.inf))))
    return base, low, high


def _key(name: str, field) -> Key:
    alternatives = _leaves(field.annotation)
    optional = field.default is None or (
        typing.get_origin(field.annotation) in (typing.Union, types.UnionType)
        and type(None) in typing.get_args(field.annotation))
    meta_low, meta_high = -math.inf, math.inf
    for m in field.metadata:
        if isinstance(m, at.Ge | at.Gt):
            meta_low = float(getattr(m, "ge", getattr(m, "gt", -math.inf)))
        elif isinstance(m, at.Le | at.Lt):
            meta_high = float(getattr(m, "le", getattr(m, "lt", math.inf)))
    first = alternatives[0]
    if typing.get_origin(first) is typing.Literal:
        return Key(name, "choice", choices=typing.get_args(first), optional=optional)
    base, low, high = _bounds(first)
    low, high = max(low, meta_low), min(high, meta_high)
    if base is bool:
        return Key(name, "flag", optional=optional)
    if base is int:
        return Key(name, "whole", low, high, optional=optional)
    if base is float:
        return Key(name, "real", low, high, optional=optional)
    return Key(name, "other", optional=optional)


def _walk(model: type[BaseModel], prefix: str, out: dict[str, Key]) -> None:
    for fname, field in model.model_fields.items():
        name = f"{prefix}{fname}"
        sub = _section(field.annotation)
        if sub is not None:
            _walk(sub, name + ".", out)
        else:
            out[name] = _key(name, field)


@cache
def scenario_keys() -> dict[str, Key]:
    """Every dotted key of a scenario, in the schema's order."""
    out: dict[str, Key] = {}
    _walk(Scenario, "", out)
    return out


def check_key(key, where: str) -> Key:
    """The :class:`Key` named ``key``, or an :class:`InputError` (one line) naming the near
    miss and the valid keys (of its section when the section exists, else the sections)."""
    keys = scenario_keys()
    if isinstance(key, str) and key in keys:
        return keys[key]
    shown = clean(str(key), 60)
    if not isinstance(key, str):
        raise InputError.from_line(f"{where}: key {shown} is not a dotted key such as "
                                   "seabed.breakout_time_s")
    section, _, _ = key.rpartition(".")
    same = [k for k in keys if k.rpartition(".")[0] == section] if section else []
    near = difflib.get_close_matches(key, list(keys), n=1, cutoff=0.6)
    head = f"{where}: unknown key '{shown}'; " + (f"did you mean '{near[0]}'? " if near else "")
    if not same:
        sections = ", ".join(dict.fromkeys(k.split(".")[0] for k in keys))
        raise InputError.from_line(f"{head}keys are SECTION.KEY (e.g. seabed.breakout_time_s) "
                                   f"with the sections {sections}; the README lists every key")
    listed = []
    for k in same:
        if len(head) + sum(len(x) + 2 for x in listed) + len(k) > 290:
            listed.append(f"... (+{len(same) - len(listed)}; the README lists every key)")
            break
        listed.append(k)
    raise InputError.from_line(f"{head}valid keys of {section} are " + ", ".join(listed))
