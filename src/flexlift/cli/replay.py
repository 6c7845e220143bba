"""``flexlift replay LOG SCENARIO``: the estimator and the fault detector over a recorded
sensor log, faster than real time (docs/guide/replay.md). Writes, into ``--out`` (default
``flexlift-out/replay-<scenario>``), ``summary.json`` (the alarms, the forecasts of
breakout and arrival with their 5-95 % bands, the filter's and the log's counts), the
estimated histories ``estimates.nc``, ``replay.png`` and ``report.html``.

Exit codes: 0 no alarm, 1 an alarm raised, 2 bad input.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from flexlift.cli._common import (
    add_json_arg,
    add_scenario_arg,
    emit_json,
    help_text,
    positive_int,
    scenario_from,
)


def add_parser(sub) -> None:
    p = sub.add_parser("replay", help="the lift's state, forecasts and faults from a recorded "
                       "sensor log", description=help_text(__doc__),
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("log", type=Path, help="the sensor log (JSON lines or CSV, "
                   "docs/reference/sensor-log.md)")
    add_scenario_arg(p)
    p.add_argument("--out", type=Path, default=None, help="the output folder")
    p.add_argument("--members", type=positive_int("--members"), default=16,
                   help="ensemble members (default 16)")
    p.add_argument("--window", type=float, default=2.0,
                   help="assimilation window [s] (default 2, at least a recorded row)")
    p.add_argument("--forecast-every", type=float, default=120.0,
                   help="a forecast every this many seconds of lift time (default 120; 0 none)")
    p.add_argument("--seed", type=int, default=0, help="the ensemble's seed (default 0)")
    p.add_argument("--false-alarms", type=float, default=1e-3,
                   help="the detector's false alarms per lift-hour (default 0.001)")
    add_json_arg(p)
    p.add_argument("--quiet", action="store_true", help="no progress")
    p.set_defaults(func=_main)


def _main(args: argparse.Namespace) -> int:
    from flexlift.estimate.replay import Settings, replay
    from flexlift.output import output_folder
    from flexlift.output.folders import check_target
    from flexlift.output.replay import write_replay

    scenario = scenario_from(args)
    settings = Settings(members=args.members, window_s=args.window,
                        forecast_every_s=args.forecast_every, seed=args.seed,
                        false_alarms_per_hour=args.false_alarms)
    settings.check()
    out = args.out if args.out is not None else Path("flexlift-out") / f"replay-{scenario.name}"
    shown = str(out)
    check_target(Path(os.path.abspath(shown)), shown)  # before minutes of work, not after

    shown = [-1]

    def progress(fraction):  # a line per 10 % of the scenario's run length
        tenth = int(10 * fraction)
        if not (args.quiet or args.json) and tenth > shown[0]:
            shown[0] = tenth
            sys.stderr.write(f"flexlift replay: {10 * tenth} % of the run length\n")

    result = replay(args.log, scenario, settings, progress)
    with output_folder(out, "replay") as tmp:
        write_replay(tmp, result)
    s = result["summary"]
    if args.json:
        emit_json(s)
    else:
        _print(s, out)
    return 1 if s["alarms"] else 0


def _print(s: dict, out: Path) -> None:
    lines = [f"alarm at {a['time_s']:.0f} s: {a['message']} -> {a['advice']}"
             for a in s["alarms"]] or ["no fault detected"]
    if s["forecasts"]:
        f = s["forecasts"][-1]
        b, a = f["breakout_time_s"], f["arrival_time_s"]
        lines.append(f"forecast at {f['time_s']:.0f} s: breakout "
                     + (f"{b['p50']:.0f} s ({b['p5']:.0f}-{b['p95']:.0f})" if b else "-")
                     + ", arrival "
                     + (f"{a['p50']:.0f} s ({a['p5']:.0f}-{a['p95']:.0f})" if a else "-")
                     + f", P(unsafe) {f['p_unsafe']:.2f}")
    c = s["filter"]
    lines.append(f"{s['lift_time_s']:.0f} s of lift in {s['wall_time_s']:.1f} s "
                 f"({s['speed_x_real_time']:.0f}x); {c['assimilated']} readings assimilated, "
                 f"{c['gated']} gated, {c['late']} late; log: {s['log_report']['bad_lines']} "
                 f"bad lines; written to {out}")
    sys.stdout.write("".join(f"flexlift replay: {line}\n" for line in lines))
