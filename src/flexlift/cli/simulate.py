"""``flexlift simulate``: the controlled ascent of a scenario (SPEC §5-8).

Exit codes: 0 when the run completed (whether or not the criteria passed: they are in the
JSON and the summary, and ``flexlift run`` shows pass/fail), 1 when the numerics failed (the
results up to that moment are still written), 2 for bad input.
"""

from __future__ import annotations

import argparse
import sys
import typing
from pathlib import Path

from flexlift.cli._common import (
    add_json_arg,
    add_out_arg,
    add_scenario_arg,
    emit_json,
    positive_float,
    scenario_from,
    writing,
)
from flexlift.errors import SimulationError
from flexlift.output.stage import Figure, StageOutput, Table
from flexlift.scenario import ControlMode

MODES = typing.get_args(ControlMode)


def add_parser(sub) -> None:
    p = sub.add_parser("simulate", help="simulate the controlled ascent", description=__doc__)
    add_scenario_arg(p)
    p.add_argument("--control", choices=MODES, default=None,
                   help="control mode (default: the scenario's control.mode)")
    p.add_argument("--duration", type=positive_float("--duration"), default=None,
                   help="largest simulated time [s] (default: simulation.duration_s)")
    add_out_arg(p, "results (netCDF, CSV) and figures")
    add_json_arg(p)
    p.set_defaults(func=_main)


def _write(result, out: Path, mode: str, primary: bool) -> list[Figure]:
    from flexlift.output.plots import ascent
    from flexlift.output.plots._style import save
    from flexlift.output.results import save_netcdf, to_csv

    save_netcdf(result, out / "data" / f"simulate_{mode}.nc")
    if primary:
        save_netcdf(result, out / "results.nc")
    to_csv(result, out / "tables", prefix=f"simulate_{mode}")
    figs = []
    fd = out / "figures"
    figs.append(Figure(save(ascent.bag_histories(result), fd / f"simulate_{mode}_bags.png"),
                       f"Height, ascent velocity, pitch angle, pitch rate and net gas flow of every bag ({mode} control)."))
    figs.append(Figure(save(ascent.hull_motion(result), fd / f"simulate_{mode}_hull.png"),
                       f"Hull heave and pitch ({mode} control)."))
    if "x" in result.dataset.coords:
        figs.append(Figure(save(ascent.moment_map(result), fd / f"simulate_{mode}_moment.png"),
                           f"Bending-moment envelope and its history along the hull ({mode} control)."))
    return figs


def run_stage(scenario, out: Path | None, control: str | None = None,
              duration: float | None = None, progress=None, engine="table",
              primary: bool | None = None) -> StageOutput:
    """Simulate one control mode; write netCDF (``data/simulate_<mode>.nc``, and
    ``results.nc`` for the scenario's own control mode or when ``primary``), CSV tables and
    figures under ``out`` when given. A numerics failure still writes the partial results and
    is reported in the summary and warnings."""
    from flexlift.ascent import simulate

    mode = control or scenario.control.mode
    warnings = []
    try:
        result = simulate(scenario, control=mode, duration=duration, engine=engine, progress=progress)
    except SimulationError as exc:
        result = exc.partial
        warnings.append(str(exc))
        if result is None:
            raise
    if primary is None:
        primary = mode == scenario.control.mode
    figures = _write(result, Path(out), mode, primary) if out is not None else []
    summary = result.summary()
    rows = [[e["time_s"], e["kind"], e["bag"] or "", e.get("detail", "")] for e in result.events]
    tables = [Table(f"Events of the ascent ({mode})", ["time [s]", "event", "bag", "detail"], rows)]
    return StageOutput(name=f"simulate:{mode}", summary=summary, figures=figures, tables=tables,
                       warnings=warnings, criteria=result.criteria)


def compare_stage(outputs: list[StageOutput], out: Path | None) -> StageOutput:
    """One figure comparing the control modes simulated into ``out`` by :func:`run_stage`."""
    from flexlift.output.plots import ascent
    from flexlift.output.plots._style import save
    from flexlift.output.results import load_netcdf

    modes = [o.name.split(":", 1)[1] for o in outputs]
    rows = [[m, o.summary["max_pitch_deg"], o.summary["max_ascent_velocity_ms"],
             o.summary["arrival_spread_s"], o.summary["max_bending_moment_MNm"],
             o.summary["gas_used_free_air_m3"], all(o.criteria.values())]
            for m, o in zip(modes, outputs)]
    table = Table("Control modes compared",
                  ["control", "max pitch [deg]", "max ascent velocity [m/s]", "arrival spread [s]",
                   "max bending moment [MN m]", "gas used, free air [m3]", "all criteria"], rows)
    figures = []
    if out is not None:
        results = [load_netcdf(Path(out) / "data" / f"simulate_{m}.nc") for m in modes]
        path = save(ascent.compare(results), Path(out) / "figures" / "simulate_compare.png")
        figures.append(Figure(path, f"Control modes compared: {', '.join(modes)}."))
    summary = {m: {k: o.summary[k] for k in ("max_pitch_deg", "max_ascent_velocity_ms", "arrival_spread_s")}
               for m, o in zip(modes, outputs)}
    return StageOutput(name="compare", summary=summary, figures=figures, tables=[table])


def _main(args: argparse.Namespace) -> int:
    scenario = scenario_from(args)
    with writing(args.out, "simulate") as folder:
        out = run_stage(scenario, folder, control=args.control, duration=args.duration,
                        primary=True)
    s = out.summary
    if args.json:
        emit_json(s)
    else:
        crit = ", ".join(f"{k} {'pass' if v else 'FAIL'}" for k, v in s["criteria"].items())
        arr = [v for v in s["arrival_time_s"].values() if v is not None]
        sys.stdout.write(
            f"{s['control']} control: separation at {s['separation_time_s']} s, breakout complete at "
            f"{s['breakout_time_s']} s, last arrival at {max(arr) if arr else None} s; "
            f"max ascent velocity {s['max_ascent_velocity_ms']} m/s, max pitch {s['max_pitch_deg']} deg, "
            f"max bending moment {s['max_bending_moment_MNm']} MN m, gas {s['gas_used_free_air_m3']} m3 "
            f"free air\ncriteria: {crit}\n")
    for w in out.warnings:
        sys.stderr.write(f"flexlift simulate: {w}\n")
    return 1 if out.warnings and s.get("error") else 0
