"""Pydantic's validation errors of a scenario as one line each (used by :mod:`flexlift.scenario`).

A line names the file, the dotted key as the user wrote it (``lift.bags[2].span_m``, without
pydantic's own location parts such as union members and discriminator tags), the value in at
most ~80 characters (never expanded in full: an alias bomb or a megabyte of text stays short)
and what is allowed; an unknown key lists the valid keys of its section. Control characters
and line breaks of the user's keys and values are escaped, so the line stays one line.
"""

from __future__ import annotations

from typing import get_args

from pydantic import BaseModel

from flexlift.errors import brief, clean


def _models(annotation) -> list[type[BaseModel]]:
    """The sections (pydantic models) an annotation can hold: ``Hull``, ``list[BagSpec]``,
    ``list[Fault]`` (several)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for arg in get_args(annotation) for m in _models(arg)]


def _kinds(model: type[BaseModel]) -> tuple:
    field = model.model_fields.get("kind")
    return get_args(field.annotation) if field is not None else ()


def key_path(loc, root: type[BaseModel]) -> tuple[str, type[BaseModel], list[type[BaseModel]]]:
    """(dotted key of an error location, the section its last part belongs to, the sections
    a discriminated union at the end could have been)."""
    model, choices, text = root, [], ""
    for part in loc:
        if isinstance(part, int):
            text += f"[{part}]"
            continue
        if not isinstance(part, str):  # a key that is not text (from the Python API)
            text += f"[{brief(part, 40)}]"
            continue
        if choices:  # a discriminated union (faults): the tag picks the section
            picked = [m for m in choices if part in _kinds(m)]
            if picked:
                model, choices = picked[0], []
                continue
        if part not in model.model_fields:
            continue  # pydantic's name of a union member (``float``, ``list[...]``), not a key
        found = _models(model.model_fields[part].annotation)
        if len(found) == 1:
            model = found[0]
        elif found:
            choices = found
        text += ("." if text else "") + part
    return text, model, choices


def first_error(errors: list[dict], root: type[BaseModel]) -> dict:
    """The error to report: the first, or a deeper one at the same key (a list given for
    ``float | list[float]`` fails both members: its bad item says more than "not a number")."""
    first = errors[0]
    key = key_path(first["loc"], root)[0]
    if not key:
        return first
    paths = [(key_path(e["loc"], root)[0], e) for e in errors]
    same = [(p, e) for p, e in paths if p == key or p.startswith((key + ".", key + "["))]
    return max(same, key=lambda pe: len(pe[0]))[1]


def format_error(err: dict, source: str, root: type[BaseModel]) -> str:
    """One line for one pydantic error ``err`` of validating ``root`` from ``source``."""
    kind = err["type"]
    if kind == "extra_forbidden":
        loc, section, _ = key_path(err["loc"][:-1], root)
        unknown = clean(str(err["loc"][-1]), 40)
        key = f"{loc}.{unknown}" if loc else unknown
        head = f"unknown key '{key}'; "
        return f"{source}: {head}{_valid_keys(unknown, list(section.model_fields), 255 - len(head))}"
    value = err.get("input")
    ctx = err.get("ctx") or {}
    if kind == "invalid_key":  # from the Python API: a YAML file's keys are checked on reading
        loc = key_path(err["loc"][:-1], root)[0]
        return (f"{source}: key {brief(value, 40)} in {loc or 'the scenario'} is not a name; "
                "keys are names such as length_m")
    loc, _, choices = key_path(err["loc"], root)
    if kind == "union_tag_invalid":
        msg = f"unknown kind {brief(ctx.get('tag'), 40)}; use one of {ctx.get('expected_tags')}"
    elif kind == "union_tag_not_found":
        msg = "needs a kind, one of " + ", ".join(repr(t) for m in choices for t in _kinds(m))
    else:
        msg = clean(err["msg"].removeprefix("Value error, "), 200)
    if kind == "value_error" and isinstance(value, dict):  # a section's check names its fields
        return f"{source}: {loc + ': ' if loc else ''}{msg}"
    return f"{source}: {loc or 'scenario'} = {brief(value)}: {msg}"


def _valid_keys(unknown: str, valid: list[str], room: int = 220) -> str:
    """'did you mean ..?' for a near miss, then the valid keys, within ``room`` characters."""
    import difflib

    near = difflib.get_close_matches(unknown, valid, n=1, cutoff=0.6)
    head = f"did you mean '{near[0]}'? " if near else ""
    keys = ""
    for k, name in enumerate(valid):
        part = name if not keys else f", {name}"
        if len(head) + len(keys) + len(part) > room - 24:
            keys += f", ... (+{len(valid) - k}, see the README)"
            break
        keys += part
    return f"{head}valid keys here are: {keys}"
