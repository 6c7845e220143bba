"""The first rung of the ladder: the static checks of a candidate (docs/theory/design.md#ladder).

Cheapest first, each with the design basis's own code:

1. ``lift``: the bags' rated lift (each bag its own: with one catalogue bag per lift point
   the points differ) against the required lift R (breakout factor x W', x the weight
   contingency), and after losing any one bag, the largest (``lift_n_minus_1``); ``holding``:
   each external bag's share of what it holds through the ascent
   (:meth:`~flexlift.loads.liftplan.LiftPlan.holding_lifts`: W' less the full internal
   bags, shared equally) at most its rated lift (only a plan of mixed bags can fail it);
2. ``arrangement`` and ``rigging``: :func:`flexlift.ascent.arrangement.arrangement_checks`
   (clusters on the hull, headroom, rated depth, dump valve, slings and lift points);
3. ``workable``: :func:`flexlift.ascent.checks.refuse_unworkable` on the candidate's plant;
4. ``strength``: the largest bending utilisation sigma / sigma_allow over the closed design
   cases (:func:`flexlift.stages.loads.design`), at most 1.

The plant built for 3 and 4 is the one the dynamic rungs run
(:func:`flexlift.sweep.plants.plant_for` keeps it): no candidate builds its model twice.
"""

from __future__ import annotations

from flexlift import constants as C
from flexlift.ascent.arrangement import arrangement_checks
from flexlift.errors import InputError
from flexlift.loads.liftplan import plan_lift


def static_checks(scenario, hull, tolerant: bool = True) -> dict:
    """The static rung of ``scenario`` (a candidate's) on ``hull``: ``{"passed", "check",
    "why", "violation", "utilisation"}``; ``check`` names the first failed check,
    ``violation`` (>= 0, 0 when passed) how far it failed, for the optimiser."""
    g = scenario.environment.gravity_m_s2
    t = C.TONNE * g
    try:
        plan = plan_lift(scenario, hull)
    except InputError as exc:
        return _fail("layout", str(exc), 1.0)
    total, R = plan.total_lift, plan.required_lift
    if total < R * (1 - 1e-9):
        return _fail("lift", f"the bags lift {total / t:,.0f} t of the {R / t:,.0f} t "
                     "required", (R - total) / R)
    if tolerant:
        left = total - max(b.lift for b in plan.bags)
        if left < R * (1 - 1e-9):
            return _fail("lift_n_minus_1", f"after losing a bag the rest lift {left / t:,.0f} t "
                         f"of the {R / t:,.0f} t required", (R - left) / R)
    held = [(h, b.lift) for h, b in zip(plan.holding_lifts(), plan.bags)
            if b.kind == "external"]
    over = [(h - f) / f for h, f in held if h > f * (1 + 1e-9)]
    if over:
        return _fail("holding", f"each external bag holds {max(h for h, _ in held) / t:,.1f} t "
                     f"through the ascent; the smallest lifts {min(f for _, f in held) / t:,.1f} "
                     "t", max(over))
    failed = [c for c in arrangement_checks(scenario, plan) if not c.ok]
    if failed:
        return _fail(failed[0].name, failed[0].message, float(len(failed)))
    return _with_plant(scenario)


def _with_plant(scenario) -> dict:
    from flexlift.ascent.checks import refuse_unworkable
    from flexlift.stages.loads import design, utilisation_along
    from flexlift.sweep.plants import plant_for

    try:
        plant = plant_for(scenario, scenario.control.mode)
        refuse_unworkable(scenario, plant)
    except InputError as exc:
        return _fail("workable", str(exc), 1.0)
    cases = design(scenario, plant.hull, plant.plan, plant)
    use = max(float(utilisation_along(scenario, c.strength).max()) for c in cases)
    if use > 1.0:
        return {**_fail("strength", f"hull girder utilisation {use:.2f} in the design cases "
                        "(at most 1)", use - 1.0), "utilisation": use}
    return {"passed": True, "check": None, "why": "", "violation": 0.0, "utilisation": use}


def _fail(check: str, why: str, violation: float) -> dict:
    return {"passed": False, "check": check, "why": why, "violation": float(violation),
            "utilisation": None}
