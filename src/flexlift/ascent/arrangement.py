"""Arrangement and rigging checks of a lift plan before the run (docs/theory/factors.md#arrangement,
docs/theory/factors.md#rigging): each says what it found, with its numbers and the fix.

- clusters: a cluster of n bags of diameter D at one lift point, floor(B / D) of them across
  the breadth B (at least one), needs ceil(n / floor(B / D)) D of hull length centred on its
  lift point, inside the hull and clear of the neighbouring clusters (:mod:`flexlift.loads.clusters`);
- headroom: a bag's height and its sling against the water above the hull at the target;
- rated depth: the catalogue bag's rated depth against the wreck's depth (the water depth);
- dump valve: the catalogue bag's dump-valve capacity against the expansion of a full bag's
  gas at the planned ascent speed at the target, dV/dt = V rho g v / p, per type (an open bag
  spills a full bag's excess from its mouth, a closed one relieves it);
- rigging: each sling's design load is its bag's full true lift, capacity_factor x the larger
  of its rated and modelled lift (any single failure, a fill valve stuck open, fills it),
  compared with the sling's and shackle's working load limit, which already holds the
  gear's safety factor (no further factor); a lift point's gear (``cluster_wll_t``) against
  the sum over its bags; a lift point's structural capacity against that sum x the
  consequence factor 1.30 (GL Noble Denton 0027/ND Table 11-1: lift points and their
  attachments).
"""

from __future__ import annotations

from dataclasses import dataclass

from flexlift.errors import InputError
from flexlift.loads.clusters import across, cluster_faults, cluster_lengths
from flexlift.physics.gas import ambient_pressure, expansion_rate
from flexlift.scenario.valves import external_valve

#: GL Noble Denton 0027/ND Table 11-1: consequence factor of lift points and their attachments
CONSEQUENCE_LIFT_POINT = 1.30
UPRIGHT = ("open_parachute", "closed_parachute")  # length_m is the height, mouth down


@dataclass(frozen=True)
class Check:
    """One check of the plan: ``ok`` or not, and a one-line ``message`` (numbers and fix)."""

    name: str
    ok: bool
    message: str


def bag_height(bag) -> float:
    """A catalogue bag's height above its lift point [m]: its length when upright (parachute
    bags, mouth down), its diameter when lying (enclosed bags and cylinders)."""
    return bag.length_m if bag.type in UPRIGHT else bag.diameter_m


def cluster_check(scenario, plan) -> Check:
    """Whether each external cluster fits on the hull, clear of its neighbours."""
    bag, hull = scenario.lift.catalogue_bag, scenario.hull
    L, B, D = hull.length_m, hull.breadth_m, bag.diameter_m
    rows = cluster_lengths(plan.lift_points(), D, B)
    if not rows:
        return Check("clusters", True, "no external bags: no cluster to arrange")
    k = across(D, B)
    faults = cluster_faults(plan.lift_points(), D, B, L)
    rule = (f"{k} bag(s) of {D:g} m across the {B:g} m breadth, ceil(n / {k}) x {D:g} m "
            "of hull per lift point")
    if not faults:
        worst = max(rows, key=lambda r: r[2])
        return Check("clusters", True, f"every cluster fits ({rule}; the largest, {worst[1]} bag(s) "
                     f"at {worst[0]:.2f} m, needs {worst[2]:.2f} m)")
    return Check("clusters", False, f"{faults[0][1]} ({rule}"
                 + (f"; {len(faults) - 1} more" if len(faults) > 1 else "")
                 + "); use a larger bag (fewer per point), more lift points, or move the bags")


def headroom_check(scenario) -> Check:
    """A bag's height and sling against the water above the hull at the target."""
    env, bag, c = scenario.environment, scenario.lift.catalogue_bag, scenario.control
    sling = scenario.lift.rigging.sling_length_m
    room = (env.water_depth_m - c.target_height_m - scenario.hull.depth_m
            - scenario.limits.surface_clearance_m)
    need = bag_height(bag) + sling
    ok = need <= room
    msg = (f"a bag {bag_height(bag):.2f} m high ({bag.type.replace('_', ' ')}) on a {sling:g} m "
           f"sling needs {need:.2f} m above the hull; at the {c.target_height_m:g} m target "
           f"there are {room:.2f} m of water above it")
    if not ok:
        msg += (f": the bags would broach; lower control.target_height_m to at most "
                f"{c.target_height_m - (need - room):.2f} m, or use a shorter sling or bag")
    return Check("headroom", bool(ok), msg)


def depth_check(scenario) -> Check:
    """The catalogue bag's rated depth against the wreck's depth."""
    rated, depth = scenario.lift.catalogue_bag.rated_depth_m, scenario.environment.water_depth_m
    if rated is None:
        return Check("rated_depth", True, f"the bag's rated depth is not given (the wreck lies "
                     f"at {depth:g} m): give lift.catalogue_bag.rated_depth_m from its maker")
    ok = rated >= depth
    msg = f"the bag is rated to {rated:g} m; the wreck lies at {depth:g} m"
    if not ok:
        msg += "; choose a bag rated for the depth"
    return Check("rated_depth", bool(ok), msg)


def expansion_rate_at_target(scenario, volume: float) -> tuple[float, float]:
    """(dV/dt [m^3/s], ambient pressure [Pa]) of ``volume`` [m^3] of gas rising at the
    planned speed at the target, the shallowest point of the plan (docs/theory/gas.md#purge-capacity):
    dV/dt = V rho g v / p, the pressure at the bag's point as the loop takes it."""
    env, c = scenario.environment, scenario.control
    rho_g = env.seawater_density_kg_m3 * env.gravity_m_s2
    p = float(ambient_pressure(c.target_height_m, env.water_depth_m, env.atmospheric_pressure_Pa,
                               rho_g))
    return float(expansion_rate(volume, p, rho_g, c.ascent_speed_m_s)), float(p)


#: what a bag of each type does with the gas its dump valve cannot pass
_EXCESS = {"open_parachute": "a full open bag spills the rest from its mouth, but one below full "
                             "gains lift faster than the valve can take it away",
           "closed_parachute": "the rest raises the bag's pressure to its relief setting and "
                               "its relief valve must pass it",
           "enclosed": "the rest raises the bag's pressure to its relief setting and its "
                       "relief valve must pass it",
           "pressurised_cylinder": "the rest raises the cylinder's pressure to its relief "
                                   "setting"}


def dump_valve_check(scenario, plan) -> Check:
    """The dump valve the run uses (:func:`flexlift.scenario.valves.external_valve`: the user's
    ``gas.purge_rate_max_m3_s``, else the catalogue bag's, else the assumed one) against the
    expansion of a full bag's gas (its true capacity) rising at the planned speed at the
    target, per type (what the gas it cannot pass does: ``_EXCESS``); with the speed it can
    hold and the valve it would need. A bag whose catalogue entry gives no valve passes with
    a note (the purge-capacity check then judges the run's valve)."""
    bag, c = scenario.lift.catalogue_bag, scenario.control
    used = external_valve(scenario)
    if not plan.external:
        return Check("dump_valve", True, "no external bags: no dump valve to size")
    volume = max(b.capacity for b in plan.external)
    rate, p = expansion_rate_at_target(scenario, volume)
    where = (f"a full bag ({volume:.3g} m3) rising at the planned {c.ascent_speed_m_s:g} m/s "
             f"at the {c.target_height_m:g} m target ({p / 1e5:.2f} bar) expands at "
             f"{rate:.3g} m3/s")
    if bag.dump_valve_m3_s is None:  # the paper's cylinder, a bag without a maker's valve
        return Check("dump_valve", True, f"the bag's dump-valve capacity is not given; {where}; "
                     f"the run takes gas.purge_rate_max_m3_s = {used.m3_s:g} m3/s "
                     f"({used.source}; the purge-capacity check); give "
                     "lift.catalogue_bag.dump_valve_m3_s from its maker")
    valve = used.m3_s
    ok = valve >= rate
    whose = "its dump valve" if used.source == "catalogue" else "the user's dump valve"
    msg = (f"{bag.type.replace('_', ' ')} bag: {whose} ({used.key}) passes {valve:.3g} m3/s; "
           f"{where}"
           + (f" (margin {valve / rate:.2f})" if ok and rate > 0 else ""))
    if not ok:
        msg += (f": {_EXCESS[bag.type]}; lower control.ascent_speed_m_s to at most "
                f"{c.ascent_speed_m_s * valve / rate:.3g} m/s, or use a dump valve of at least "
                f"{rate:.3g} m3/s")
    if used.source == "user" and bag.dump_valve_m3_s is not None and valve > bag.dump_valve_m3_s:
        msg += (f" (more than the catalogue bag's {bag.dump_valve_m3_s:.3g} m3/s: the user's "
                "valve is taken)")
    return Check("dump_valve", bool(ok), msg)


def design_loads_t(scenario, plan) -> list[tuple[float, list[str], float]]:
    """(x [m], bag names, the lift point's design load [t]) of each external lift point: the
    sum of its bags' full true lifts (module docstring)."""
    bag = scenario.lift.catalogue_bag
    g = plan.gravity
    per = {b.name: bag.capacity_factor * max(bag.lift_t, b.lift / (1000.0 * g))
           for b in plan.external}
    return [(x, names, sum(per[n] for n in names)) for x, names in plan.lift_points()]


def sling_design_load_t(scenario, plan) -> float:
    """The largest single sling's design load [t]: its bag's full true lift."""
    bag = scenario.lift.catalogue_bag
    g = plan.gravity
    lifts = [b.lift / (1000.0 * g) for b in plan.external] or [0.0]
    return bag.capacity_factor * max(bag.lift_t, max(lifts))


def lift_point_capacities(scenario, plan) -> list[float] | None:
    """Each external lift point's capacity [t] aft to bow, or None when not given; a list of
    the wrong length is one line."""
    cap = scenario.lift.rigging.lift_point_capacity_t
    n = len(plan.lift_points())
    if cap is None:
        return None
    if isinstance(cap, list):
        if len(cap) != n:
            raise InputError("lift.rigging.lift_point_capacity_t", cap,
                             f"the plan has {n} external lift point(s); give {n} capacities "
                             "aft to bow, or one for every point")
        return [float(c) for c in cap]
    return [float(cap)] * n


def rigging_checks(scenario, plan) -> list[Check]:
    """The slings, the lift points' gear and the lift points (module docstring)."""
    rig = scenario.lift.rigging
    out = []
    points = design_loads_t(scenario, plan)
    sling = sling_design_load_t(scenario, plan)
    if rig.sling_wll_t is None:
        out.append(Check("sling", True, f"each sling's design load is {sling:.2f} t (its bag's "
                         "full true lift); the sling's working load limit is not given "
                         "(lift.rigging.sling_wll_t)"))
    else:
        ok = rig.sling_wll_t >= sling
        out.append(Check("sling", bool(ok), f"each sling's design load {sling:.2f} t (its bag's "
                         f"full true lift) against its {rig.sling_wll_t:g} t working load limit: "
                         f"utilisation {sling / rig.sling_wll_t:.2f}"
                         + ("" if ok else f"; use gear of at least {sling:.2f} t WLL")))
    if points and rig.cluster_wll_t is not None:
        x, names, load = max(points, key=lambda p: p[2])
        ok = rig.cluster_wll_t >= load
        out.append(Check("cluster_gear", bool(ok), f"the heaviest lift point ({len(names)} bag(s) "
                         f"at {x:.2f} m) carries up to {load:.2f} t against its gear's "
                         f"{rig.cluster_wll_t:g} t working load limit: utilisation "
                         f"{load / rig.cluster_wll_t:.2f}"
                         + ("" if ok else f"; use gear of at least {load:.2f} t WLL")))
    caps = lift_point_capacities(scenario, plan)
    f = CONSEQUENCE_LIFT_POINT
    if not points:
        return out
    if caps is None:
        worst = max(p[2] for p in points)
        out.append(Check("lift_points", True, f"the heaviest lift point's design load is "
                         f"{worst:.2f} t x {f:.2f} (0027/ND Table 11-1) = {worst * f:.2f} t; the "
                         "lift points' capacity is not given (lift.rigging.lift_point_capacity_t)"))
        return out
    util = [(p[2] * f / c, p, c) for p, c in zip(points, caps)]
    u, (x, names, load), cap = max(util, key=lambda r: r[0])
    ok = u <= 1.0
    out.append(Check("lift_points", bool(ok), f"the most loaded lift point ({len(names)} bag(s) at "
                     f"{x:.2f} m): design load {load:.2f} t x {f:.2f} (0027/ND Table 11-1) = "
                     f"{load * f:.2f} t against its {cap:g} t capacity: utilisation {u:.2f}"
                     + ("" if ok else "; strengthen the lift point or spread its bags")))
    return out


def arrangement_checks(scenario, plan) -> list[Check]:
    """Every arrangement and rigging check of ``plan`` (module docstring)."""
    return ([cluster_check(scenario, plan), headroom_check(scenario), depth_check(scenario),
             dump_valve_check(scenario, plan)] + rigging_checks(scenario, plan))
