"""``flexlift loads``: the lift plan (how much lift, how many bags, where) and the hull's
shear force and bending moment under it in the three design cases (holding, breakout,
full lift), each closed, and the paper's still-water table beside them for its layout.

JSON values are in tonnes, metres, MN and MN m; nodes are numbered 1.. from the aft end.
"""

from __future__ import annotations

import sys

from flexlift.cli._common import (
    add_json_arg,
    add_out_arg,
    add_scenario_arg,
    emit_json,
    help_text,
    scenario_from,
    writing,
)
from flexlift.stages.loads import NAME, run_stage


def add_parser(sub) -> None:
    p = sub.add_parser(
        NAME,
        help="lift plan and longitudinal strength: bag count, layout, shear force, bending moment",
        description=help_text(__doc__),
    )
    add_scenario_arg(p)
    add_out_arg(p, "figures (figures/loads_*.png) and tables (tables/loads_*.csv)")
    add_json_arg(p)
    p.set_defaults(func=_main)


def _main(args) -> int:
    scenario = scenario_from(args)
    with writing(args.out, "loads") as out:
        res = run_stage(scenario, out)
    s = res.summary
    if args.json:
        emit_json(s)
        return 0
    w = sys.stdout.write
    w(f"{scenario.name}: wet weight {s['wet_weight_t']:.0f} t, required lift "
      f"{s['required_lift_t']:.0f} t ({s['breakout_factor']:g} W')\n")
    w(f"  {s['bag_count']} bags of {s['bag_lift_t']:.0f} t = {s['total_lift_t']:.0f} t "
      f"({s['layout']})\n")
    for b in s["bags"]:
        where = (f"x = {b['x_m']:.2f} m" + (f" (node {b['node']})" if b["node"] else "")
                 if b["span_m"] is None
                 else f"span {b['span_m'][0]:.2f}..{b['span_m'][1]:.2f} m")
        w(f"    {b['name']:<8} {b['kind']:<8} {b['lift_t']:6.0f} t  {where}\n")
    for name, c in s["design_cases"].items():
        m = c["max_moment_MNm"]
        w(f"  {name:<9} scale {c['scale_factor']:.4f}, pitch acc. "
          f"{c['pitch_acceleration_rad_s2']:+.2e} rad/s2: max |V| = "
          f"{abs(c['max_shear_MN']['value']):.3f} MN, max |M| = {abs(m['value']):.3f} MN m at "
          f"x = {m['x_m']:.2f} m (node {m['node']}), residual at the bow "
          f"{c['residual_shear_MN']:.1e} MN, {c['residual_moment_MNm']:.1e} MN m\n")
    p = s["max_moment_MNm"]
    w(f"  peak |M| = {abs(p['value']):.3f} MN m ({p['case']} case)\n")
    paper = s.get("paper_still_water")
    if paper is not None:
        w(f"  the paper's still-water case (not closed): max |V| = "
          f"{abs(paper['max_shear_MN']['value']):.3f} MN at node {paper['max_shear_MN']['node']}, "
          f"max |M| = {abs(paper['max_moment_MNm']['value']):.3f} MN m at node "
          f"{paper['max_moment_MNm']['node']}, closing V = {paper['closing_shear_MN']:.4f} MN, "
          f"M = {paper['closing_moment_MNm']:.4f} MN m\n")
    for msg in res.warnings:
        w(f"  WARNING: {msg}\n")
    if args.out is not None:
        w(f"  figures and tables written under {args.out}\n")
    return 0


