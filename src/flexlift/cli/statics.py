"""``flexlift statics``: the static equilibrium of the structure on the seabed (one-sided
contact per node) under given bag lifts, before any dynamics (as OrcaFlex's statics).

``--lift BAG=TONNES`` sets a bag's lift (a cluster's name sets each of its bags); the other
bags hold their share of the wet weight as in the plan. JSON in tonnes, metres, MN m, degrees.
"""

from __future__ import annotations

import argparse
import math
import sys

import numpy as np

from flexlift.cli._common import (
    add_json_arg,
    add_out_arg,
    add_scenario_arg,
    emit_json,
    help_text,
    scenario_from,
    writing,
)
from flexlift.loads.statics import scenario_statics, summary


def _lift(text: str) -> tuple[str, float]:
    name, sep, value = text.partition("=")
    try:
        t = float(value)
    except ValueError:
        t = math.nan
    if not sep or not name or not math.isfinite(t) or t < 0:
        raise argparse.ArgumentTypeError(f"--lift needs BAG=TONNES with a lift of 0 t or more, "
                                         f"got {text!r}")
    return name, t


def add_parser(sub) -> None:
    p = sub.add_parser("statics", help="static equilibrium on the seabed under given bag lifts",
                       description=help_text(__doc__))
    add_scenario_arg(p)
    p.add_argument("--lift", type=_lift, action="append", default=[], metavar="BAG=TONNES",
                   help="a bag's lift in tonnes (repeatable); default the plan's holding lift")
    add_out_arg(p, "the table tables/statics.csv and summary statics.json")
    add_json_arg(p)
    p.set_defaults(func=_main)


def _main(args) -> int:
    scenario = scenario_from(args)
    st = scenario_statics(scenario, dict(args.lift))
    g = scenario.environment.gravity_m_s2
    s = summary(st, g)
    with writing(args.out, "statics") as out:
        if out is not None:
            from flexlift.plumbing.atomic import write_json, write_text

            rows = np.column_stack([st.x, st.w, np.degrees(st.slope), st.contact, st.reaction,
                                    st.moment / 1e6, st.utilisation])
            write_text(out / "tables" / "statics.csv",
                       "x_m,height_m,slope_deg,contact,seabed_force_N,moment_MNm,utilisation\n"
                       + "\n".join(",".join(f"{v:.6g}" for v in r) for r in rows) + "\n")
            write_json(out / "statics.json", s)
    if args.json:
        emit_json(s)
        return 0
    w = sys.stdout.write
    m = s["max_moment_MNm"]
    td = ", ".join(f"{x:.1f}" for x in s["touchdown_x_m"]) or "none (off the seabed)"
    w(f"{scenario.name}: statics on the seabed, {len(s['lift_t'])} bags "
      f"({sum(s['lift_t'].values()):.1f} t), net lift {s['net_lift_t']:+.1f} t\n")
    w(f"  touchdown at x = {td} m; highest point {s['max_height_m']:.3f} m\n")
    w(f"  max |M| = {abs(m['value']):.3f} MN m at x = {m['x_m']:.1f} m; utilisation "
      f"{s['max_utilisation']:.3f} at x = {s['max_utilisation_x_m']:.1f} m; largest slope "
      f"{s['max_slope_deg']:.2f} deg\n")
    for msg in s["warnings"]:
        w(f"  WARNING: {msg}\n")
    return 0
