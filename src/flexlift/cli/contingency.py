"""``flexlift contingency [SCENARIO]``: every single failure of the plan at every phase (one
bag lost, a sling broken, a dump valve stuck closed, a fill valve stuck open, a supply lost,
a sensor stuck, drifting or dropped out), whether the lift survives it, why, and by how much.

The phases come from the fault-free run's events (pull, breakout, mid, near_target) and any
times named with ``--phases``. Without noise, one representative per lift point and type is
run (``--all``: every bag). The cases run on the sweep engine (``--workers``, ``--dask-local``,
``--scheduler``) into a resumable folder (default ``flexlift-out/contingency-<scenario>``):
run the same command again after an interruption and only the missing cases run. It ends with
``contingency.json``, ``report.html`` and one rerun scenario per case in ``rerun/``.

Exit codes: 0 single-failure tolerant; 1 not (the failures are results: see the report), no
verdict (no case ran, or the fault-free run or a case ended incomplete: "tolerant": null), or a
case raised a programming error; 2 bad input (no, or an unknown, phase or kind, a time beyond
the run, a kind the plan has no part for, too many cases); 130 interrupted (finished cases
kept).
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
from pathlib import Path

from flexlift.cli._common import (
    add_json_arg,
    add_scenario_arg,
    checked,
    emit_json,
    help_text,
    scenario_from,
)
from flexlift.output.folders import check_length
from flexlift.scenario.types import whole
from flexlift.sweep.executors import WORKERS_PER_CORE, max_workers


def _words(option: str, allowed: str):
    """argparse type: a comma-separated list of at least one word (an empty one is refused in
    one line naming ``option`` and what is ``allowed``)."""

    def parse(text: str) -> list[str]:
        words = [w for w in text.replace(",", " ").split() if w]
        if not words:
            raise argparse.ArgumentTypeError(f"got {text!r}; name at least one: {allowed}")
        return words

    return parse


def _kinds() -> str:
    from flexlift.sweep.contingency.cases import KINDS

    return ", ".join(KINDS)


def add_parser(sub) -> None:
    from flexlift.stages.simulate import MODES

    p = sub.add_parser("contingency", help="every single failure at every phase: does the lift "
                       "survive it?", description=help_text(__doc__),
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    add_scenario_arg(p)
    p.add_argument("--control", choices=MODES, default=None,
                   help="control mode (default: the scenario's control.mode)")
    p.add_argument("--phases", type=_words("--phases", "pull, breakout, mid, near_target or "
                                           "a time in seconds"), default=None, metavar="LIST",
                   help="phases, comma-separated: pull, breakout, mid, near_target and/or "
                        "times in seconds (default: the four phases)")
    p.add_argument("--kinds", type=_words("--kinds", _kinds()), default=None, metavar="LIST",
                   help="failure kinds, comma-separated (default: every kind the bags have "
                        "the part for)")
    p.add_argument("--all", action="store_true", dest="all_bags",
                   help="run every bag, not one representative per lift point and type")
    p.add_argument("--no-margin", action="store_true",
                   help="do not bisect the margin of the failing cases")
    p.add_argument("--workers", type=checked("--workers", whole(1, max_workers()),
                                             f" ({WORKERS_PER_CORE} per core)"), default=None,
                   help="local worker processes (default: every core; 1: in this process)")
    dask = p.add_mutually_exclusive_group()
    dask.add_argument("--scheduler", metavar="ADDRESS", default=None,
                      help="run on the Dask cluster of this scheduler, e.g. tcp://host:8786")
    dask.add_argument("--dask-local", metavar="N", type=checked(
        "--dask-local", whole(1, max_workers()), f" ({WORKERS_PER_CORE} per core)"),
        default=None, help="start a Dask LocalCluster of N workers and run on it")
    p.add_argument("--out", type=Path, default=None,
                   help="output folder (default: flexlift-out/contingency-<scenario name>)")
    p.add_argument("--yes", action="store_true", help="allow a study estimated beyond 10 min")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_json_arg(p)
    p.set_defaults(func=_main)


def _main(args: argparse.Namespace) -> int:
    from flexlift.cli import Terminated
    from flexlift.cli.sweep import _Bar
    from flexlift.sweep.contingency.phases import PHASES, parse_phases
    from flexlift.sweep.contingency.run import run_contingency
    from flexlift.sweep.executors import make_engine
    from flexlift.sweep.worker import CaseError, OutsideCases

    scenario = scenario_from(args)
    names, times = (parse_phases(args.phases, scenario.simulation.run_length_s)
                    if args.phases is not None else (PHASES, ()))
    out = args.out if args.out is not None else Path("flexlift-out") / f"contingency-{scenario.name}"
    check_length(Path(os.path.abspath(out)), str(out))  # before the fault-free run and its line
    engine = make_engine(args.workers, args.scheduler, args.dask_local)
    bar = _Bar(args.quiet or args.json, engine.name)

    def announce(n: int, text: str) -> None:
        if not args.json:
            sys.stderr.write(f"flexlift contingency: {text}\n")

    quiet_cases = OutsideCases()
    handlers = list(logging.getLogger("flexlift").handlers)
    for h in handlers:
        h.addFilter(quiet_cases)
    try:
        result = run_contingency(scenario, out, mode=args.control, phases=names, times=times,
                                 kinds=args.kinds, all_bags=args.all_bags, engine=engine,
                                 progress=bar, margins=not args.no_margin, yes=args.yes,
                                 announce=announce)
    except CaseError as exc:
        bar.close()
        sys.stderr.write(f"flexlift contingency: traceback of case {exc.case}:\n{exc.trace}")
        sys.stderr.write(f"flexlift contingency: {exc}; the finished cases are kept in {out}\n")
        return 1
    except (KeyboardInterrupt, Terminated) as exc:
        bar.close()
        sys.stderr.write(f"flexlift contingency: interrupted; the finished cases are kept in "
                         f"{out}: run the same command again to finish\n")
        return 143 if isinstance(exc, Terminated) else 130
    finally:
        bar.close()
        for h in handlers:
            h.removeFilter(quiet_cases)
    s = result.summary
    if args.json:
        emit_json(s)
    else:
        _print_summary(s, out)
    return 0 if result.tolerant else 1


def _print_summary(s: dict, out: Path) -> None:
    rows = {r["index"]: r for r in s["cases"]}
    c = s["counts"]
    lines = [f"{s['n_cases']} cases ({s['control']} control, {s['engine']}, "
             f"{s['elapsed_s']:.1f} s): {c['safe']} safe, {c['unsafe']} unsafe, "
             f"{c['not_achieved']} not achieved, {c['incomplete']} incomplete",
             "phases: " + ", ".join(f"{p['name']} {p['time_s']:g} s" if p["time_s"] is not None
                                    else f"{p['name']} not reached" for p in s["phases"]),
             f"verdict: {s['verdict']}"]
    for rank, i in enumerate(s["failures"][:10], start=1):
        r = rows[i]
        m = r.get("margin") or {}
        lines.append(f"  {rank}. {r['kind']} of {r['bag']} at {r['phase']} ({r['time_s']:g} s): "
                     f"{r['answer']['outcome'].replace('_', ' ')}; margin "
                     f"{m.get('text', '-')} {m.get('scales', '')}".rstrip())
    if len(s["failures"]) > 10:
        lines.append(f"  ... and {len(s['failures']) - 10} more (the report lists them all)")
    lines.append(f"report: {out / 'report.html'}")
    sys.stdout.write("\n".join(lines) + "\n")
