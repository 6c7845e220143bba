"""Checks of a lift plan before the run (docs/theory/strength.md#checks): each says what it found, with the
numbers and the fix.

A *refusal* means the plan cannot work at all (the run would only fail): :func:`refuse_unworkable`
raises :class:`~flexlift.errors.InputError` with one line, and :func:`~flexlift.ascent.simulate`
calls it. The others are warnings, shown by ``flexlift loads`` and in the report:

- balance: the lift centroid against the centre of gravity, and the static pitch moment;
- breakout: the pull against the suction H_0 and the separation time it implies (docs/theory/seabed.md#suction-held)
  against the run's duration;
- purge capacity: from which height up the planned speed cannot be held by purging (the
  planned ascent slows there, :mod:`flexlift.control.profile`);
- fill: the time the supply takes to fill the breakout pull;
- duration: the separation, the ascent at the planned (valve-limited) speed and the hold
  against ``simulation.duration_s`` (a run too short ends *incomplete*);
- hull girder stress under the plan: sigma = M / Z against the allowable stress;
- the arrangement and rigging (:mod:`flexlift.ascent.arrangement`);
- a staged lift: whether the structure is flexible enough to peel off in its stages.
"""

from __future__ import annotations

import logging
import math

import numpy as np

from flexlift import constants as C
from flexlift.ascent.arrangement import Check, arrangement_checks, lift_point_capacities
from flexlift.control.build import bag_pulls, breakout_pull
from flexlift.control.profile import speed_limit
from flexlift.control.reference import trapezoid
from flexlift.control.sequence import start_times
from flexlift.errors import InputError
from flexlift.loads.statics import suspended_length
from flexlift.physics import seabed
from flexlift.physics.gas import ambient_pressure

log = logging.getLogger(__name__)


def _t(force: float, g: float) -> float:
    return force / (C.TONNE * g)


def refuse_unworkable(scenario, plant) -> None:
    """InputError (one line) for a plan that cannot work: the target above where the bags
    reach the surface, no breakout pull, or closed bags relieving above their working pressure."""
    env, lim, c = scenario.environment, scenario.limits, scenario.control
    if not plant.external.any():
        raise InputError("lift.internal_bags", scenario.lift.internal_bags,
                         f"all {plant.external.size} bags are internal: none is left to pull the "
                         "hull off the seabed and control the ascent; use fewer internal bags")
    top = float(plant.bags.top_offset.max())
    highest = env.water_depth_m - lim.surface_clearance_m - top
    if c.target_height_m >= highest:
        raise InputError(
            "control.target_height_m", c.target_height_m,
            f"the bags' tops ({top:.1f} m above the hull bottom) reach the surface when the hull "
            f"is {highest:.1f} m above the seabed in {env.water_depth_m:g} m of water; choose a "
            f"target below {highest:.1f} m")
    H0 = float(plant.seabed.H0.sum())
    if H0 > 0 and breakout_pull(scenario, H0) <= 0:
        raise InputError("control.breakout_pull_t", c.breakout_pull_t,
                         f"with no pull the hull never separates from its {_t(H0, plant.gravity):.0f} t "
                         "of suction; give a positive pull (default: 18 % of the suction)")
    lift_point_capacities(scenario, plant.plan)  # a list of the wrong length: one line
    relief, work = scenario.gas.relief_pressure_bar, scenario.lift.catalogue_bag.working_pressure_bar
    if (~plant.external).any() and work is not None and relief > work:
        raise InputError("gas.relief_pressure_bar", relief,
                         f"the closed (internal) bags would hold more over-pressure than their "
                         f"{work:g} bar working pressure; set the relief at or below it")


def plan_checks(scenario, plant) -> list[Check]:
    """Every warning-level check of ``plant``'s lift plan (module docstring)."""
    checks = [balance_check(plant), breakout_check(scenario, plant),
              purge_check(scenario, plant), fill_check(scenario, plant),
              duration_check(scenario, plant)] + arrangement_checks(scenario, plant.plan)
    if scenario.control.sequence is not None:
        checks.append(sequence_check(scenario, plant))
    return checks


def sequence_check(scenario, plant) -> Check:
    """Whether the structure is flexible enough to be peeled off in the stages of
    ``control.sequence``: a stage rising h ahead of the next bends the structure over the
    length a heavy beam lifted off the seabed takes, l = (24 EI h / q)^(1/4) (docs/theory/statics.md#peel-off); a
    stage's stretch shorter than that does not peel, it pivots on the held one."""
    c, hull = scenario.control, plant.hull
    lead = trapezoid(c.sequence.delay_s, c.target_height_m, c.ascent_speed_m_s,
                     c.ascent_acceleration_m_s2)[0]
    q = plant.wet_weight / hull.length
    EI = float(np.median(hull.EI))
    peel = suspended_length(EI, q, max(lead, 1e-9))
    stretch = hull.length / max(plant.seabed.ng, 1)
    ok = bool(peel <= stretch)
    msg = (f"a stage {lead:.2f} m ahead of the next (its {c.sequence.delay_s:g} s start) bends the "
           f"structure over ~{peel:,.0f} m (l = (24 EI h / q)^1/4), "
           f"{'within' if ok else 'longer than'} a stage's {stretch:,.0f} m of it")
    if not ok:
        msg += ("; too stiff to peel in these stages: it pivots on the held stretch and whips "
                "when that lets go; lift it at once (no control.sequence) or in fewer, longer "
                "stages")
    return Check("sequence", ok, msg)


def weight_centre(hull, g: float, rho_water: float, rho_steel: float) -> float:
    """Where the submerged weight W' acts [m from the aft end]: each element's own wet weight
    (its density: a pipe's coating and contents per element) and the point masses' (steel),
    the centre the balanced layout puts the holding lifts on (:mod:`flexlift.loads.balance`)."""
    x_e = 0.5 * (hull.x_nodes[1:] + hull.x_nodes[:-1])
    w = np.concatenate([hull.wet_weight_per_length(g, rho_water, rho_steel) * hull.element_length,
                        hull.point_wet_weights(g, rho_water, rho_steel)])
    return float(w @ np.concatenate([x_e, hull.x_nodes]) / w.sum())


def balance_check(plant) -> Check:
    """The bags' holding-lift centroid against the centre of the wet weight (the centre the
    layout balances on: :func:`weight_centre`)."""
    hull, plan = plant.hull, plant.plan
    cg = weight_centre(hull, plant.gravity, plant.seawater_density, plant.steel_density)
    e = plan.lift_centroid - cg
    moment = float(plan.holding_lifts().sum()) * e
    ok = abs(e) <= 0.01 * hull.length
    msg = (f"lift centroid {plan.lift_centroid:.2f} m from the aft end, centre of the wet weight "
           f"{cg:.2f} m: {e:+.2f} m ({100 * e / hull.length:+.2f} % of L), a static pitch moment "
           f"of {moment / 1e6:.1f} MN m")
    if not ok:
        msg += "; balance the bags (lift.layout: balanced) or move them"
    return Check("balance", ok, msg)


def _separations(scenario, plant):
    """The breakout pull of each external bag and what the fill holds of it [m^3], and each
    stage's separation time and fill time [s] (docs/theory/seabed.md#suction-held: the bags of a stage fill at once)."""
    ext = np.flatnonzero(plant.external)
    V_pull = bag_pulls(scenario, plant)
    held = np.maximum(V_pull - scenario.control.volume_deadband_m3, 0.0)
    start = start_times(scenario, plant.names, plant.x_point, plant.external)[ext]
    q_in = fill_rate_on_seabed(scenario, int(plant.external.sum()))
    T_b = scenario.seabed.breakout_time_s
    times, fills = [], []
    for k in range(plant.seabed.ng):
        mine = plant.bags.group[ext] == k
        fill = float(held[mine].sum()) / max(mine.sum() * q_in, 1e-12)
        fills.append(fill)
        pull = float(held[mine].sum()) * plant.bags.rho_g
        times.append(float(start[mine].max(initial=0.0)) + fill + (
            seabed.soil_separation_time(pull, float(plant.seabed.H0[k]),
                                        plant.seabed.consolidation_time)
            if plant.seabed.law == seabed.LAW_SOIL
            else seabed.separation_time(pull, float(plant.seabed.H0[k]), T_b)))
    return V_pull, held, times, fills


def planned_run(scenario, plant) -> tuple[float, float, float]:
    """(the last separation, the rise to the target, the whole run with the hold) [s] as the
    plan expects them: the breakout check's separation times, the ascent at the planned speed
    where the purge valves keep up and at their limit where not, ``simulation.hold_time_s``
    (inf when the pull never separates the hull)."""
    from flexlift.ascent.outcome import remaining_ascent_s

    t_sep = max(_separations(scenario, plant)[2]) if float(plant.seabed.H0.sum()) > 0 else 0.0
    rise = remaining_ascent_s(scenario, plant, 0.0)
    return t_sep, rise, t_sep + rise + scenario.simulation.hold_time_s


def duration_check(scenario, plant) -> Check:
    """Whether the run is long enough for the plan: the last separation (the breakout check's
    estimate), the ascent to the target at the planned speed where the purge valves keep up
    and at their limit where not, and the hold (``simulation.hold_time_s``)."""
    sim = scenario.simulation
    t_sep, rise, need = planned_run(scenario, plant)
    if not math.isfinite(need):
        return Check("duration", False, "the pull never separates the hull (the breakout check "
                     "says why), so no run is long enough: the plan cannot finish")
    how = (f"the plan needs ~{need:,.0f} s: separation at ~{t_sep:,.0f} s, {rise:,.0f} s rising "
           f"{scenario.control.target_height_m:g} m at the planned "
           f"{scenario.control.ascent_speed_m_s:g} m/s (slower where the purge valves cannot keep "
           f"up) and the {sim.hold_time_s:.0f} s hold")
    if sim.duration_s == "auto":
        ok = bool(need < sim.longest_run_s)
        return Check("duration", ok, f"{how}; duration auto: the run stops once the target is "
                     f"held, at most after {sim.longest_run_s:,.0f} s"
                     + ("" if ok else " (too short: lengthen simulation.time_step_s or "
                        "output_interval_s, which set that limit)"))
    ok = bool(need <= sim.duration_s)
    msg = f"{how}, {'within' if ok else 'longer than'} the {sim.duration_s:,.0f} s run"
    if not ok:
        msg += (f": the run would end incomplete; set simulation.duration_s to at least "
                f"{math.ceil(need * 1.1 / 100) * 100:,.0f} s, or auto")
    return Check("duration", ok, msg)


def warn_short(scenario, plant) -> None:
    """Log the :func:`duration_check` warning when the run is too short for the plan."""
    check = duration_check(scenario, plant)
    if not check.ok:
        log.warning("simulation.duration_s: %s", check.message)


def breakout_check(scenario, plant) -> Check:
    """Whether the pull breaks the suction within the run (docs/theory/seabed.md#suction-held and the fill). The fill
    stops within the volume deadband of its target, so each bag holds its pull less the
    deadband. A staged lift: each stage's stretch separates under its own bags' pull from
    their start; the last to let go decides."""
    g = plant.gravity
    H0 = float(plant.seabed.H0.sum())
    if H0 <= 0:
        return Check("breakout", True, "no suction (breakout factor 1): the hull lifts as soon as it is light")
    V_pull, held, times, fills = _separations(scenario, plant)
    T_b = scenario.seabed.breakout_time_s
    last = int(np.argmax(times))
    duration = scenario.simulation.run_length_s
    ok = bool(times[last] < 0.8 * duration)
    pull = float(V_pull.sum()) * plant.bags.rho_g
    lost = pull - float(held.sum()) * plant.bags.rho_g
    verdict = f"{'within' if ok else 'too close to or beyond'} the {duration:,.0f} s run"
    if plant.seabed.ng == 1:
        msg = (f"a pull of {_t(pull, g):.0f} t breaks the {_t(H0, g):.0f} t hold in "
               f"~{times[0]:,.0f} s ({fills[0]:.0f} s of it filling the pull), {verdict}")
    else:
        msg = (f"a staged lift in {plant.seabed.ng} stages: each stretch separates under its own bags' "
               f"pull ({_t(pull, g):.0f} t in all), the first at ~{times[0]:,.0f} s, the last "
               f"(stage {last + 1}, {_t(float(plant.seabed.H0[last]), g):.1f} t of suction) at "
               f"~{times[last]:,.0f} s, {verdict}")
    if lost > 0.1 * pull:
        msg += (f"; the fill stops {scenario.control.volume_deadband_m3:g} m3 short of each bag's "
                f"target (control.volume_deadband_m3), {_t(lost, g):.1f} t of the pull: lower it "
                "for small bags")
    if not ok and plant.seabed.ng == 1:
        need = H0 / (1.0 + max(0.8 * duration - fills[0], 1.0) / T_b)
        msg += (f"; raise control.breakout_pull_t to at least {_t(need, g):.0f} t or "
                "simulation.duration_s")
    elif not ok:
        msg += ("; raise control.breakout_pull_t, shorten control.sequence.delay_s or lengthen "
                "simulation.duration_s")
    return Check("breakout", ok, msg)


def purge_check(scenario, plant) -> Check:
    """From which height up the planned speed cannot be held by purging."""
    c = scenario.control
    ext = np.flatnonzero(plant.external)
    if not ext.size:
        return Check("purge_capacity", True, "no external bags: nothing to purge")
    z = np.linspace(0.0, c.target_height_m, 2001)
    lim = np.min([speed_limit(z, plant.neutral_volume[i], plant.bags.capacity[i], plant.bags.purge_max[i],
                              c.purge_margin, plant.bags.water_depth, plant.bags.p_atm, plant.bags.rho_g) for i in ext], axis=0)
    slow = lim < c.ascent_speed_m_s
    if not slow.any():
        return Check("purge_capacity", True,
                     f"the purge valves keep up with the gas expansion at the planned "
                     f"{c.ascent_speed_m_s:g} m/s all the way to the target "
                     f"(at least {lim.min():.2f} m/s with margin {c.purge_margin:g})")
    z0 = float(z[slow][0])
    return Check("purge_capacity", False,
                 f"from {z0:.1f} m above the seabed ({plant.bags.water_depth - z0:.1f} m deep) up, the gas "
                 f"expands faster than {c.purge_margin:g} of the purge capacity at the planned "
                 f"{c.ascent_speed_m_s:g} m/s: the planned ascent slows to {lim[slow].min():.3f} m/s "
                 "there (larger purge valves, gas.purge_rate_max_m3_s, would keep the speed)")


def fill_rate_on_seabed(scenario, n_filling: int) -> float:
    """Each of ``n_filling`` bags' fill rate at the seabed [m^3/s at local pressure]: its own
    rate, or a compressor's share of free air derated by depth (docs/theory/gas.md#supply)."""
    q = scenario.gas.fill_rate_max_m3_s
    fad = scenario.gas.supply_free_air_m3_min
    if fad is None:
        return q
    env = scenario.environment
    p = float(ambient_pressure(0.0, env.water_depth_m, env.atmospheric_pressure_Pa,
                               env.seawater_density_kg_m3 * env.gravity_m_s2))
    return min(q, fad / 60.0 * env.atmospheric_pressure_Pa / p / max(n_filling, 1))


def fill_check(scenario, plant) -> Check:
    """How long the supply takes to fill the breakout pull."""
    n_ext = int(plant.external.sum())
    if not n_ext:
        return Check("fill", True, "no external bags: nothing is filled during the run")
    pull = breakout_pull(scenario, float(plant.seabed.H0.sum())) / plant.bags.rho_g  # [m^3] at local pressure
    q = fill_rate_on_seabed(scenario, n_ext)
    t_fill = pull / max(n_ext * q, 1e-12)
    V_n = plant.neutral_volume[plant.external]
    t_first = float(V_n.max()) / q
    ok = t_fill < 0.1 * scenario.simulation.run_length_s
    fad = scenario.gas.supply_free_air_m3_min
    supply = (f"the supply ({q:g} m3/s per bag)" if fad is None else
              f"the compressor ({fad:g} m3/min of free air: {q:.3g} m3/s per bag at the seabed)")
    msg = (f"{supply} fills the {pull:.0f} m3 pull in {t_fill:.0f} s; the initial fill to the "
           f"neutral volume took {t_first / 60:.0f} min per bag")
    if not ok:
        msg += ("; raise gas.fill_rate_max_m3_s" if fad is None
                else "; a larger compressor (gas.supply_free_air_m3_min), or more of them")
    return Check("fill", ok, msg)
