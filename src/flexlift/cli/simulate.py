"""``flexlift simulate``: the controlled ascent of a scenario (docs/theory/loop.md).

Exit codes: 0 when the run completed (whether or not the criteria passed: they are in the
JSON and the summary, and ``flexlift run`` shows pass/fail), 1 when the numerics failed (the
results up to that moment are still written), 2 for bad input.
"""

from __future__ import annotations

import argparse
import sys

from flexlift.cli._common import (
    add_json_arg,
    add_out_arg,
    add_scenario_arg,
    emit_json,
    help_text,
    key_option,
    scenario_from,
    with_options,
    writing,
)
from flexlift.output.controllers import copy_controller_files
from flexlift.stages.simulate import MODES, run_stage


def add_parser(sub) -> None:
    p = sub.add_parser("simulate", help="simulate the controlled ascent", description=help_text(__doc__))
    add_scenario_arg(p)
    p.add_argument("--control", choices=MODES, default=None,
                   help="control mode (default: the scenario's control.mode)")
    p.add_argument("--duration", type=key_option("--duration", "simulation.duration_s"), default=None,
                   help="largest simulated time [s] (default: simulation.duration_s)")
    p.add_argument("--sensor-log", metavar="FILE", default=None,
                   help="also write the readings the scenario's sensors would have given (a new "
                        "file: JSON lines, CSV if it ends .csv; docs/reference/sensor-log.md)")
    add_out_arg(p, "results (netCDF, CSV) and figures")
    add_json_arg(p)
    p.set_defaults(func=_main)


def _main(args: argparse.Namespace) -> int:
    scenario = scenario_from(args)
    # --duration is simulation.duration_s: checked with the scenario's other keys (steps, rows)
    with_options(scenario, {"--duration": ("simulation.duration_s", args.duration)})
    with writing(args.out, "simulate") as folder:
        out = run_stage(scenario, folder, control=args.control, duration=args.duration,
                        sensor_log=args.sensor_log)
        if folder is not None:
            copy_controller_files(scenario, folder)  # the user's .fis files, with checksums
    s = out.summary
    if args.json:
        emit_json(s)
    else:
        crit = ", ".join(f"{k} {'pass' if v else 'FAIL'}" for k, v in s["criteria"].items())
        arr = [v for v in s["arrival_time_s"].values() if v is not None]
        sys.stdout.write(
            f"{s['control']} control, {s.get('breakout_law', 'timer')} breakout law: "
            + (f"separation at {s['separation_time_s']} s, " if s["separation_time_s"] is not None
               else "no separation, ")
            + (f"breakout complete at {s['breakout_time_s']} s, "
               if s["breakout_time_s"] is not None else "breakout not complete, ")
            + (f"last arrival at {max(arr)} s; " if arr else "no bag arrived; ")
            + f"max ascent velocity {s['max_ascent_velocity_ms']} m/s, max pitch {s['max_pitch_deg']} deg, "
            f"max descent velocity {s['max_descent_velocity_ms']} m/s, "
            f"max bending moment {s['max_bending_moment_MNm']} MN m, gas {s['gas_total_free_air_m3']} m3 "
            f"free air in all ({s['gas_initial_free_air_m3']} initial fill + {s['gas_used_free_air_m3']} "
            f"top-up)\ncriteria: {crit}\noutcome: {(s.get('outcome') or '-').replace('_', ' ')}\n")
        for k, why in s["reasons"].items():
            sys.stdout.write(f"  {k}: {why}\n")
    for w in out.warnings:
        sys.stderr.write(f"flexlift simulate: {w}\n")
    return 1 if out.warnings and s.get("error") else 0


