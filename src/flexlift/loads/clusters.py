"""Whether the external bags' clusters fit on the hull (docs/theory/factors.md#arrangement), and
the default bag of a user's hull that makes them fit.

A cluster of n bags of diameter D at one lift point, floor(B / D) of them across the breadth
B (at least one), needs ceil(n / floor(B / D)) D of hull length centred on its lift point,
inside the hull (0 .. L) and clear of the neighbouring clusters.
"""

from __future__ import annotations

import math

from flexlift.errors import InputError

__all__ = ["across", "cluster_lengths", "cluster_faults", "DEFAULT_SIZES_T", "default_bag"]

#: the standard sizes a user's hull may get, largest first (<= 50 t, the largest in use)
DEFAULT_SIZES_T = (50, 35, 20, 10, 5, 2, 1)
DEFAULT_TYPE = "open_parachute"  # the salvor's usual bag


def across(diameter: float, breadth: float) -> int:
    """Bags side by side across the breadth: floor(B / D), at least one."""
    return max(1, math.floor(breadth / diameter + 1e-9))


def cluster_lengths(points, diameter: float, breadth: float) -> list[tuple[float, int, float]]:
    """(x [m], bags n, hull length needed [m]) of each lift point ``points`` = [(x, names)]."""
    k = across(diameter, breadth)
    return [(x, len(names), math.ceil(len(names) / k) * diameter) for x, names in points]


def cluster_faults(points, diameter: float, breadth: float, length: float) -> list[tuple[float, str]]:
    """(how far off [m], what) of each cluster beyond the hull or over its neighbour, worst
    first (empty: every cluster fits)."""
    rows = cluster_lengths(points, diameter, breadth)
    faults = []
    for k, (x, n, need) in enumerate(rows):
        a, b = x - need / 2, x + need / 2
        if a < -1e-9 or b > length + 1e-9:
            faults.append((need - min(x, length - x) * 2, f"the {n} bag(s) at {x:.2f} m need "
                           f"{need:.2f} m of hull ({a:.2f} .. {b:.2f} m), beyond the hull's "
                           f"0 .. {length:g} m"))
        if k + 1 < len(rows):
            x2, n2, need2 = rows[k + 1]
            gap = (x2 - x) - (need + need2) / 2
            if gap < -1e-9:
                faults.append((-gap, f"the {n} bag(s) at {x:.2f} m ({need:.2f} m of hull) and "
                               f"the {n2} at {x2:.2f} m ({need2:.2f} m) overlap by {-gap:.2f} m"))
    return sorted(faults, key=lambda f: -f[0])


def default_bag(scenario, plan_of):
    """``scenario`` with the default bag of a user's hull chosen: when flexlift derived its
    bag (``defaulted["lift.catalogue_bag"]``), the largest standard open parachute bag <= 50 t
    whose clusters fit (``plan_of(scenario)`` -> its lift plan); the largest when none fits
    (the arrangement check then says so), or when the sizes left need more bags than the cost
    limits allow. Any other scenario is returned as it is."""
    if (scenario.defaulted or {}).get("lift.catalogue_bag") != "derived":
        return scenario
    h = scenario.hull
    first = None
    for t in DEFAULT_SIZES_T:
        model = f"{DEFAULT_TYPE}_{t}t"
        choice = (scenario if scenario.lift.catalogue_bag.model == model else
                  scenario.with_changes(**{"lift.catalogue_bag": {"model": model}}))
        first = first or choice
        try:
            plan = plan_of(choice)
        except InputError:  # too many bags of this size for the cost limits: smaller ones too
            break
        bag = choice.lift.catalogue_bag
        if not cluster_faults(plan.lift_points(), bag.diameter_m, h.breadth_m, h.length_m):
            return choice
    return first
