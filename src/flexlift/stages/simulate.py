"""The ascent stage (docs/theory/loop.md): one control mode simulated, its results written (netCDF, CSV,
figures), and control modes compared.
"""

from __future__ import annotations

import typing
from pathlib import Path

import numpy as np

from flexlift import constants as C
from flexlift.errors import InputError, SimulationError
from flexlift.output.pointtables import event_rows, point_tables
from flexlift.output.stage import Figure, StageOutput, Table
from flexlift.scenario import ControlMode

MODES = typing.get_args(ControlMode)


def static_view(scenario) -> dict:
    """What the seabed figure of a long structure adds to the ascent: the slope validity [deg]
    and the utilisation along it in the governing static design case of the loads stage
    (``x`` [m], ``utilisation`` [-])."""
    from flexlift.loads.liftplan import plan_lift
    from flexlift.stages.loads import still_water, utilisation_along
    from flexlift.structure.hull import hull_from_scenario

    hull = hull_from_scenario(scenario)
    _, st = still_water(scenario, hull, plan_lift(scenario, hull), per_element=4)
    return {"validity_deg": scenario.limits.slope_validity_deg, "x": st.x,
            "utilisation": utilisation_along(scenario, st)}


def _write(result, out: Path, mode: str, seabed: dict | None = None,
           tables: tuple[Table, ...] = ()) -> list[Figure]:
    from flexlift.output.plots import ascent
    from flexlift.output.plots._style import draw
    from flexlift.output.results import add_to_netcdf, to_csv
    from flexlift.plumbing.atomic import write_text

    add_to_netcdf(result, out / "results.nc")  # every mode of the run in one file
    to_csv(result, out / "tables", prefix=f"simulate_{mode}")
    for t in tables:
        write_text(out / "tables" / t.csv, t.to_csv())
    figs = []
    fd = out / "figures"
    window = ascent.window_text(result)
    figs.append(Figure(draw(fd / f"simulate_{mode}_bags.png", ascent.bag_histories, result),
                       f"Height, ascent velocity, pitch angle, pitch rate and net gas flow by "
                       f"lift point ({mode} control), {window}; above them the heights over "
                       "the whole run. One line per lift point (the mean of its bags, their "
                       "spread as a band), coloured by its position along the hull. Time in "
                       "seconds from the start of filling."))
    figs.append(Figure(draw(fd / f"simulate_{mode}_hull.png", ascent.hull_motion, result),
                       f"Hull heave and pitch ({mode} control), {window}."))
    if "x" in result.dataset.coords:
        figs.append(Figure(draw(fd / f"simulate_{mode}_moment.png", ascent.moment_map, result),
                           f"Bending-moment envelope over the whole run and the bending "
                           f"moment along the hull in time, {window} ({mode} control)."))
    if seabed is not None and "x" in result.dataset.coords:
        figs.append(Figure(draw(fd / f"simulate_{mode}_seabed.png", ascent.seabed_and_stress,
                                result, **seabed),
                           f"The part of the structure on the seabed in time (its edges are "
                           f"the touchdown points), the largest slope along it against the "
                           f"small-deflection beam's validity, {window}, and the bending-stress "
                           f"utilisation along it: its envelope over the lift ({mode} control) "
                           f"and in the governing static design case (the loads stage)."))
    return figs


def static_peak_moment(scenario) -> tuple[float, str]:
    """The governing static design case's peak |M| [N m] (the largest of the loads stage's
    closed design cases, :func:`flexlift.stages.loads.design`) and its name."""
    from flexlift.loads.liftplan import plan_lift
    from flexlift.stages.loads import design
    from flexlift.structure.hull import hull_from_scenario

    hull = hull_from_scenario(scenario)
    cases = design(scenario, hull, plan_lift(scenario, hull))
    c = max(cases, key=lambda c: float(np.abs(c.strength.M).max()))
    return float(np.abs(c.strength.M).max()), c.name


def sling_design_loads(scenario) -> dict:
    """Each bag's sling design load [N]: its full true lift, capacity factor x max(rated,
    modelled lift), as the design basis states it (internal bags have no sling: absent)."""
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    plan = plan_lift(scenario, hull_from_scenario(scenario))
    bag = scenario.lift.catalogue_bag
    rated = bag.lift_t * C.TONNE * plan.gravity
    return {b.name: bag.capacity_factor * max(rated, b.lift) for b in plan.external}


def amplification(result, scenario, mode: str) -> tuple[dict, Table, Table]:
    """The dynamic amplification of a run beside the static design cases: the summary keys
    (``daf_bending``, ``max_sling_over_design_load`` and its bag), the per-bag table (CSV) and
    the report's small table."""
    ds = result.dataset
    h = result.headline
    design_load = sling_design_loads(scenario)
    names = [str(b) for b in ds.bag.values]
    peak = np.fmax(ds["peak_sling_force_pull"].values, ds["peak_sling_force_ascent"].values)
    rows, ratios = [], {}
    for i, n in enumerate(names):
        dl = design_load.get(n)
        if dl:
            ratios[n] = float(peak[i]) / dl
        rows.append([n, str(ds["bag_kind"].values[i]),
                     _r(ds["static_force_pull"].values[i] / 1e6, 4),
                     _r(ds["peak_sling_force_pull"].values[i] / 1e6, 4),
                     _r(ds["daf_pull"].values[i], 4),
                     _r(ds["static_force_hold"].values[i] / 1e6, 4),
                     _r(ds["peak_sling_force_ascent"].values[i] / 1e6, 4),
                     _r(ds["daf_ascent"].values[i], 4),
                     _r(dl / 1e6, 4) if dl else None,
                     _r(ratios.get(n), 4)])
    per_bag = Table(f"Dynamic amplification of the sling forces by bag ({mode})",
                    ["bag", "kind", "static pull-phase force [MN]", "peak sling force before "
                     "separation [MN]", "DAF before separation", "static holding force [MN]",
                     "peak sling force after separation [MN]", "DAF after separation",
                     "sling design load [MN]", "peak over design load"], rows,
                    csv=f"simulate_{mode}_amplification.csv")
    out = {"daf_bending": None, "daf_bending_case": None,
           "max_sling_over_design_load": None, "max_sling_over_design_load_bag": None}
    M_dyn = h.get("max_bending_moment_MNm")
    if M_dyn is not None:
        M_st, case = static_peak_moment(scenario)
        out["daf_bending"] = _r(M_dyn * 1e6 / M_st, 3) if M_st > 0 else None
        out["daf_bending_case"] = case
    if ratios:
        b = max(ratios, key=ratios.get)
        out["max_sling_over_design_load"] = _r(ratios[b], 3)
        out["max_sling_over_design_load_bag"] = b
    small = Table(f"Dynamic amplification from the run ({mode})", ["quantity", "value", "bag"],
                  [["sling force before separation: peak over holding share plus pull",
                    h.get("daf_pull"), h.get("daf_pull_bag")],
                   ["sling force after separation: peak over holding share",
                    h.get("daf_ascent"), h.get("daf_ascent_bag")],
                   [f"bending moment: peak over the static {out['daf_bending_case'] or '–'} "
                    "case's", out["daf_bending"], None],
                   ["peak sling force over its sling design load",
                    out["max_sling_over_design_load"], out["max_sling_over_design_load_bag"]]],
                  note="The static forces are the closed design cases' (the loads stage): the "
                       "holding share (neutral buoyancy) plus the planned breakout pull before "
                       "the separation, the holding share after it; a bag still carries its "
                       "pull just after the separation until its controller purges it. Every "
                       f"bag's values: tables/{per_bag.csv}. The design basis's in-air DAF is "
                       "for comparison only.")
    return out, per_bag, small


def _r(v, nd):
    return None if v is None or not np.isfinite(v) else round(float(v), nd)


def gas_budget_rows(s: dict) -> list[list]:
    """The whole gas budget of a run summary, free air at the surface [m^3], row by row."""
    return [["initial fill to the neutral volumes, before the run [m3]", s["gas_initial_free_air_m3"]],
            ["top-up during the run [m3]", s["gas_used_free_air_m3"]],
            ["in all [m3]", s["gas_total_free_air_m3"]],
            ["vented: spill, relief and leaks [m3]", s["gas_vented_free_air_m3"]],
            ["purged by the controllers [m3]", s["gas_purged_free_air_m3"]],
            ["supply time at the fill rate, one bag after another [h]", s["supply_bag_hours"]]]


def gas_table(s: dict, mode: str) -> Table:
    return Table(f"Gas budget ({mode}), as free air at the surface (at local pressure in the "
                 "netCDF)", ["quantity", "value"], gas_budget_rows(s))


def stress_table(result, scenario, mode: str) -> Table:
    """Where the hull girder stress envelope peaks, against the allowable stress."""
    ds = result.dataset
    k = int(np.argmax(ds["utilisation_max"].values))
    x = float(ds["x"][k])
    return Table(f"Hull girder stress over the ascent ({mode})",
                 ["quantity", "value"],
                 [["largest bending stress |M| / Z [MPa]", round(float(ds["stress_max"][k]) / 1e6, 1)],
                  ["at x from the aft end [m]", round(x, 1)],
                  ["allowable stress [MPa]", scenario.hull.allowable_stress_MPa],
                  ["utilisation", round(float(ds["utilisation_max"][k]), 3)]])


def run_stage(scenario, out: Path | None, control: str | None = None,
              duration: float | None = None, progress=None, engine="table",
              sensor_log: Path | None = None) -> StageOutput:
    """Simulate one control mode; add it to ``results.nc`` (every mode simulated into ``out``
    is one file, :func:`flexlift.output.results.save_netcdf`) and write its CSV tables and
    figures under ``out`` when given. A numerics failure still writes the partial results and
    is reported in the summary and warnings. ``sensor_log``: also write the readings of the
    scenario's sensors to this new file (:func:`flexlift.sensors.tap.run_with_log`; JSON
    lines, CSV when it ends ``.csv``), written whole or not at all."""
    from flexlift.ascent import simulate

    mode = control or scenario.control.mode
    warnings = []
    try:
        if sensor_log is None:
            result = simulate(scenario, control=mode, duration=duration, engine=engine,
                              progress=progress)
        else:
            result = _with_sensor_log(scenario, mode, duration, engine, progress, sensor_log)
    except SimulationError as exc:
        result = exc.partial
        warnings.append(str(exc))
        if result is None:
            raise
    long_ = scenario.pipe is not None or scenario.control.sequence is not None
    per_point, per_bag = point_tables(result, mode)
    daf, daf_bags, daf_small = amplification(result, scenario, mode)
    figures = (_write(result, Path(out), mode, static_view(scenario) if long_ else None,
                      (per_point, per_bag, daf_bags))
               if out is not None else [])
    summary = result.summary()
    summary.update(daf)
    summary["conclusion"] = _conclusion(mode, result.outcome)
    warnings += result.warnings
    tables = [Table(f"Events of the ascent ({mode})", ["time [s]", "event", "bag", "detail"],
                    event_rows(result)),
              gas_table(summary, mode), per_point, per_bag, daf_small]
    if summary["max_stress_MPa"] is not None:
        tables.append(stress_table(result, scenario, mode))
    return StageOutput(name=f"simulate:{mode}", summary=summary, figures=figures, tables=tables,
                       warnings=warnings, criteria=result.criteria)


def _with_sensor_log(scenario, mode, duration, engine, progress, path: Path):
    """The run of :func:`flexlift.ascent.simulate`, stepped with its sensors' log written to
    ``path`` (a new file; written beside it and renamed when whole)."""
    from flexlift.ascent.loop import prepare
    from flexlift.plumbing.atomic import atomic_file
    from flexlift.sensors.tap import run_with_log

    if Path(path).exists() or Path(path).is_symlink():
        raise InputError("--sensor-log", str(path), "already exists: flexlift writes a new log "
                         "and never overwrites a file (remove it or name another)")
    run = prepare(scenario, mode, duration, engine)
    with atomic_file(path) as tmp:
        try:
            result, _ = run_with_log(run, tmp)
        except SimulationError as exc:  # the log up to the failure is the lift's log
            error = exc
        else:
            error = None
    if error is not None:
        raise error
    return result


#: the outcome of an ascent in the lead of its section
OUTCOME_WORDS = {"safe": "safe", "unsafe": "unsafe", "not_achieved": "not achieved",
                 "incomplete": "incomplete (not unsafe: the run ended first)"}


def _conclusion(mode: str, outcome: dict) -> str:
    """The section's first sentence: the outcome of the ascent and why."""
    kind = outcome.get("kind")
    if kind is None:
        return ""
    return f"Outcome ({mode} control): {OUTCOME_WORDS.get(kind, kind)}: {outcome.get('cause', '')}."


def compare_stage(outputs: list[StageOutput], out: Path | None) -> StageOutput:
    """One figure comparing the control modes simulated into ``out`` by :func:`run_stage`."""
    from flexlift.output.plots import ascent
    from flexlift.output.plots._style import draw
    from flexlift.output.results import load_netcdf

    modes = [o.name.split(":", 1)[1] for o in outputs]
    rows = [[m, o.summary["max_pitch_deg"], o.summary["max_ascent_velocity_ms"],
             o.summary["max_descent_velocity_ms"], o.summary["arrival_spread_s"],
             o.summary["max_bending_moment_MNm"], o.summary["max_utilisation"],
             o.summary["gas_total_free_air_m3"], all(o.criteria.values()),
             OUTCOME_WORDS.get(o.summary.get("outcome"), "–").split(" (")[0]]
            for m, o in zip(modes, outputs)]
    table = Table("Control modes compared",
                  ["control", "max pitch [deg]", "max ascent velocity [m/s]",
                   "max descent velocity [m/s]", "arrival spread [s]", "max bending moment [MN m]",
                   "max stress utilisation", "gas in all (initial fill + top-up), free air [m3]",
                   "all criteria", "outcome"], rows)
    figures = []
    if out is not None:
        results = [load_netcdf(Path(out) / "results.nc", m, variables=ascent.COMPARED)
                   for m in modes]
        path = draw(Path(out) / "figures" / "simulate_compare.png", ascent.compare, results)
        figures.append(Figure(path, f"Control modes compared: {', '.join(modes)}; time in "
                                    "seconds, from 60 s before the first separation."))
    summary = {m: {k: o.summary[k] for k in ("max_pitch_deg", "max_ascent_velocity_ms", "arrival_spread_s")}
               for m, o in zip(modes, outputs)}
    return StageOutput(name="compare", summary=summary, figures=figures, tables=[table])
