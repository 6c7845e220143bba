"""The design basis (docs/theory/factors.md#design-basis): every factor, limit and assumed value
of a scenario with its source, the catalogue bag used, and the factors that do not apply with
their reason. The report's Design basis section and ``summary.json`` (``design_basis``) show it.

Sources: "user" (given in the scenario), "paper" (the built-in reference case's value),
"0027/ND ..." (GL Noble Denton 0027/ND, Guidelines for marine lifting and lowering
operations, by clause or table), "assumed" or "derived" (scenario/defaults.py), "default" (a
generic default of flexlift, the same for every structure: also when a file gives that same
value, as a run's own scenario.yaml does).
"""

from __future__ import annotations

from flexlift.physics.gas import ambient_pressure
from flexlift.scenario import catalogue, valves
from flexlift.scenario.defaults import POLICY, set_in
from flexlift.scenario.provenance import generic_defaults, source, value_of

__all__ = ["design_basis", "in_air_daf", "DAF_TABLE", "CONSEQUENCE_LIFT_POINT"]

#: 0027/ND Table 5-1, offshore in-air dynamic amplification: (up to this static hook load [t],
#: factor); shown for comparison only (a buoyancy-controlled lift's dynamics are the run's)
DAF_TABLE = ((300.0, 1.25), (1000.0, 1.20), (2500.0, 1.15), (float("inf"), 1.10))
#: 0027/ND Table 11-1: lift points and their attachments
CONSEQUENCE_LIFT_POINT = 1.30


def in_air_daf(weight_t: float) -> float | None:
    """0027/ND Table 5-1's offshore in-air DAF for a static hook load ``weight_t`` [t] (None
    below the table's 100 t)."""
    if weight_t < 100.0:
        return None
    return next(f for top, f in DAF_TABLE if weight_t <= top)


def _free_air_at_wreck(scenario) -> float:
    """A bag's fill rate at the wreck's depth as free air at the surface [m3/s] (Boyle)."""
    env = scenario.environment
    p = float(ambient_pressure(0.0, env.water_depth_m, env.atmospheric_pressure_Pa,
                               env.seawater_density_kg_m3 * env.gravity_m_s2))
    return scenario.gas.fill_rate_max_m3_s * p / env.atmospheric_pressure_Pa


def _row(item, value, src, note="") -> dict:
    return {"item": item, "value": value, "source": src, "note": note}


def _show(v, unit=""):
    if v is None:
        return "not given"
    if isinstance(v, list):
        return ", ".join(f"{x:g}" for x in v) + (f" {unit}" if unit else "")
    return f"{v:g}{' ' + unit if unit else ''}" if isinstance(v, float | int) else str(v)


def _catalogue_rows(scenario) -> list[dict]:
    bag = scenario.lift.catalogue_bag
    src = source(scenario, "lift.catalogue_bag.lift_t")
    note = ""
    if bag.model is not None:
        entry = catalogue.load(scenario.lift.catalogue_file).get(bag.model, {})
        packaged = bag.model in catalogue.load(None)
        where = ("flexlift's catalogue: generic, by stated rules" if packaged
                 else f"your catalogue file {scenario.lift.catalogue_file}")
        src = f"catalogue: {bag.model} ({entry.get('source', where)})"
        if entry.get("as_published"):
            note = (f"kept as published: a {bag.diameter_m:g} m x {bag.length_m:g} m body holds "
                    f"{catalogue.body_volume(entry):.1f} m3, not the "
                    f"{catalogue.rated_volume(entry):.0f} m3 its {bag.lift_t:g} t needs")
    if (scenario.defaulted or {}).get("lift.catalogue_bag") == "derived":
        note = ("chosen by flexlift (no bag given): "
                + POLICY["lift.catalogue_bag"][1] + (f"; {note}" if note else ""))
    body = ("type", "diameter_m", "length_m", "working_pressure_bar")
    if (bag.model is None and set_in(scenario, "lift.catalogue_bag.lift_t")
            and bag.lift_t != generic_defaults().lift.catalogue_bag.lift_t
            and not any(set_in(scenario, f"lift.catalogue_bag.{f}") for f in body)):
        # a lift alone: the rest of the bag is still the paper's 565 t cylinder's
        only = (f"only its lift given: its type and body are the paper's "
                f"{bag.type.replace('_', ' ')}'s ({bag.diameter_m:g} m x {bag.length_m:g} m, "
                f"{_show(bag.working_pressure_bar, 'bar')}), not sized for {bag.lift_t:g} t; "
                "name a catalogue bag (lift.catalogue_bag.model) or give its type and "
                "dimensions")
        note = f"{note}; {only}" if note else only
    dims = (f"{bag.type.replace('_', ' ')}, {bag.lift_t:g} t rated, {bag.diameter_m:g} m x "
            f"{bag.length_m:g} m, relief {_show(bag.relief_bar, 'bar')}, working pressure "
            f"{_show(bag.working_pressure_bar, 'bar')}, dump valve "
            f"{_show(bag.dump_valve_m3_s, 'm3/s')}, rated depth {_show(bag.rated_depth_m, 'm')}")
    used = valves.external_valve(scenario)
    why = {"user": "gas.purge_rate_max_m3_s given: it replaces the catalogue's valve",
           "catalogue": "the catalogue bag's dump_valve_m3_s (a generic entry: a full bag's "
                        "volume in 120 s, assumed; a maker's figure replaces it)",
           "assumed": POLICY[valves.KEY][1] + "; the bag's catalogue entry gives none",
           "paper": "the paper's large dump valve"}[used.source]
    return [_row("lift bag (catalogue entry)", dims, src, note),
            _row("dump valve of each external bag, in the run (fully open, bag full)",
                 f"{used.m3_s:g} m3/s", used.source,
                 why + "; internal bags: gas.purge_rate_max_m3_s"),
            _row("capacity factor (true over rated gas capacity)", bag.capacity_factor,
                 source(scenario, "lift.catalogue_bag.capacity_factor"),
                 "the bag-count rule decides how many bags; this factor their gas capacity")]


def design_basis(scenario, weight_t: float | None = None) -> list[dict]:
    """The design basis of ``scenario`` as rows {item, value, source, note}; ``weight_t``: the
    structure's mass [t] for the in-air DAF shown for comparison (default: the scenario's)."""
    lift, lim, rig = scenario.lift, scenario.limits, scenario.lift.rigging
    weight_t = scenario.hull_mass_t() if weight_t is None else weight_t
    pitch_src = source(scenario, "limits.pitch_deg")
    if pitch_src in ("assumed", "default") and lim.pitch_deg == 2.0:
        pitch_src = "0027/ND 5.3.2 (lifted object, by analogy)"
    rows = [
        _row("breakout factor (required lift / submerged weight)", lift.breakout_factor,
             source(scenario, "lift.breakout_factor")),
        _row("weight contingency", "none given" if lift.weight_contingency is None
             else lift.weight_contingency, "user",
             "the user's; flexlift assumes none"),
        *_catalogue_rows(scenario),
        _row("sling design load", "the bag's full true lift (capacity factor x rated lift)",
             "assumed", "any single failure (a fill valve stuck open) fills a bag; compared with "
             "the working load limit, which holds the gear's safety factor: no further factor"),
        _row("sling and shackle working load limit (per bag)", _show(rig.sling_wll_t, "t"),
             "user" if rig.sling_wll_t is not None else "not given"),
        _row("lift point gear working load limit (per point)", _show(rig.cluster_wll_t, "t"),
             "user" if rig.cluster_wll_t is not None else "not given"),
        _row("lift point structural capacity", _show(rig.lift_point_capacity_t, "t"),
             "user" if rig.lift_point_capacity_t is not None else "not given"),
        _row("consequence factor, lift points and their attachments", CONSEQUENCE_LIFT_POINT,
             "0027/ND Table 11-1", "1.15 for members framing into them"),
        _row("skew load factor", "not applicable", "0027/ND 5.6.12",
             "for crane rigging whose sling lengths redistribute the load; a bag's sling "
             "carries its own buoyancy"),
        _row("dynamic amplification, in air (comparison only)",
             "below the table's 100 t" if in_air_daf(weight_t) is None
             else in_air_daf(weight_t), "0027/ND Table 5-1",
             f"offshore 1.25 / 1.20 / 1.15 / 1.10 for 100-300 / 300-1000 / 1000-2500 / > 2500 t "
             f"({weight_t:,.0f} t here); not applied: a buoyancy-controlled lift needs a dynamic "
             "analysis (19.12.4), which the simulated ascent is"),
        _row("tilt limit", "none (the bending utilisation governs)" if lim.pitch_deg is None
             else f"{lim.pitch_deg:g} deg", pitch_src),
        _row("ascent velocity limit", f"{lim.ascent_velocity_m_s:g} m/s",
             source(scenario, "limits.ascent_velocity_m_s")),
        _row("descent velocity limit", f"{lim.descent_velocity_m_s:g} m/s",
             source(scenario, "limits.descent_velocity_m_s")),
        _row("arrival tolerance", f"{lim.arrival_tolerance_m:g} m",
             source(scenario, "limits.arrival_tolerance_m")),
        _row("allowable hull girder stress", f"{scenario.hull.allowable_stress_MPa:g} MPa",
             source(scenario, "hull.allowable_stress_MPa")),
        (_row("gas supply per bag", f"{scenario.gas.fill_rate_max_m3_s:g} m3/s at the bag's depth",
              source(scenario, "gas.fill_rate_max_m3_s"),
              "no compressor stated (gas.supply_free_air_m3_min): at the wreck's "
              f"{scenario.environment.water_depth_m:g} m that is "
              f"~{_free_air_at_wreck(scenario):.2g} m3/s of free air per bag")
         if scenario.gas.supply_free_air_m3_min is None else
         _row("gas supply (compressor)",
              f"{scenario.gas.supply_free_air_m3_min:g} m3/min of free air, shared; at the bag "
              "x p_atm / p", source(scenario, "gas.supply_free_air_m3_min"),
              f"each bag at most {scenario.gas.fill_rate_max_m3_s:g} m3/s at its depth")),
    ]
    shown = {"lift.breakout_factor", "limits.pitch_deg", "hull.allowable_stress_MPa",
             "gas.fill_rate_max_m3_s", "lift.catalogue_bag",  # the bag: its own row above
             "gas.purge_rate_max_m3_s"}  # the dump valve: its own row above
    for key, how in (scenario.defaulted or {}).items():
        if key not in shown:
            try:
                value = value_of(scenario, key)
            except AttributeError:
                value = None
            shown_value = "auto (the rule beside it)" if value is None else _show(value)
            rows.append(_row(key, value if isinstance(value, str) else shown_value, how,
                             POLICY.get(key, ("", ""))[1]))
    return rows
