"""The lower bound on the bag count (docs/theory/design.md#lower-bound).

With the design basis's factors the bags must carry the required lift R = breakout_factor x
W' (x the user's weight contingency), W' the submerged weight; bags of rated lift F:

- N = ceil(R / F): the fewest that lift at all (the bag-count rule,
  :func:`flexlift.loads.liftplan.bag_count`);
- N-1 tolerant: the fewest n with (n - 1) F >= R, i.e. N + 1: the fewest that still lift
  after losing any one bag.

No plan of that bag can use fewer; the proposal is reported against both.
"""

from __future__ import annotations

from flexlift import constants as C
from flexlift.loads.liftplan import bag_count


def required_lift_t(scenario, hull) -> float:
    """R [t]: the lift the bags must carry with the design basis's factors."""
    env, lift = scenario.environment, scenario.lift
    wet = hull.total_wet_weight(env.gravity_m_s2, env.seawater_density_kg_m3,
                                env.steel_density_kg_m3)
    return lift.breakout_factor * wet * (lift.weight_contingency or 1.0) / (
        C.TONNE * env.gravity_m_s2)


def lower_bound(scenario, hull, lift_t: float) -> dict:
    """``{"required_lift_t", "bag_lift_t", "n", "n_minus_1"}`` for bags of ``lift_t`` [t]."""
    R = required_lift_t(scenario, hull)
    n, _ = bag_count(R, lift_t)
    return {"required_lift_t": R, "bag_lift_t": float(lift_t), "n": n, "n_minus_1": n + 1}
