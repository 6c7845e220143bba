"""``flexlift sweep SPEC.yaml``: a grid or a Monte Carlo of ascents of one base scenario, on
every local core (default), in this process (``--workers 1``) or on a Dask cluster.

The output folder (default ``flexlift-out/sweep-<SPEC name>``) keeps every case as it
finishes: run the same command again after an interruption and only the missing cases run.
It ends with ``results.nc`` (a ``case`` dimension, the varied keys as coordinates),
``summary.json`` and ``report.html``.

``flexlift sweep --study salvage SCENARIO`` runs a ready uncertainty study of the scenario
(a built-in name or a file): the salvors' uncertainties, each law with its source
(docs/guide/sweeps.md); ``--method sobol`` gives which of them drives each criterion's margin
(Sobol' indices), ``--method lhs`` or ``random`` the probabilities, ``--until-halfwidth H``
stops once every probability is known to +-H (95 %). A SPEC with ``study: salvage`` adds
or narrows the ranges.

Exit codes: 0 the sweep ran (criteria failing are results, not errors); 1 every case failed
(the most common failure is printed), a case raised a programming error (its traceback is
printed), or the Dask scheduler was lost during the sweep (in both, the finished cases are
kept and the command to finish the sweep is printed); 2 bad input (an unknown key, a bad
distribution, an
unreachable scheduler, ...); 130 interrupted (the finished cases are kept).
"""

from __future__ import annotations

import argparse
import logging
import shlex
import sys
from pathlib import Path

from flexlift.cli._common import add_json_arg, checked, emit_json, help_text
from flexlift.errors import clean
from flexlift.scenario.types import whole
from flexlift.sweep.executors import WORKERS_PER_CORE, max_workers


def add_parser(sub) -> None:
    p = sub.add_parser("sweep", help="a grid or Monte Carlo of ascents: probability of a safe lift",
                       description=help_text(__doc__), formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("spec", help="the SPEC file (YAML: base, control, set, grid or monte_carlo); "
                                "with --study, the scenario (a built-in name or a file)")
    p.add_argument("--study", metavar="NAME", default=None,
                   help="run the ready uncertainty study NAME of the scenario SPEC (salvage)")
    p.add_argument("--method", choices=("lhs", "random", "sobol"), default=None,
                   help="the Monte Carlo's sampling: lhs or random (probabilities), sobol "
                        "(Sobol' indices: which uncertainty matters)")
    p.add_argument("--samples", type=checked("--samples", whole(1, 1_000_000)), default=None,
                   help="cases (sobol: base samples, N x (keys + 2) cases; with "
                        "--until-halfwidth: the most cases)")
    p.add_argument("--seed", type=checked("--seed", whole(0, 2**63 - 1)), default=None,
                   help="the Monte Carlo's seed")
    p.add_argument("--until-halfwidth", metavar="H", type=float, default=None,
                   help="stop once every probability's 95 %% half-width is at most H (0 < H < "
                        "0.5), checked at the end of each block of cases")
    p.add_argument("--workers", type=checked("--workers", whole(1, max_workers()),
                                                    f" ({WORKERS_PER_CORE} per core)"), default=None,
                   help=f"local worker processes, at most {WORKERS_PER_CORE} per core (default: "
                        "every core; 1: in this process)")
    dask = p.add_mutually_exclusive_group()
    dask.add_argument("--scheduler", metavar="ADDRESS", default=None,
                      help="run on the Dask cluster of this scheduler, e.g. tcp://host:8786")
    dask.add_argument("--dask-local", metavar="N", type=checked("--dask-local", whole(1, max_workers()),
                                                              f" ({WORKERS_PER_CORE} per core)"), default=None,
                      help=f"start a Dask LocalCluster of N workers (at most {WORKERS_PER_CORE} per "
                      "core) and run on it")
    p.add_argument("--out", type=Path, default=None,
                   help="output folder (default: flexlift-out/sweep-<SPEC name>); rerun with the "
                        "same SPEC and --out to resume")
    p.add_argument("--yes", action="store_true",
                   help="allow a very large sweep (more than 100,000 cases, or estimated to take "
                        "more than 10 minutes)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_json_arg(p)
    p.set_defaults(func=_main)


class _Bar:
    """A tqdm bar on stderr: cases done, failures so far, the rate and the time left."""

    def __init__(self, quiet: bool, engine: str):
        self.quiet, self.engine, self.bar = quiet, engine, None

    def __call__(self, done: int, total: int, failed: int) -> None:
        if self.quiet:
            return
        if self.bar is None:
            from tqdm import tqdm

            class Bar(tqdm):  # no monitor thread: the sweep's end may fork (sweep/aside.py)
                monitor_interval = 0

            self.bar = Bar(total=total, initial=done, unit="case", file=sys.stderr,
                            desc=f"sweep ({self.engine})", dynamic_ncols=True, smoothing=0.05,
                            mininterval=0.5)
        self.bar.update(done - self.bar.n)
        self.bar.set_postfix_str(f"{failed} failed", refresh=False)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def _main(args: argparse.Namespace) -> int:
    from flexlift.cli import Terminated
    from flexlift.sweep import run_sweep
    from flexlift.sweep.executors import SchedulerLost, make_engine
    from flexlift.sweep.worker import CaseError, OutsideCases

    engine = None
    if args.scheduler is None and args.dask_local is None:  # its workers warm up meanwhile
        engine = make_engine(args.workers, None, None)
    try:
        spec = _spec(args)
    except BaseException:
        if engine is not None:
            engine.close(cancel=True)
        raise
    stem = Path(args.spec).stem if args.study is None else f"{args.study}-{Path(args.spec).stem}"
    out = args.out if args.out is not None else Path("flexlift-out") / f"sweep-{stem}"
    if engine is None:
        engine = make_engine(args.workers, args.scheduler, args.dask_local)
    try:
        _check_cost(spec, engine.workers, args)
    except BaseException:
        engine.close(cancel=True)
        raise
    bar = _Bar(args.quiet, engine.name)
    quiet_cases = OutsideCases()  # a case's warnings go to its record, not to the terminal
    handlers = list(logging.getLogger("flexlift").handlers)
    for h in handlers:
        h.addFilter(quiet_cases)
    try:
        result = run_sweep(spec, out, engine=engine, progress=bar)
    except CaseError as exc:  # a bug, not a result: its traceback, and how to go on
        bar.close()
        sys.stderr.write(f"flexlift sweep: traceback of case {exc.case}:\n{exc.trace}")
        sys.stderr.write(f"flexlift sweep: {exc}; the finished cases are kept in {out}: fix "
                         f"the cause (or report it) and run {_rerun(args, out)} to finish the "
                         "sweep\n")
        return 1
    except (KeyboardInterrupt, Terminated) as exc:
        bar.close()
        how = "terminated" if isinstance(exc, Terminated) else "interrupted"
        sys.stderr.write(f"flexlift sweep: {how}; the finished cases are kept in {out}: run "
                         "the same command again to finish the sweep\n")
        return 143 if isinstance(exc, Terminated) else 130
    except SchedulerLost as exc:
        bar.close()
        sys.stderr.write(f"flexlift sweep: {exc}; the finished cases are kept in {out}: to "
                         f"finish the sweep, run {_rerun(args, out)}\n")
        return 1
    finally:
        bar.close()
        for h in handlers:
            h.removeFilter(quiet_cases)
    s = result.summary
    if args.json:
        fp = {c: {k: v[k] for k in ("p", "low", "high", "n", "incomplete", "incomplete_as")
                  if k in v} for c, v in s["failure_probability"].items()}
        extra = {k: s[k] for k in ("sobol", "stopped_at", "halfwidths") if k in s}
        emit_json({"cases": s["cases"], "completed": s["completed"], "failed": s["failed"],
                   "engine": s["engine"], "failure_probability": fp,
                   "sensitivity": s["sensitivity"], "out": s["out"], **extra})
    elif not args.quiet:
        _print_summary(s, out)
    if result.completed == 0 and s["cases"] > 0:
        msg, n = result.most_common_failure() or ("?", 0)
        sys.stderr.write(f"flexlift sweep: every case failed; the most common failure "
                         f"({n} of {s['cases']}): {msg}\n")
        return 1
    return 0


def _spec(args: argparse.Namespace):
    """The sweep: the SPEC file, or the ready study of a scenario, with the command line's
    Monte Carlo options over it."""
    from flexlift.sweep import load_spec, parse_spec

    over = {k: v for k, v in (("method", args.method), ("samples", args.samples),
                              ("seed", args.seed), ("until_halfwidth", args.until_halfwidth))
            if v is not None}
    if args.study is None:
        return load_spec(args.spec, yes=args.yes, overrides=over)
    data = {"base": str(args.spec), "study": args.study, "monte_carlo": over}
    return parse_spec(data, f"study {clean(args.study, 40)} of {clean(str(args.spec), 80)}",
                      Path.cwd(), args.yes)


def _check_cost(spec, workers: int, args) -> None:
    """Refuse a sweep estimated beyond the cost limit unless ``--yes`` (scenario/cost.py)."""
    from flexlift.errors import InputError
    from flexlift.scenario.cost import MAX_SECONDS
    from flexlift.sweep.run import estimate_sweep

    per, total = estimate_sweep(spec, workers)
    if total > MAX_SECONDS and not args.yes:
        raise InputError.from_line(
            f"{clean(str(args.spec), 120)}: {spec.n_cases:,} cases of up to {per:.2g} s each on "
            f"{workers} worker(s): about {total / 60:,.0f} min estimated; at most "
            f"{MAX_SECONDS / 60:.0f} min without --yes (give --yes to run it, or fewer cases)")


def _rerun(args: argparse.Namespace, out: Path) -> str:
    """The command that resumes this sweep (same SPEC, same folder, same engine)."""

    cmd = ["flexlift", "sweep", str(args.spec), "--out", str(out)]
    if args.study is not None:
        cmd += ["--study", args.study]
    for opt in ("method", "samples", "seed", "until_halfwidth"):
        if getattr(args, opt) is not None:
            cmd += [f"--{opt.replace('_', '-')}", str(getattr(args, opt))]
    if args.scheduler is not None:
        cmd += ["--scheduler", args.scheduler]
    if args.dask_local is not None:
        cmd += ["--dask-local", str(args.dask_local)]
    if args.yes:
        cmd.append("--yes")
    return shlex.join(cmd)


def _print_summary(s: dict, out: Path) -> None:
    lines = [f"{s['cases']} cases: {s['completed']} completed, {s['failed']} failed "
             f"({s['lost']} lost); {s['skipped']} were already finished; {s['elapsed_s']:.1f} s "
             f"on {s['engine']}"]
    for mode, fp in s["by_control"].items():
        w = fp.get("all_criteria")
        if w and w["n"]:
            o = s["outcomes_by_control"][mode]
            lines.append(f"{mode}: probability that any criterion fails {w['p']:.3g} "
                         f"(95 % {w['low']:.3g}-{w['high']:.3g}, {w['failed']} of {w['n']} "
                         f"cases: {o['unsafe']['failed']} unsafe, "
                         f"{o['not_achieved']['failed']} not achieved, {o['failed']['failed']} "
                         f"failed to run, {o['incomplete']['failed']} incomplete (the run "
                         "ended before the target was held, counted as failing)")
    for mode, outs in s.get("sobol", {}).items():
        for name, res in outs.items():
            drivers = [g for g, v in sorted(res.get("groups", {}).items(),
                                            key=lambda kv: -kv[1]["ST"]) if v["driver"]]
            lines.append(f"{mode}: {name}: drivers (total Sobol index, 95 % interval above 0): "
                         + (", ".join(drivers) or "none"))
    lines.append(f"report: {out / 'report.html'}")
    sys.stdout.write("\n".join(lines) + "\n")
