"""Ready uncertainty studies: the uncertainties a salvor faces, each law with its source.

A study is a Monte Carlo whose variables are what the salvor does not know, while the plan
stays the one rigged: the study's base is the scenario with its lift plan pinned (every bag
of the plan listed in ``lift.bags``, one entry per bag with the plan's lift), so a heavier
structure or a stronger soil meets the same bags rather than a plan redrawn for it.

``salvage`` (:data:`STUDIES`), for a hull (``tanker``, a user's hull):

======================================  ========================================  ==========
variable                                law (nominal: the scenario's value)       source
======================================  ========================================  ==========
``soil.breakout_force_factor``          uniform 0.5-1.5 (x the soil's H0)         R-755
``seabed.breakout_time_s`` (**)        log-uniform 0.5-2 x nominal               R-755
``lift.bags.NAME.capacity_factor``      uniform 0.95-1.25, one draw per bag       incident
``hull.submerged_weight_t``             uniform 0.9-1.1 x nominal W'              the user's
``disturbance.current_m_s``             uniform nominal -/+ 0.25 m/s              assumed
``gas.fill_rate_max_m3_s``              uniform 0.8-1.2 x nominal                 assumed
``gas.purge_rate_max_m3_s`` (*)         uniform 0.8-1.2 x nominal                 assumed
``gas.supply_free_air_m3_min``          uniform 0.8-1.0 x nominal (when stated)   assumed
======================================  ========================================  ==========

(**) under the soil's breakout law (``seabed.breakout_law: soil``,
docs/theory/breakout-soil.md) ``seabed.consolidation_coefficient_m2_s`` instead, log-uniform
0.5-2 x nominal (the time goes as 1 / c_v), and ``soil.breakout_force_factor`` u scales the
soil's strength, ``seabed.shear_strength_kPa = u s_u`` (H0 is proportional to it): the timer
law's keys are not read by the soil law. The field cases check these bands
(docs/validation/study-bands.md).

(*) the key that sets the external bags' dump valve in the run
(:func:`flexlift.scenario.valves.external_valve`): ``lift.catalogue_bag.dump_valve_m3_s`` when
the catalogue bag's valve governs.

The soil's breakout force is H0 = (breakout_factor - 1) W' (docs/theory/seabed.md); the
R-755 band (+-50 %, NCEL R-755, Lee 1973) is on H0, the soil's force, not on the total lift
breakout_factor W': ``soil.breakout_force_factor`` u gives the case
``lift.breakout_factor = 1 + u (bf0 - 1) W0' / W'`` (bf0, W0' the nominal ones, W' the
case's), so that H0 = u H0_nominal whatever the case's weight. A SPEC with ``study: salvage``
may list, under ``monte_carlo.vary``, a law for any of these names (narrowing or widening a
range; ``lift.bags.capacity_factor`` sets every bag's) or for any other scenario key (added);
each law is checked against its variable's allowed range (:data:`ALLOWED`). Each case runs
until it has an outcome (``simulation.duration_s: auto``) unless the SPEC sets or varies the
duration (:mod:`flexlift.sweep.spec`): the slow breakouts drawn here outlast a fixed run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from flexlift.errors import InputError, brief
from flexlift.scenario.valves import external_valve
from flexlift.sweep.distributions import Distribution, parse_distribution
from flexlift.sweep.keys import Key, check_key

SOIL = "soil.breakout_force_factor"
BAGS = "lift.bags.capacity_factor"  # the group of every bag's factor
#: the allowed ranges of the study's own variables (not scenario keys)
ALLOWED = {SOIL: Key(SOIL, "real", 0.0, 4.0), BAGS: Key(BAGS, "real", 1e-3, 10.0)}

R755 = ("NCEL R-755 (Lee 1973, Techniques for predicting sea floor breakout forces): the "
        "soil's breakout force to about +-50 %, its time to about +-100 %")
INCIDENT = ("a published incident: a lift bag lifted 25 % over its rating; lower end 0.95 "
            "assumed (a bag not quite filling its rating)")
SOURCES = {
    SOIL: R755 + "; the band is on H0 = (breakout_factor - 1) W', not the total lift",
    "seabed.breakout_time_s": R755 + "; log-uniform 0.5-2 x nominal",
    "seabed.consolidation_coefficient_m2_s": R755 + "; log-uniform 0.5-2 x nominal c_v (the "
                                             "soil law: the time goes as 1 / c_v)",
    BAGS: INCIDENT + "; one independent draw per bag",
    "hull.submerged_weight_t": "the user's range (default +-10 % of the nominal W', assumed: "
                               "give your own under monte_carlo.vary)",
    "disturbance.current_m_s": "assumed: +-0.25 m/s about the nominal current",
    "gas.fill_rate_max_m3_s": "assumed: fill valves +-20 % of their rating",
    "gas.purge_rate_max_m3_s": "assumed: dump valves +-20 % of their rating",
    "lift.catalogue_bag.dump_valve_m3_s": "assumed: dump valves +-20 % of their rating",
    "gas.supply_free_air_m3_min": "assumed: a compressor delivers 80-100 % of its rated free air",
}


@dataclass(frozen=True)
class StudyPlan:
    """What a study's case needs to turn its values into scenario changes: the nominal
    breakout factor and wet weight [t], and the pinned bags (as dumped mappings)."""

    name: str
    breakout_factor: float
    wet_weight_t: float
    bags: tuple  # the base's lift.bags, each a dict
    sources: tuple  # (variable, source) pairs, for the report
    law: str = "timer"  # the base's seabed.breakout_law
    shear_strength_kPa: float = 0.0  # the base's seabed.shear_strength_kPa (the soil law)


STUDIES = {"salvage": "the salvors' uncertainties: soil breakout force and time (R-755), each "
                      "bag's capacity (one draw per bag), the submerged weight, the current, "
                      "the valves and the supply"}


def study_names() -> str:
    return ", ".join(STUDIES)


def check_study(name, where: str) -> str:
    if name not in STUDIES:
        raise InputError.from_line(f"{where}: unknown study {brief(name, 40)}; the studies are "
                                   f"{study_names()}")
    return name


def bag_key(name: str) -> str:
    return f"lift.bags.{name}.capacity_factor"


def is_bag_key(key) -> bool:
    return (isinstance(key, str) and key.startswith("lift.bags.")
            and key.endswith(".capacity_factor") and key != BAGS)


def group_of(key: str) -> str:
    """The Sobol group of a variable: every bag's capacity factor is one group."""
    return BAGS if is_bag_key(key) else key


def pin_plan(base, where: str):
    """(``base`` with its lift plan listed in ``lift.bags``, one entry per bag, and the
    nominal breakout factor and wet weight [t])."""
    from flexlift import constants as C
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    if base.pipe is not None:
        raise InputError.from_line(f"{where}: the salvage study is for a hull; a pipeline's "
                                   "bags and suction come from pipe: (vary its keys in a SPEC)")
    try:
        plan = plan_lift(base, hull_from_scenario(base))
    except InputError as exc:
        raise InputError.from_line(f"{where}: {exc}") from None
    g = plan.gravity
    own = {b.name: b for b in base.lift.bags} if base.lift.bags is not None else {}
    bags = []
    for b in plan.bags:
        d = {"name": b.name, "kind": b.kind, "lift_t": b.lift / (C.TONNE * g)}
        if b.kind == "external":
            d.update({"node": b.node + 1} if b.node is not None else {"x_m": b.x})
        else:
            d["span_m"] = [float(b.span[0]), float(b.span[1])]
        if b.name in own and own[b.name].capacity_factor is not None:
            d["capacity_factor"] = own[b.name].capacity_factor
        bags.append(d)
    pinned = base.with_changes(**{"lift.bags": bags})
    return pinned, plan.breakout_factor, plan.wet_weight / (C.TONNE * g)


def default_laws(base, wet_t: float) -> dict:
    """{variable: its law as a SPEC mapping} of the salvage study for ``base`` (pinned)."""
    sb, gas, cur = base.seabed, base.gas, base.disturbance.current_m_s
    valve = external_valve(base)  # the dump valve the run takes, by the key that sets it
    time = (("seabed.consolidation_coefficient_m2_s", sb.consolidation_coefficient_m2_s)
            if sb.breakout_law == "soil" else ("seabed.breakout_time_s", sb.breakout_time_s))
    laws = {SOIL: {"dist": "uniform", "low": 0.5, "high": 1.5},
            time[0]: {"dist": "loguniform", "low": 0.5 * time[1], "high": 2.0 * time[1]},
            BAGS: {"dist": "uniform", "low": 0.95, "high": 1.25},
            "hull.submerged_weight_t": {"dist": "uniform", "low": 0.9 * wet_t,
                                        "high": 1.1 * wet_t},
            "disturbance.current_m_s": {"dist": "uniform", "low": max(-5.0, cur - 0.25),
                                        "high": min(5.0, cur + 0.25)},
            "gas.fill_rate_max_m3_s": {"dist": "uniform", "low": 0.8 * gas.fill_rate_max_m3_s,
                                       "high": 1.2 * gas.fill_rate_max_m3_s},
            valve.key: {"dist": "uniform", "low": 0.8 * valve.m3_s, "high": 1.2 * valve.m3_s}}
    if gas.supply_free_air_m3_min is not None:
        laws["gas.supply_free_air_m3_min"] = {"dist": "uniform",
                                              "low": 0.8 * gas.supply_free_air_m3_min,
                                              "high": gas.supply_free_air_m3_min}
    return laws


def study_distributions(name: str, base, user: dict, fixed: dict, where: str):
    """(the pinned base, {variable: Distribution}, the :class:`StudyPlan`): the study's laws
    with the user's ``vary`` laid over them (a narrower or wider law, or a new key)."""
    check_study(name, f"{where}: study")
    pinned, bf0, wet_t = pin_plan(base, f"{where}: study {name}")
    laws = default_laws(pinned, wet_t)
    for k in fixed:
        laws.pop(k, None)  # fixed under set: is not varied
    defaults = dict(laws)
    laws.update(user)
    out: dict[str, Distribution] = {}
    for key, law in laws.items():
        if key in ALLOWED:
            k = ALLOWED[key]
        elif is_bag_key(key):
            bag = key[len("lift.bags."):-len(".capacity_factor")]
            if bag not in {b.name for b in pinned.lift.bags}:
                raise InputError.from_line(
                    f"{where}.vary: {key} names no bag of the plan (bags: "
                    f"{brief([b.name for b in pinned.lift.bags], 80)})")
            k = Key(key, "real", ALLOWED[BAGS].low, ALLOWED[BAGS].high)
        else:
            k = check_key(key, f"{where}.vary")
        if isinstance(law, dict) and law.get("dist") == "choice" and key in (SOIL, BAGS):
            raise InputError.from_line(f"{where}.vary.{key}: a factor needs a continuous law")
        out[key] = parse_distribution(k, law, f"{where}.vary")
    if BAGS in out:  # one law, drawn per bag
        law = out.pop(BAGS)
        for b in pinned.lift.bags:
            if bag_key(b.name) not in out:
                out[bag_key(b.name)] = Distribution(bag_key(b.name), law.kind, law.params,
                                                    law.low, law.high)
    sources = tuple({group_of(k): _source(k, user, defaults) for k in laws}.items())
    bags = tuple(b.model_dump(mode="json", exclude_none=True) for b in pinned.lift.bags)
    return pinned, out, StudyPlan(name, bf0, wet_t, bags, sources,
                                  law=pinned.seabed.breakout_law,
                                  shear_strength_kPa=pinned.seabed.shear_strength_kPa)


def _source(key: str, user: dict, defaults: dict) -> str:
    """Where a variable's law comes from: the study's source, and whether the SPEC changed
    its range (a law the SPEC repeats unchanged, as a resumed sweep's does, keeps its source)."""
    known = SOURCES.get(group_of(key))
    if key in user and user[key] != defaults.get(group_of(key)):
        return f"{known}; the range given in the SPEC" if known else "the SPEC"
    return known or "the SPEC"


def study_changes(plan: StudyPlan, values: dict) -> dict:
    """The scenario changes of a case's study ``values`` (plain keys pass through)."""
    out = {k: v for k, v in values.items() if k != SOIL and not is_bag_key(k)}
    if SOIL in values and plan.law == "soil":  # H0 = A s_u N_c: u H0 is u s_u
        out["seabed.shear_strength_kPa"] = float(values[SOIL]) * plan.shear_strength_kPa
    elif SOIL in values:
        wet = float(values.get("hull.submerged_weight_t", plan.wet_weight_t))
        out["lift.breakout_factor"] = 1.0 + (float(values[SOIL]) * (plan.breakout_factor - 1.0)
                                             * plan.wet_weight_t / wet)
    factors = {k: v for k, v in values.items() if is_bag_key(k)}
    if factors:
        bags = [dict(b) for b in plan.bags]
        for b in bags:
            f = factors.get(bag_key(b["name"]))
            if f is not None and math.isfinite(f):
                b["capacity_factor"] = float(f)
        out["lift.bags"] = bags
    return out
