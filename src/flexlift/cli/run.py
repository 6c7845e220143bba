"""``flexlift run``: every stage on one scenario, into one output folder with a report.

The folder (default ``flexlift-out/<scenario name>/``) is built in a temporary sibling and
swapped in only when complete: an interrupted or failed run leaves the previous one intact.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from pathlib import Path

from flexlift._jit import cache_is_warm
from flexlift.cli._common import add_scenario_arg, emit_json, help_text, scenario_from
from flexlift.output import output_folder, write_json, write_text
from flexlift.output.controllers import copy_controller_files
from flexlift.output.folders import check_target
from flexlift.output.report import APPENDIX_PAGE, BODY_STAGES, render_appendix, render_report
from flexlift.stages.run import (
    CONTROL_MODES,
    DEFAULT_CONTROLS,
    STAGES,
    heap_frozen,
    run_all,
    summary_of,
)


def _csv_list(kind: str, allowed: tuple[str, ...]):
    def parse(text: str) -> tuple[str, ...]:
        items = tuple(s.strip() for s in text.split(",") if s.strip())
        bad = [s for s in items if s not in allowed]
        if bad or not items:
            raise argparse.ArgumentTypeError(
                f"{kind} {','.join(bad) or repr(text)} not known; choose from {','.join(allowed)}"
            )
        return items

    return parse


#: the stages ``--stages`` may name: the analysis, and the single-failure study (not by
#: default: it runs every single failure at every phase, flexlift.sweep.contingency)
CLI_STAGES = (*STAGES, "contingency")

log = logging.getLogger(__name__)


def add_parser(sub) -> None:
    p = sub.add_parser(
        "run",
        help="the whole analysis: modes, lift plan, reduction, fuzzy controller, ascent, report",
        description=help_text(__doc__),
    )
    add_scenario_arg(p)
    p.add_argument(
        "--out",
        type=Path,
        default=None,
        help="output folder (default: flexlift-out/<scenario name>)",
    )
    p.add_argument(
        "--stages",
        type=_csv_list("stage", CLI_STAGES),
        default=STAGES,
        help=f"comma-separated subset of {','.join(CLI_STAGES)} (default: "
        f"{','.join(STAGES)}; contingency: every single failure at every phase)",
    )
    p.add_argument(
        "--control",
        type=_csv_list("control mode", CONTROL_MODES),
        default=DEFAULT_CONTROLS,
        help=f"control modes to simulate and compare, from {','.join(CONTROL_MODES)} "
        f"(default: {','.join(DEFAULT_CONTROLS)})",
    )
    p.add_argument("--quiet", action="store_true", help="no progress on the terminal")
    p.add_argument(
        "--strict",
        action="store_true",
        help="exit with code 1 when any acceptance criterion fails (default: 0, verdict in the report)",
    )
    p.add_argument("--json", action="store_true", help="print summary.json on stdout")
    p.set_defaults(func=_main)


class Progress:
    """Stage-by-stage lines and a simulation bar on stderr (silent when quiet)."""

    def __init__(self, quiet: bool, stream=None):
        self.quiet = quiet
        self.stream = stream or sys.stderr
        self.tty = hasattr(self.stream, "isatty") and self.stream.isatty()
        self._last = -1

    def note(self, text: str) -> None:
        if not self.quiet:
            self.stream.write(f"flexlift: {text}\n")
            self.stream.flush()

    def stage(self, k: int, n: int, text: str) -> None:
        if not self.quiet:
            self.stream.write(f"[{k}/{n}] {text}\n")
            self.stream.flush()

    def bar(self, fraction: float, label: str = "") -> None:
        if self.quiet:
            return
        pct = int(100 * min(max(fraction, 0.0), 1.0))
        if self.tty:
            filled = pct * 30 // 100
            self.stream.write(f"\r      {label} [{'#' * filled}{'.' * (30 - filled)}] {pct:3d}%")
            if pct == 100:
                self.stream.write("\n")
            self.stream.flush()
        elif pct // 25 != self._last // 25 or pct == 100 and self._last != 100:
            self.stream.write(f"      {label} {pct}%\n")
            self.stream.flush()
        self._last = pct


def _contingency(scenario, tmp: Path, args, progress, k: int):
    """The single-failure stage, in the scenario's control mode when it is among --control."""
    from flexlift.sweep.contingency.stage import run_stage

    mode = scenario.control.mode if scenario.control.mode in args.control else args.control[0]
    progress.stage(k, k, f"Single failures: {mode}")
    return run_stage(scenario, tmp, control=mode,
                     progress=lambda f: progress.bar(f, "single failures"))


#: the warnings a finished run prints on the terminal (the rest: summary.json, the report)
SHOWN_WARNINGS = 3


def warning_lines(warnings: list, where: Path) -> list[str]:
    """The first :data:`SHOWN_WARNINGS` warnings, one line each, and where the rest are."""
    lines = [" ".join(str(w).split()) for w in warnings[:SHOWN_WARNINGS]]
    if len(warnings) > SHOWN_WARNINGS:
        lines.append(f"... and {len(warnings) - SHOWN_WARNINGS} more warning(s): {where} "
                     "(warnings) and the report")
    return lines


def _main(args: argparse.Namespace) -> int:
    from flexlift.output.plots._style import figures_in_background

    scenario = scenario_from(args)
    out = args.out if args.out is not None else Path("flexlift-out") / scenario.name
    progress = Progress(quiet=args.quiet)
    check_target(Path(os.path.abspath(out)), os.fspath(out))  # before any note or work
    if not args.quiet and "simulate" in args.stages and not cache_is_warm():
        progress.note("the ascent loop is compiled first (once after an install or a change "
                      "to it; about one to two minutes on two cores; `python -m "
                      "flexlift.cli.warm` does it ahead)")
    t0 = time.perf_counter()
    with output_folder(out, "run") as tmp:  # refuses folders flexlift did not write
        # the speed-ups of the whole process are the command's, not the library's: the heap
        # of the imports frozen for the collector, the figures drawn by figure processes
        # while the next stage computes (all complete, and the processes gone, at its end)
        with heap_frozen(), figures_in_background():
            stages = tuple(s for s in args.stages if s != "contingency")
            outputs = run_all(scenario, tmp, stages, args.control, progress)
            if "contingency" in args.stages:
                outputs.append(_contingency(scenario, tmp, args, progress, len(stages) + 1))
        as_written, copies = copy_controller_files(scenario, tmp)
        summary = summary_of(scenario, outputs, time.perf_counter() - t0)
        if copies:
            summary["controller_files"] = copies
        write_text(tmp / "scenario.yaml", as_written.to_yaml())
        write_json(tmp / "summary.json", summary)
        write_text(tmp / "report.html", render_report(scenario, outputs,
                                                       appendix_page=APPENDIX_PAGE))
        if any(o.name.split(":")[0] not in BODY_STAGES for o in outputs):
            write_text(tmp / APPENDIX_PAGE, render_appendix(scenario, outputs))
    if args.json:
        emit_json(summary)
    if not args.quiet:
        verdict = summary["all_criteria_passed"]
        status = {True: "all criteria passed", False: "SOME CRITERIA FAILED", None: "no criteria"}
        sys.stderr.write(
            f"done in {summary['elapsed_s']:.1f} s: {status[verdict]}, "
            f"{len(summary['warnings'])} warning(s)\nreport: {out / 'report.html'}\n"
        )
        for line in warning_lines(summary["warnings"], out / "summary.json"):
            log.warning(line)  # printed after the command, once (a library's own: not twice)
    return 1 if args.strict and summary["all_criteria_passed"] is False else 0


