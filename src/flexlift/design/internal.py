"""Internal bags in the designer's space: how many the tanks hold, and the check a candidate's
count must pass (docs/theory/design.md#internal-bags).

Internal bags lie in the ballast tanks end to end over the tank span
(:func:`flexlift.loads.liftplan.tank_edges`, not snapped: the balanced layout's rule); in the
run they are the paper's closed cylinders, full from the start (docs/theory/gas.md). A
candidate's internal bags are of its catalogue bag (rated lift F, diameter D, length L).
Two limits:

- room: the bags' bodies, each lying along the hull in a box D x D x L, packed in rows in
  the tank span's box (span s x breadth B x depth H of the hull): at most
  floor(s / L) floor(B / D) floor(H / D) of them (the box is an upper bound on the tanks:
  frames, plating and a double bottom take some of it);
- weight: their full lift k F below the submerged weight W', so the hull still rests on the
  seabed with the external bags holding the rest (the initial state of docs/theory/gas.md);
  with k F >= W' the external bags would hold nothing and the breakout would not be theirs
  to control.

The most that pass both is the default upper end of ``--internal``; a structure without
ballast tanks (a pipe, or a hull of the user's own that names no ``hull.ballast_tank_frames``)
holds none.
"""

from __future__ import annotations

import math

from flexlift import constants as C
from flexlift.scenario.defaults import own_structure, set_in


def has_tanks(scenario) -> bool:
    """Whether the scenario's structure has ballast tanks to hold internal bags."""
    if scenario.pipe is not None:
        return False
    return not own_structure(scenario) or set_in(scenario, "hull.ballast_tank_frames")


def tank_box_m(scenario) -> tuple[float, float, float]:
    """The box of the tank span: ((frames f1 - f0) x frame spacing, breadth, depth) [m]."""
    h = scenario.hull
    f0, f1 = h.ballast_tank_frames
    return max(0.0, (f1 - f0) * h.frame_spacing_m), h.breadth_m, h.depth_m


def room(scenario, entry: dict) -> int:
    """How many bodies of the catalogue ``entry`` (D x D x L, lying along the hull) the tank
    span's box holds in rows (module docstring)."""
    s, B, H = tank_box_m(scenario)
    D, L = float(entry["diameter_m"]), float(entry["length_m"])
    return int(math.floor(s / L + 1e-9) * math.floor(B / D + 1e-9) * math.floor(H / D + 1e-9))


def wet_weight_t(scenario, hull) -> float:
    """W', the submerged weight [t]."""
    env = scenario.environment
    return hull.total_wet_weight(env.gravity_m_s2, env.seawater_density_kg_m3,
                                 env.steel_density_kg_m3) / (C.TONNE * env.gravity_m_s2)


def most_internal(scenario, hull, entry: dict) -> int:
    """The most internal bags of the catalogue ``entry`` that pass both limits (module
    docstring); 0 without tanks."""
    if not has_tanks(scenario):
        return 0
    weight = math.ceil(wet_weight_t(scenario, hull) / float(entry["lift_t"]) - 1e-9) - 1
    return max(0, min(room(scenario, entry), weight))  # weight: k F < W'


def tank_check(scenario, hull, k: int, entry: dict) -> dict | None:
    """None when ``k`` internal bags of the catalogue ``entry`` fit (module docstring), else
    the failed static check ``{"passed", "check": "tanks", "why", "violation", ...}``."""
    if k == 0:
        return None
    lift_t = float(entry["lift_t"])
    if not has_tanks(scenario):
        why, violation = "the structure has no ballast tanks for internal bags", float(k)
    else:
        fit, wet = room(scenario, entry), wet_weight_t(scenario, hull)
        if k > fit:
            s, B, H = tank_box_m(scenario)
            why = (f"{k} internal bags of {entry['diameter_m']:g} x {entry['length_m']:g} m; "
                   f"the tank span's box ({s:.4g} x {B:g} x {H:g} m) holds {fit} lying in rows")
            violation = (k - fit) / max(fit, 1)
        elif k * lift_t >= wet:
            why = (f"{k} internal bags lift {k * lift_t:,.0f} t, not less than the "
                   f"{wet:,.0f} t submerged weight: the external bags would hold nothing")
            violation = (k * lift_t - wet) / wet + 1e-3
        else:
            return None
    return {"passed": False, "check": "tanks", "why": why, "violation": float(violation),
            "utilisation": None}


def internal_specs(scenario, hull, k: int, lift_t: float) -> list[dict]:
    """``lift.bags`` entries of ``k`` internal bags of ``lift_t`` [t] end to end over the tank
    span (names ``i1`` .. ``ik``, aft to bow)."""
    if k == 0:
        return []
    from flexlift.loads.liftplan import tank_edges

    e = tank_edges(scenario, hull, k, snap=False)
    return [{"name": f"i{j + 1}", "kind": "internal",
             "span_m": [round(float(e[j]), 4), round(float(e[j + 1]), 4)],
             "lift_t": float(lift_t)} for j in range(k)]
