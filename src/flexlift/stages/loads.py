"""The lift-plan stage (docs/theory/factors.md#bag-count): bag count and layout, and the hull's static shear force
and bending moment under the plan, as data, figures and tables.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from flexlift import constants as C
from flexlift.ascent.checks import plan_checks, refuse_unworkable
from flexlift.ascent.plant import coupled_plant
from flexlift.ascent.result import section_modulus
from flexlift.loads.design import DesignCase, design_cases, paper_case
from flexlift.loads.liftplan import LiftPlan, plan_lift
from flexlift.loads.strength import Strength, lift_load_case
from flexlift.output.stage import Figure, StageOutput, Table
from flexlift.plumbing.atomic import write_text
from flexlift.structure.hull import hull_from_scenario

log = logging.getLogger(__name__)
NAME = "loads"


def _extreme(e, scale: float) -> dict:
    return {"value": e.value / scale, "x_m": e.x, "node": e.node}


def design(scenario, hull, plan, plant=None, per_element: int = 50):
    """The three closed design cases of the plan (:mod:`flexlift.loads.design`): the mass that
    accelerates in water is the structure plus the added mass and the entrained water, as the
    ascent integrates it; the holding lifts (the bags' neutral volumes), the suction H_0, its
    shape and the shaped breakout pull are the ascent's own."""
    from flexlift.ascent.plant import wet_beam
    from flexlift.control.build import bag_pulls

    plant = plant or coupled_plant(scenario, hull, plan)
    moving = hull.mass_per_length + wet_beam(scenario, hull)[1]
    ext = [n for n, e in zip(plant.names, plant.external) if e]
    pulls = dict(zip(ext, (bag_pulls(scenario, plant) * plant.bags.rho_g).tolist()))
    holding = dict(zip(plant.names, (plant.neutral_volume * plant.bags.rho_g).tolist()))
    return design_cases(plan, hull, moving, float(plant.seabed.H0.sum()), plant.hold_stern_bow,
                        pulls, per_element, holding)


def still_water(scenario, hull, plan, per_element: int = 50):
    """(closed load case, strength) of the governing design case: the largest bending
    utilisation (the largest |M| where the section modulus is uniform)."""
    cases = design(scenario, hull, plan, per_element=per_element)
    c = max(cases, key=lambda c: float(utilisation_along(scenario, c.strength).max()))
    return c.case, c.strength


def utilisation_along(scenario, st: Strength) -> np.ndarray:
    """sigma / sigma_allow = |M| / (Z sigma_allow) at ``st.x`` [-]."""
    return np.abs(st.M) / section_modulus(scenario, st.x) / (scenario.hull.allowable_stress_MPa * 1e6)


def stress_of(scenario, st: Strength) -> dict:
    """Hull girder bending stress sigma = |M| / Z under the plan and its utilisation."""
    Z = section_modulus(scenario, st.x)
    sigma = np.abs(st.M) / Z
    k = int(np.argmax(sigma))
    allow = scenario.hull.allowable_stress_MPa
    return {"max_MPa": float(sigma[k] / 1e6), "x_m": float(st.x[k]),
            "allowable_MPa": allow, "max_utilisation": float(sigma[k] / 1e6 / allow)}


def _strength_of(st: Strength) -> dict:
    return {"max_shear_MN": _extreme(st.max_shear, 1e6),
            "max_moment_MNm": _extreme(st.max_moment, 1e6),
            "max_sagging_MNm": _extreme(st.max_sagging, 1e6),
            "max_hogging_MNm": _extreme(st.max_hogging, 1e6)}


def case_summary(scenario, c: DesignCase, g: float) -> dict:
    """One closed design case in the JSON summary (tonnes, MN, MN m, m/s^2, rad/s^2)."""
    st, cl = c.strength, c.closure
    down = -sum(d.resultant for d in c.case.line_loads
                if d.resultant < 0 and not d.name.startswith("inertia")) - sum(
        p.force for p in c.case.point_loads if p.force < 0 and not p.name.startswith("inertia"))
    return {"title": c.title, "scale_factor": cl.scale,
            "heave_acceleration_m_s2": cl.heave_acceleration,
            "pitch_acceleration_rad_s2": cl.pitch_acceleration,
            "centre_of_moving_mass_m": cl.centre, "moving_mass_t": cl.moving_mass / C.TONNE,
            "load_t": down / (C.TONNE * g), "lift_t": sum(c.lifts.values()) / (C.TONNE * g),
            **_strength_of(st),
            "residual_shear_MN": st.closing_shear / 1e6,
            "residual_moment_MNm": st.closing_moment / 1e6,
            "static_stress": stress_of(scenario, st)}


def summary_of(plan: LiftPlan, hull, cases: dict, layout: str, paper: Strength | None) -> dict:
    """The JSON summary (tonnes, m, MN, MN m; nodes 1-based): the plan, the closed design
    cases (``design_cases``) and their peaks (``max_*``, each naming its ``case``), the
    residuals at the bow (largest of the cases) and the paper's still-water case when the
    plan is laid out by the paper's rule (``paper_still_water``, not closed)."""
    t = C.TONNE * plan.gravity
    ext, internal = plan.external, plan.internal
    span = [min(b.span[0] for b in internal), max(b.span[1] for b in internal)] if internal else None

    def largest(key, sign):
        name = max(cases, key=lambda n: sign(cases[n][key]["value"]))
        return {**cases[name][key], "case": name}

    out = {
        "dry_weight_t": plan.dry_weight / t,
        "wet_weight_t": plan.wet_weight / t,
        "breakout_factor": plan.breakout_factor,
        "required_lift_t": plan.required_lift / t,
        "catalogue_bag_lift_t": plan.catalogue_lift / t,
        "bag_count": plan.bag_count,
        "bag_lift_t": plan.bag_lift / t,
        "total_lift_t": plan.total_lift / t,
        "shortfall_t": plan.shortfall / t,
        "layout": layout,
        "external_bag_nodes": [hull.nearest_node(b.x) + 1 for b in ext],
        "internal_bag_span_m": span,
        "bags": [
            {
                "name": b.name,
                "kind": b.kind,
                "x_m": b.x,
                "node": None if b.node is None else b.node + 1,
                "span_m": None if b.span is None else list(b.span),
                "lift_t": b.lift / t,
                "capacity_m3": b.capacity,
            }
            for b in plan.bags
        ],
        "design_cases": cases,
        "max_shear_MN": largest("max_shear_MN", abs),
        "max_moment_MNm": largest("max_moment_MNm", abs),
        "max_sagging_MNm": largest("max_sagging_MNm", lambda v: v),
        "max_hogging_MNm": largest("max_hogging_MNm", lambda v: -v),
        "closing_shear_MN": max((c["residual_shear_MN"] for c in cases.values()), key=abs),
        "closing_moment_MNm": max((c["residual_moment_MNm"] for c in cases.values()), key=abs),
        "samples": int(max(c["samples"] for c in cases.values())) if cases else 0,
        "lift_centroid_m": plan.lift_centroid,
        "lift_points": [{"x_m": x, "bags": names} for x, names in plan.lift_points()],
        "warnings": list(plan.warnings),
    }
    if paper is not None:
        out["paper_still_water"] = {**_strength_of(paper),
                                    "closing_shear_MN": paper.closing_shear / 1e6,
                                    "closing_moment_MNm": paper.closing_moment / 1e6}
    return out


#: the rows of the design-case table: (label, unit, getter of a case summary)
_ROWS = (
    ("lift scale factor", "-", lambda c: c["scale_factor"]),
    ("heave acceleration (inertia relief)", "m/s2", lambda c: c["heave_acceleration_m_s2"]),
    ("pitch acceleration (inertia relief)", "rad/s2", lambda c: c["pitch_acceleration_rad_s2"]),
    ("load (down) / lift (up)", "t", lambda c: f"{c['load_t']:.1f} / {c['lift_t']:.1f}"),
    ("V at the largest |V| (signed)", "MN", lambda c: c["max_shear_MN"]["value"]),
    ("  at x", "m", lambda c: c["max_shear_MN"]["x_m"]),
    ("M at the largest |M| (signed)", "MN m", lambda c: c["max_moment_MNm"]["value"]),
    ("  at x", "m", lambda c: c["max_moment_MNm"]["x_m"]),
    ("  nearest node", "-", lambda c: c["max_moment_MNm"]["node"]),
    ("max sagging M", "MN m", lambda c: c["max_sagging_MNm"]["value"]),
    ("max hogging M", "MN m", lambda c: c["max_hogging_MNm"]["value"]),
    ("residual V at the bow", "MN", lambda c: c["residual_shear_MN"]),
    ("residual M at the bow", "MN m", lambda c: c["residual_moment_MNm"]),
    ("max bending stress |M|/Z", "MPa", lambda c: c["static_stress"]["max_MPa"]),
    ("utilisation", "-", lambda c: c["static_stress"]["max_utilisation"]),
)


#: the most bags listed one per row on the report's page; more are grouped by lift point
MAX_BAG_ROWS = 12


def bag_table(summary: dict) -> Table:
    """Every bag, one row each (``tables/loads_bags.csv``; on the page up to
    :data:`MAX_BAG_ROWS` bags)."""
    return Table(
        "Lift bags (full rated lift)",
        ["bag", "kind", "x [m]", "node", "span from [m]", "span to [m]", "lift [t]", "capacity [m3]"],
        [
            [
                b["name"], b["kind"], b["x_m"], b["node"],
                b["span_m"][0] if b["span_m"] else None,
                b["span_m"][1] if b["span_m"] else None,
                b["lift_t"], b["capacity_m3"],
            ]
            for b in summary["bags"]
        ],
        csv="loads_bags.csv",
    )


def lift_point_table(summary: dict) -> Table:
    """The bags grouped by lift point (kind and position or span): one row per point with its
    count, per-bag and total lift."""
    groups: dict[tuple, list[dict]] = {}
    for b in summary["bags"]:
        key = (b["kind"], b["x_m"], tuple(b["span_m"]) if b["span_m"] else None)
        groups.setdefault(key, []).append(b)
    rows = []
    for (kind, x, span), bs in groups.items():
        lifts = sorted({b["lift_t"] for b in bs})
        names = bs[0]["name"] if len(bs) == 1 else f"{bs[0]['name']}..{bs[-1]['name']}"
        rows.append([names, kind, len(bs), x, span[0] if span else None,
                     span[1] if span else None,
                     lifts[0] if len(lifts) == 1 else f"{lifts[0]}-{lifts[-1]}",
                     round(sum(b["lift_t"] for b in bs), 1), bs[0]["capacity_m3"]])
    return Table(
        "Lift points (full rated lift)",
        ["bags", "kind", "count", "x [m]", "span from [m]", "span to [m]", "lift per bag [t]",
         "lift [t]", "capacity per bag [m3]"],
        rows, csv="loads_bags.csv")


def _tables(summary: dict) -> list[Table]:
    bags = bag_table(summary) if len(summary["bags"]) <= MAX_BAG_ROWS else lift_point_table(summary)
    bags = Table(bags.title, bags.columns, bags.rows, csv=bags.csv, note=(
        f"Wet weight W' = {summary['wet_weight_t']:.0f} t; required lift "
        f"{summary['breakout_factor']:g} W' = {summary['required_lift_t']:.0f} t; "
        f"{summary['bag_count']} bags carry {summary['total_lift_t']:.0f} t ({summary['layout']})."
        + ("" if len(summary["bags"]) <= MAX_BAG_ROWS else " Every bag is a row of the CSV.")))
    cases = summary["design_cases"]
    peak = summary["max_moment_MNm"]
    st = Table(
        "Longitudinal strength (design cases, each closed)",
        ["quantity", "unit"] + [n.replace("_", "-") for n in cases],
        [[label, unit] + [get(c) for c in cases.values()] for label, unit, get in _ROWS],
        note=(
            "Holding: W' against the holding lifts; breakout: W' + H0 in the suction's shape "
            "against the holding lifts plus the shaped pull; full-lift: every bag at full "
            "capacity against W' + H0. Each closed physically: the external bags' lifts scaled "
            "to carry the load (the factor), the remaining moment carried by rigid-body "
            "inertia relief of the mass that moves in water (structure, added mass, entrained "
            "water); no trim load. Statics of the free beam integrated from the aft end, "
            f"M sagging positive; the residuals at the bow measure the closure. Peak |M| "
            f"{abs(peak['value']):.4g} MN m in the {peak['case'].replace('_', '-')} case at "
            f"x = {peak['x_m']:.2f} m."
        ),
    )
    tables = [bags, st]
    paper = summary.get("paper_still_water")
    if paper is not None:
        rows = [[label, paper[key]["value"], unit, paper[key]["x_m"], paper[key]["node"]]
                for label, key, unit in (("V at the largest |V| (signed)", "max_shear_MN", "MN"),
                                         ("M at the largest |M| (signed)", "max_moment_MNm",
                                          "MN m"),
                                         ("max sagging M", "max_sagging_MNm", "MN m"),
                                         ("max hogging M", "max_hogging_MNm", "MN m"))]
        rows.append(["closing V at the bow", paper["closing_shear_MN"], "MN", None, None])
        rows.append(["closing M at the bow", paper["closing_moment_MNm"], "MN m", None, None])
        tables.append(Table(
            "Appendix: the paper's still-water case (bags at full lift, not closed)",
            ["quantity", "value", "unit", "x [m]", "node"], rows,
            note=(f"As the paper computes it: every bag at full lift against "
                  f"{summary['breakout_factor']:g} W' distributed like the mass, integrated from "
                  "the aft end and not closed; the closing values at the bow are the imbalance of "
                  "that load case (bag lift rounded up to the tonne). For comparison only: the "
                  "design cases above are the ones to sign.")))
    return tables


def _check_table(checks) -> Table:
    return Table("Checks before the run", ["check", "result", "finding"],
                 [[c.name, "ok" if c.ok else "WARNING", c.message] for c in checks],
                 note="Each warning says the numbers and the fix; a plan that cannot work at all "
                      "is refused before the run.")


def _layout_text(scenario, plan) -> str:
    lift = scenario.lift
    if lift.bags is not None:
        return "explicit layout (lift.bags)"
    if not plan.external:
        return "internal bags only"
    if plan.layout == "mode_nodes":
        return f"external bags at the nodes of flexible mode {lift.layout_flexible_mode}"
    return (f"external bags balanced on the centre of gravity at {len(plan.lift_points())} lift "
            "points")


def run_stage(scenario, out: Path | None = None, per_element: int = 50) -> StageOutput:
    """Lift plan and strength of ``scenario``; figures and CSV tables under ``out`` when given.

    per_element : sample intervals per element for V and M (plus the load discontinuities)
    """
    hull = hull_from_scenario(scenario)
    plan = plan_lift(scenario, hull)
    plant = coupled_plant(scenario, hull, plan)
    refuse_unworkable(scenario, plant)
    cases = design(scenario, hull, plan, plant, per_element)
    g = plan.gravity
    case_sums = {c.name: {**case_summary(scenario, c, g), "samples": int(c.strength.x.size)}
                 for c in cases}
    paper = None
    if plan.layout == "mode_nodes" and scenario.pipe is None:
        paper = paper_case(plan, hull, per_element)[1]
    summary = summary_of(plan, hull, case_sums, _layout_text(scenario, plan), paper)
    checks = plan_checks(scenario, plant)
    summary["checks"] = {c.name: {"ok": c.ok, "message": c.message} for c in checks}
    worst = max(case_sums, key=lambda n: case_sums[n]["static_stress"]["max_utilisation"])
    summary["static_stress"] = {**case_sums[worst]["static_stress"], "case": worst}
    summary["defaulted"] = dict(scenario.defaulted)  # derived or assumed, not given
    warnings = (scenario.notes() + list(plan.warnings)
                + [f"{c.name}: {c.message}" for c in checks if not c.ok])
    tables = _tables(summary)
    tables.insert(2, _check_table(checks))
    figures: list[Figure] = []
    if out is not None:
        from flexlift.output.plots._style import draw
        from flexlift.output.plots.loads import load_diagram, shear_moment_figure

        out = Path(out)
        fdir, tdir = out / "figures", out / "tables"
        figures.append(
            Figure(
                draw(fdir / "loads_diagram.png", load_diagram, hull, plan,
                     lift_load_case(plan, hull)),
                "Lift plan: external bags at their lift points, internal bags over their spans, "
                "weight plus breakout as a distributed downward load.",
            )
        )
        figures.append(
            Figure(
                draw(fdir / "loads_shear_moment.png", shear_moment_figure,
                     [(c.name.replace("_", "-"), c.strength) for c in cases], hull, plan),
                "Shear force and bending moment along the hull in the three design cases, each "
                "closed (lifts scaled to the load, inertia relief for the rest of the moment); "
                "the peak marked, sagging positive.",
            )
        )
        write_text(tdir / "loads_bags.csv", bag_table(summary).to_csv())
        write_text(tdir / "loads_strength.csv", tables[1].to_csv())
        write_text(tdir / "loads_checks.csv", tables[2].to_csv())
        if paper is not None:
            write_text(tdir / "loads_paper_still_water.csv", tables[3].to_csv())
    criteria = {"static_stress_within_allowable": summary["static_stress"]["max_utilisation"] <= 1.0}
    return StageOutput(name=NAME, summary=summary, figures=figures, tables=tables,
                       warnings=warnings, criteria=criteria)
