"""The lift-plan stage (SPEC §1, §3): bag count and layout, and the hull's static shear force
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
from flexlift.loads.liftplan import LiftPlan, plan_lift
from flexlift.loads.strength import Strength, balanced_case, lift_load_case, strength
from flexlift.output.stage import Figure, StageOutput, Table
from flexlift.plumbing.atomic import write_text
from flexlift.structure.hull import hull_from_scenario

log = logging.getLogger(__name__)
NAME = "loads"


def _extreme(e, scale: float) -> dict:
    return {"value": e.value / scale, "x_m": e.x, "node": e.node}


def still_water(scenario, hull, plan, per_element: int = 50):
    """(load case, strength) of the plan in still water: bags at full lift against the weight
    times the breakout factor; a pipeline's case closed first
    (:func:`~flexlift.loads.strength.balanced_case`: over its length any imbalance would dwarf
    its moments; the ship's stays the paper's, with its published closing values)."""
    case = lift_load_case(plan, hull)
    if scenario.pipe is not None:
        case = balanced_case(case, {b.name for b in plan.bags})
    return case, strength(case, hull, per_element)


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


def summary_of(plan: LiftPlan, hull, st: Strength, layout: str) -> dict:
    """The JSON summary (tonnes, m, MN, MN m; nodes 1-based)."""
    t = C.TONNE * plan.gravity
    ext, internal = plan.external, plan.internal
    span = [min(b.span[0] for b in internal), max(b.span[1] for b in internal)] if internal else None
    return {
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
        "max_shear_MN": _extreme(st.max_shear, 1e6),
        "max_moment_MNm": _extreme(st.max_moment, 1e6),
        "max_sagging_MNm": _extreme(st.max_sagging, 1e6),
        "max_hogging_MNm": _extreme(st.max_hogging, 1e6),
        "closing_shear_MN": st.closing_shear / 1e6,
        "closing_moment_MNm": st.closing_moment / 1e6,
        "samples": int(st.x.size),
        "lift_centroid_m": plan.lift_centroid,
        "lift_points": [{"x_m": x, "bags": names} for x, names in plan.lift_points()],
        "warnings": list(plan.warnings),
    }


def _tables(summary: dict) -> list[Table]:
    bags = Table(
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
        note=(
            f"Wet weight W' = {summary['wet_weight_t']:.0f} t; required lift "
            f"{summary['breakout_factor']:g} W' = {summary['required_lift_t']:.0f} t; "
            f"{summary['bag_count']} bags carry {summary['total_lift_t']:.0f} t ({summary['layout']})."
        ),
    )
    rows = []
    for label, key, unit in (
        ("max |V|", "max_shear_MN", "MN"),
        ("max |M|", "max_moment_MNm", "MN m"),
        ("max sagging M", "max_sagging_MNm", "MN m"),
        ("max hogging M", "max_hogging_MNm", "MN m"),
    ):
        e = summary[key]
        rows.append([label, e["value"], unit, e["x_m"], e["node"]])
    rows.append(["closing V at the bow", summary["closing_shear_MN"], "MN", None, None])
    rows.append(["closing M at the bow", summary["closing_moment_MNm"], "MN m", None, None])
    st = Table(
        "Longitudinal strength (still water, bags at full lift)",
        ["quantity", "value", "unit", "x [m]", "node"],
        rows,
        note=(
            "Statics of the free beam integrated from the aft end on "
            f"{summary['samples']} samples; M sagging positive. The closing values measure "
            "the imbalance of the load case (bag lift rounded up to the tonne); a pipeline's "
            "case is closed first (the bags' lifts scaled to the load, a linear trim load "
            "for the rest of the moment): over its length any imbalance would dwarf its moments."
        ),
    )
    return [bags, st]


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
    case, st = still_water(scenario, hull, plan, per_element)
    summary = summary_of(plan, hull, st, _layout_text(scenario, plan))
    plant = coupled_plant(scenario, hull, plan)
    refuse_unworkable(scenario, plant)
    checks = plan_checks(scenario, plant)
    summary["checks"] = {c.name: {"ok": c.ok, "message": c.message} for c in checks}
    summary["static_stress"] = stress_of(scenario, st)
    summary["defaulted"] = dict(scenario.defaulted)  # derived or assumed, not given
    warnings = (scenario.notes() + list(plan.warnings)
                + [f"{c.name}: {c.message}" for c in checks if not c.ok])
    tables = _tables(summary) + [_check_table(checks)]
    s_ = summary["static_stress"]
    tables[1].rows.append(["max bending stress |M|/Z", s_["max_MPa"], "MPa", s_["x_m"], None])
    tables[1].rows.append(["utilisation (allowable "
                           f"{s_['allowable_MPa']:g} MPa)", s_["max_utilisation"], "-", s_["x_m"], None])
    figures: list[Figure] = []
    if out is not None:
        from flexlift.output.plots._style import draw
        from flexlift.output.plots.loads import load_diagram, shear_moment_figure

        out = Path(out)
        fdir, tdir = out / "figures", out / "tables"
        figures.append(
            Figure(
                draw(fdir / "loads_diagram.png", load_diagram, hull, plan, case),
                "Lift plan: external bags at their nodes, internal bags over their spans, "
                "weight plus breakout as a distributed downward load.",
            )
        )
        figures.append(
            Figure(
                draw(fdir / "loads_shear_moment.png", shear_moment_figure, st, hull, plan),
                "Shear force and bending moment along the hull with the bags at full lift; "
                "maxima marked, sagging positive.",
            )
        )
        write_text(tdir / "loads_bags.csv", tables[0].to_csv())
        write_text(tdir / "loads_strength.csv", tables[1].to_csv())
        write_text(tdir / "loads_checks.csv", tables[2].to_csv())
    criteria = {"static_stress_within_allowable": summary["static_stress"]["max_utilisation"] <= 1.0}
    return StageOutput(name=NAME, summary=summary, figures=figures, tables=tables,
                       warnings=warnings, criteria=criteria)
