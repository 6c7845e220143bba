"""Internal bags in the designer's space: how many the tanks hold, and the check a candidate's
count must pass (docs/theory/design.md#internal-bags).

Internal bags lie in the ballast tanks end to end over the tank span
(:func:`flexlift.loads.liftplan.tank_edges`, not snapped: the balanced layout's rule); in the
run they are the paper's closed cylinders, full from the start (docs/theory/gas.md). A
candidate's internal bags are of its catalogue bag's rated lift F. Two limits:

- room: their rated gas volume k F / (rho_sw g) at most the tank span's box, span x breadth
  x depth of the hull (an upper bound on the tanks' volume: frames, plating and the double
  bottom take some of it);
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


def tank_volume_m3(scenario) -> float:
    """The box of the tank span: (frames f1 - f0) x frame spacing x breadth x depth [m^3]."""
    h = scenario.hull
    f0, f1 = h.ballast_tank_frames
    return max(0.0, (f1 - f0) * h.frame_spacing_m) * h.breadth_m * h.depth_m


def wet_weight_t(scenario, hull) -> float:
    """W', the submerged weight [t]."""
    env = scenario.environment
    return hull.total_wet_weight(env.gravity_m_s2, env.seawater_density_kg_m3,
                                 env.steel_density_kg_m3) / (C.TONNE * env.gravity_m_s2)


def most_internal(scenario, hull, lift_t: float) -> int:
    """The most internal bags of rated lift ``lift_t`` [t] that pass both limits (module
    docstring); 0 without tanks."""
    if not has_tanks(scenario):
        return 0
    rho = scenario.environment.seawater_density_kg_m3
    room = math.floor(tank_volume_m3(scenario) * rho / (C.TONNE * lift_t) + 1e-9)
    weight = math.ceil(wet_weight_t(scenario, hull) / lift_t - 1e-9) - 1  # k F < W'
    return max(0, min(room, weight))


def tank_check(scenario, hull, k: int, lift_t: float) -> dict | None:
    """None when ``k`` internal bags of ``lift_t`` [t] fit (module docstring), else the
    failed static check ``{"passed", "check": "tanks", "why", "violation", ...}``."""
    if k == 0:
        return None
    rho = scenario.environment.seawater_density_kg_m3
    if not has_tanks(scenario):
        why, violation = "the structure has no ballast tanks for internal bags", float(k)
    else:
        volume, box = k * lift_t * C.TONNE / rho, tank_volume_m3(scenario)
        wet = wet_weight_t(scenario, hull)
        if volume > box * (1 + 1e-9):
            why = (f"{k} internal bags hold {volume:,.0f} m3 of gas; the tank span's box is "
                   f"{box:,.0f} m3")
            violation = (volume - box) / box
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
