"""``flexlift loads``: the lift plan (how much lift, how many bags, where) and the hull's
shear force and bending moment under it, with the bags at full rated lift.

JSON values are in tonnes, metres, MN and MN m; nodes are numbered 1.. from the aft end.
"""

from __future__ import annotations

import sys

from flexlift.cli._common import (
    add_json_arg,
    add_out_arg,
    add_scenario_arg,
    emit_json,
    scenario_from,
    writing,
)
from flexlift.stages.loads import NAME, run_stage


def add_parser(sub) -> None:
    p = sub.add_parser(
        NAME,
        help="lift plan and longitudinal strength: bag count, layout, shear force, bending moment",
        description=__doc__,
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
    for label, key, unit in (("max |V|", "max_shear_MN", "MN"), ("max |M|", "max_moment_MNm", "MN m")):
        e = s[key]
        w(f"  {label} = {abs(e['value']):.3f} {unit} at x = {e['x_m']:.2f} m (node {e['node']})\n")
    w(f"  closing at the bow: V = {s['closing_shear_MN']:.4f} MN, "
      f"M = {s['closing_moment_MNm']:.4f} MN m\n")
    for msg in res.warnings:
        w(f"  WARNING: {msg}\n")
    if args.out is not None:
        w(f"  figures and tables written under {args.out}\n")
    return 0


