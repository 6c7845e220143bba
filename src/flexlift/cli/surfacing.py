"""``flexlift surfacing``: the lift force of the final lift out of the water, with the water
trapped in the hull and its drainage (docs/theory/trapped-water.md): the scenario's
``surfacing:`` section, its hull's steel and depth.

Prints the weight in water the history starts at, the peak as the keel leaves the water and
when, the level once the water has drained (the weight in air) and when. ``--out`` writes
the history (tables/surfacing.csv, in s, m and MN) and surfacing.json.
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
from flexlift.errors import InputError
from flexlift.loads.trapped import scenario_history


def _step(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        v = math.nan
    if not (math.isfinite(v) and 0.01 <= v <= 60.0):
        raise argparse.ArgumentTypeError(f"--step needs seconds in [0.01, 60], got {text!r}")
    return v


def add_parser(sub) -> None:
    p = sub.add_parser("surfacing", help="the lift force of the final lift out of the water, "
                       "with the hull's trapped water", description=help_text(__doc__))
    add_scenario_arg(p)
    p.add_argument("--step", type=_step, default=1.0, metavar="SECONDS",
                   help="the history's sampling interval (default 1 s)")
    add_out_arg(p, "the history tables/surfacing.csv and summary surfacing.json")
    add_json_arg(p)
    p.set_defaults(func=_main)


def _main(args) -> int:
    scenario = scenario_from(args)
    if scenario.surfacing is None:
        raise InputError("surfacing", None, f"scenario {scenario.name} has no surfacing: "
                         "section (docs/theory/trapped-water.md); add one to compute its lift")
    h = scenario_history(scenario, step_s=args.step)
    s = h.summary()
    with writing(args.out, "surfacing") as out:
        if out is not None:
            from flexlift.plumbing.atomic import write_json, write_text

            rows = np.column_stack([h.time, h.keel_height, h.level_in, h.waterline, h.force / 1e6])
            write_text(out / "tables" / "surfacing.csv",
                       "time_s,keel_height_m,level_in_m,waterline_m,force_MN\n"
                       + "\n".join(",".join(f"{v:.6g}" for v in r) for r in rows) + "\n")
            write_json(out / "surfacing.json", s)
    if args.json:
        emit_json(s)
        return 0
    w = sys.stdout.write
    w(f"{scenario.name}: the lift out of the water at {scenario.surfacing.lift_speed_m_s:g} m/s, "
      f"{scenario.surfacing.trapped_volume_m3:g} m3 of water trapped\n")
    w(f"  submerged {s['weight_in_water_MN']:.3f} MN (W'); peak {s['peak_MN']:.3f} MN "
      f"({s['peak_over_weight_in_water']:.2f} W') at {s['peak_time_s']:.0f} s, the keel "
      "leaving the water\n")
    drained = s["drained_time_s"]
    when = f"drained at {drained:.0f} s" if math.isfinite(drained) else "not drained"
    w(f"  {when}; at {s['duration_s']:.0f} s {s['final_MN']:.3f} MN "
      f"(weight in air {s['weight_in_air_MN']:.3f} MN)\n")
    return 0
