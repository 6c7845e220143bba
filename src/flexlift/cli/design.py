"""``flexlift design SCENARIO``: the plan to rig, searched for and proved by the checks a user
would run (the static checks, the nominal ascent, every single failure, the salvage study).

The search (optuna's NSGA-II, seeded) chooses the catalogue bag (or one per lift point,
--per-point-types), the lift points and the bags at each, the internal bags in the tanks,
and, when given several values, the control mode, the planned ascent speed, the breakout
pull, the dump valve and the compressor's supply, and a staged lift's staging (its own
control.sequence or every bag at once); each candidate goes up the ladder only as far as it
survives. The folder (default ``flexlift-out/design-<scenario>``) keeps every evaluation:
the same command again after an interruption resumes and gives the same plan.

Exit codes: 0 a plan found (``plan.yaml``); 1 no plan found in the space (the report says
what failed and what would change it); 2 bad input; 130 interrupted (evaluations kept).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from flexlift.cli._common import add_json_arg, add_scenario_arg, emit_json, help_text, scenario_from
from flexlift.errors import InputError


def _list(kind, option: str):
    """argparse type: comma-separated values of ``kind`` (at least one)."""

    def parse(text: str):
        words = [w for w in text.replace(",", " ").split() if w]
        if not words:
            raise argparse.ArgumentTypeError(f"got {text!r}; give at least one value")
        try:
            return [None if w == "auto" else kind(w) for w in words]
        except ValueError:
            raise argparse.ArgumentTypeError(f"got {text!r}; comma-separated "
                                             f"{kind.__name__} values") from None

    return parse


def _range(text: str) -> tuple[int, int]:
    a, _, b = text.partition("..")
    try:
        lo, hi = int(a), int(b or a)
    except ValueError:
        raise argparse.ArgumentTypeError(f"got {text!r}; a range LOW..HIGH or one number") from None
    return lo, hi


def add_parser(sub) -> None:
    p = sub.add_parser("design", help="search for the plan: the fewest bags that survive every "
                       "single failure and meet the failure-probability target",
                       description=help_text(__doc__),
                       formatter_class=argparse.RawDescriptionHelpFormatter)
    add_scenario_arg(p)
    p.add_argument("--bags", type=_list(str, "--bags"), default=None, metavar="LIST",
                   help="catalogue bags to choose from (default: every catalogue bag)")
    p.add_argument("--points", type=_range, default=None, metavar="LOW..HIGH",
                   help="number of lift points (default 1..12)")
    p.add_argument("--over", type=_range, default=None, metavar="LOW..HIGH",
                   help="bags above the fewest that lift (default 0..12)")
    p.add_argument("--count", type=int, default=None, help="fix the bags per lift point")
    p.add_argument("--span", type=_list(float, "--span"), default=None, metavar="FROM,TO",
                   help="the hull's allowed attachment span [m] (default: the whole hull)")
    p.add_argument("--modes", type=_list(str, "--modes"), default=None, metavar="LIST",
                   help="control modes to choose from (default: the scenario's)")
    p.add_argument("--speeds", type=_list(float, "--speeds"), default=None, metavar="LIST",
                   help="planned ascent speeds [m/s] to choose from (default: the scenario's)")
    p.add_argument("--pulls", type=_list(float, "--pulls"), default=None, metavar="LIST",
                   help="breakout pulls [t] to choose from; auto: the default share")
    p.add_argument("--dump-valve", type=_list(float, "--dump-valve"), default=None,
                   metavar="LIST", help="dump-valve capacity factors on the catalogue's")
    p.add_argument("--internal", type=_range, default=None, metavar="LOW..HIGH",
                   help="internal bags in the ballast tanks, of the bags in all (default "
                   "0..as many as the tanks hold; 0: none)")
    p.add_argument("--per-point-types", action="store_true",
                   help="let each lift point pick its own catalogue bag (of one type)")
    p.add_argument("--supply", type=_list(float, "--supply"), default=None, metavar="LIST",
                   help="compressor free-air deliveries [m3/min] to choose from; auto: the "
                   "scenario's gas supply (default)")
    p.add_argument("--sequence", type=_list(str, "--sequence"), default=None, metavar="LIST",
                   help="staging to choose from: own (the scenario's control.sequence), none "
                   "(every bag at once) (default: both for a staged lift, else own)")
    p.add_argument("--objectives", type=_list(str, "--objectives"), default=["bags"],
                   metavar="LIST", help="bags, gas and/or cost (several: a Pareto front)")
    p.add_argument("--target", type=float, default=0.01,
                   help="P(unsafe)'s 95 %% upper bound to meet (default 0.01)")
    p.add_argument("--budget", type=int, default=60, help="candidates to try (default 60)")
    p.add_argument("--population", type=int, default=12, help="candidates per generation")
    p.add_argument("--seed", type=int, default=0, help="the search's seed (default 0)")
    p.add_argument("--up-to", default=None,
                   help="the last rung: statics, nominal, contingency or salvage (default: "
                        "salvage for a hull; contingency for a pipeline, which the salvage "
                        "study is not for)")
    p.add_argument("--samples", type=int, default=600,
                   help="the salvage study's most cases (default 600; it stops once decided)")
    p.add_argument("--no-compare", action="store_true",
                   help="do not run your own plan through the same checks")
    p.add_argument("--workers", type=int, default=None, help="local worker processes")
    dask = p.add_mutually_exclusive_group()
    dask.add_argument("--scheduler", metavar="ADDRESS", default=None,
                      help="run the cases on the Dask cluster of this scheduler")
    dask.add_argument("--dask-local", metavar="N", type=int, default=None,
                      help="start a Dask LocalCluster of N workers")
    p.add_argument("--out", type=Path, default=None,
                   help="output folder (default: flexlift-out/design-<scenario name>)")
    p.add_argument("--quiet", action="store_true", help="no progress lines")
    add_json_arg(p)
    p.set_defaults(func=_main)


def _up_to(given: str | None, scenario, quiet: bool) -> str:
    """The last rung: as given; by default the salvage study for a hull and the single
    failures for a pipeline (said); the salvage study asked of a pipeline is refused."""
    pipe = scenario.pipe is not None
    if given == "salvage" and pipe:
        raise InputError("--up-to", given, "the salvage study is for a hull: a pipeline's "
                         "search goes up to contingency (its single failures)")
    if given is not None:
        return given
    if pipe and not quiet:
        sys.stderr.write("flexlift design: a pipeline: the search goes up to its single "
                         "failures; P(unsafe) is not assessed (the salvage study is for a "
                         "hull)\n")
    return "contingency" if pipe else "salvage"


def _main(args: argparse.Namespace) -> int:
    from flexlift.design.run import run_design
    from flexlift.design.search import Options, check_options
    from flexlift.design.space import make_space
    from flexlift.sweep.executors import make_engine

    scenario = scenario_from(args)
    if args.workers is not None and args.workers < 1:
        raise InputError("--workers", args.workers, "at least 1 local process")
    if args.span is not None and len(args.span) != 2:
        raise InputError("--span", ",".join(map(str, args.span)), "two numbers FROM,TO [m]")
    space = make_space(scenario, models=args.bags, points=args.points, over=args.over,
                       count=args.count, modes=args.modes, speeds=args.speeds,
                       pulls=args.pulls, dump_factors=args.dump_valve, span=args.span,
                       internal=args.internal, per_point=args.per_point_types,
                       supplies=args.supply, sequences=args.sequence)
    options = Options(budget=args.budget, population=args.population, seed=args.seed,
                      target=args.target, objectives=tuple(args.objectives),
                      up_to=_up_to(args.up_to, scenario, args.quiet or args.json),
                      samples=args.samples)
    check_options(options, space)
    out = args.out if args.out is not None else Path("flexlift-out") / f"design-{scenario.name}"
    engine = None
    if options.up_to in ("contingency", "salvage"):
        engine = make_engine(args.workers, args.scheduler, args.dask_local)

    def progress(done, total, passed):
        if not (args.quiet or args.json):
            sys.stderr.write(f"flexlift design: {done}/{total} candidates, {passed} passed\n")

    summary = run_design(scenario, space, options, out, engine, progress,
                         compare=not args.no_compare)
    if args.json:
        emit_json(summary)
    else:
        _print(summary, out)
    return 0 if summary["found"] else 1


def _print(s: dict, out: Path) -> None:
    b, lb = s["best"], s["lower_bound"]
    ev = s["evaluations"]
    lines = []
    if b is not None:
        p = b["p_unsafe"] or {}
        inner = f", {b['internal']} internal" if b.get("internal") else ""
        c = b["contingency"]
        single = ("not run" if not c else ", ".join(
            f"{v} {k.replace('_', ' ')}" for k, v in c.items() if v)
            + f" of {b.get('contingency_cases') or sum(c.values())}")
        lines.append(f"proposal: {b['bags']} x {' + '.join(b['types'])}{inner} at "
                     f"{len(b['points'])} lift "
                     f"points ({b['mode']}, {b['ascent_speed_m_s']:g} m/s); single failures "
                     f"{single}; P(unsafe) "
                     + (f"{100 * p['p']:.2f} % (95 %: {100 * p['low']:.2f}-"
                        f"{100 * p['high']:.2f} %, n = {p['n']})"
                        if p.get("p") is not None else "not run"))
        lines.append(f"plan: {out / 'plan.yaml'}")
    else:
        lines.append("no plan found: " + "; ".join(s["no_plan"]["what_would_change_it"]))
    lines.append(f"lower bound ({lb['model']}): N = {lb['n']}, N-1 = {lb['n_minus_1']} bags")
    lines.append(f"{ev['candidates']} candidates, reached: " + ", ".join(
        f"{k} {v}" for k, v in ev["reached"].items()) + f"; {s['elapsed_s']:.0f} s")
    lines.append(f"report: {out / 'report.html'}")
    sys.stdout.write("\n".join(lines) + "\n")
