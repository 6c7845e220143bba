"""One catalogue bag per lift point (``--per-point-types``; docs/theory/design.md#per-point).

Each lift point picks its own catalogue bag of the offered ones; its bags carry that bag's
rated lift (``lift.bags[].lift_t``), and so its gas capacity, in the statics (the lift and the
lift after losing the largest bag) and in the run. The scenario has one
``lift.catalogue_bag`` for the body, the dump valve and the ratings of every external bag, so
the offered bags must be of one type and the plan's catalogue bag is their envelope
(:func:`envelope`): the largest body (cluster room, headroom and drag taken for the largest),
the smallest dump valve, rated depth, working pressure and relief setting (each bag's own is
at least that). Internal bags are of the largest point bag's lift.
"""

from __future__ import annotations

import math

from flexlift.errors import InputError

#: the catalogue fields that make a bag's body; the rest are ratings
BODY = ("diameter_m", "length_m", "cone_top_m")
RATINGS = ("dump_valve_m3_s", "rated_depth_m", "working_pressure_bar", "relief_bar")


def check_one_type(entries: dict) -> None:
    """InputError (one line) unless the offered bags are of one type."""
    types = sorted({e["type"] for e in entries.values()})
    if len(types) > 1:
        raise InputError("--per-point-types", ", ".join(types), "the bags offered must be of "
                         "one type (the plan has one bag body and valve); name them with --bags")


def largest(models, entries: dict) -> str:
    """The model of the largest rated lift among ``models`` (the first of equals)."""
    return max(models, key=lambda m: float(entries[m]["lift_t"]))


def envelope(models, entries: dict) -> dict:
    """The catalogue bag standing for ``models`` (module docstring): the largest's entry with
    the smallest of each rating (None when any bag gives none)."""
    out = dict(entries[largest(models, entries)])
    for k in RATINGS:
        vals = [entries[m].get(k) for m in models]
        out[k] = None if any(v is None for v in vals) else min(float(v) for v in vals)
    return out


def spread(n: int, points: int) -> list[int]:
    """``n`` bags over ``points`` lift points, aft to bow: ``n // points`` each, one more at
    ``n % points`` of them spread evenly."""
    out = [n // points] * points
    extra = n % points
    for j in range(extra):
        out[int((j + 0.5) * points / extra)] += 1
    return out


def fewest(lifts_t: list[float], internal: int, internal_lift_t: float,
           required_t: float) -> int:
    """The fewest bags in all (``internal`` of them of ``internal_lift_t``, the rest spread
    over the points of ``lifts_t`` [t] by :func:`spread`) whose rated lift is at least
    ``required_t`` [t] (the least that lift when shared over the points this way)."""
    need = required_t - internal * internal_lift_t
    n_ext = max(1, math.ceil(need / max(lifts_t) - 1e-9))
    while True:
        p = min(len(lifts_t), n_ext)
        got = sum(c * f for c, f in zip(spread(n_ext, p), lifts_t))
        if got >= need * (1 - 1e-9):
            return n_ext + internal
        n_ext += 1
