"""The fuzzy stage (docs/theory/control.md#supervisor): the supervisory controller (built in, or a MATLAB ``.fis``)
evaluated, tabulated and drawn, as data, figures and tables.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flexlift.control.build import fill_map_of, supervisor_fis_of
from flexlift.errors import InputError
from flexlift.fuzzy.fis import read_fis, to_fis_text
from flexlift.fuzzy.system import FIS
from flexlift.output.stage import Figure, StageOutput, Table
from flexlift.plumbing.atomic import write_text

NAME = "fuzzy"
SURFACE_GRID = 81  # the table the simulation may use instead of exact inference
PLOT_GRID = 61


def load_system(scenario, fis_file: str | Path | None = None, extrapolate: bool = False) -> FIS:
    """The scenario's supervisor (the user's ``control.supervisor.fis_file``, else the built-in
    rule base with the scenario's operators), or any MATLAB .fis file given here."""
    fis = supervisor_fis_of(scenario) if fis_file is None else \
        read_fis(fis_file, resolution=scenario.control.supervisor.resolution)
    return fis.with_options(out_of_range="extrapolate") if extrapolate else fis


def plain(u):
    """A float, or a list of floats for several outputs (JSON-ready)."""
    return u.tolist() if isinstance(u, np.ndarray) else u


def grid_values(fis: FIS, n: int) -> dict:
    """u on an n x n grid over the two inputs' ranges: {"ze", "w", "u"} (u[i][j] at ze[i], w[j])."""
    if fis.n_inputs != 2:
        raise InputError("--grid", n, f"needs a two-input system; this one has {fis.n_inputs}")
    if n < 2:
        raise InputError("--grid", n, "at least 2 points per input")
    ze = np.linspace(*fis.inputs[0].range, n)
    w = np.linspace(*fis.inputs[1].range, n)
    P = np.stack(np.meshgrid(ze, w, indexing="ij"), axis=-1).reshape(-1, 2)
    u = fis(P).reshape(n, n, *([fis.n_outputs] if fis.n_outputs > 1 else []))
    return {"ze": ze.tolist(), "w": w.tolist(), "u": u.tolist()}


def _rule_table(fis: FIS) -> Table:
    if fis.n_inputs == 2 and fis.n_outputs == 1:
        a, b = fis.inputs
        cells = [[""] * len(b.mfs) for _ in a.mfs]
        for r in fis.rules:
            i, j = r.antecedent
            if i is not None and j is not None and not any(r.negated) and r.connective == "and" \
                    and r.consequent is not None and not r.consequent_negated:
                label = fis.output.mfs[r.consequent].name
                cells[i][j] = f"{cells[i][j]}/{label}" if cells[i][j] else label
        complete = all(all(c) for c in cells) and len(fis.rules) == len(a.mfs) * len(b.mfs)
        if complete:
            rows = [[a.mfs[i].name, *cells[i]] for i in reversed(range(len(a.mfs)))]
            return Table(f"Rule table: {fis.output.name} by {a.name} (rows) and {b.name} (columns)",
                         [f"{a.name} \\ {b.name}", *b.labels], rows, csv="fuzzy_rules.csv",
                         note=f"{fis.and_method}/{fis.or_method} inference, "
                              f"{fis.implication} implication, {fis.aggregation} aggregation, "
                              f"{fis.defuzzification} on {fis.resolution} points")
    rows = []
    for k, r in enumerate(fis.rules, 1):
        parts = [f"{'NOT ' if n else ''}{v.name} is {v.mfs[i].name}"
                 for i, n, v in zip(r.antecedent, r.negated, fis.inputs) if i is not None]
        then = [f"{v.name} is {'NOT ' if n else ''}{v.mfs[i].name}"
                for i, n, v in zip(r.consequents, r.consequents_negated, fis.outputs)
                if i is not None]
        rows.append([k, f" {r.connective.upper()} ".join(parts), ", ".join(then), r.weight])
    return Table(f"Rules of {fis.name!r}", ["rule", "if", "then", "weight"], rows,
                 csv="fuzzy_rules.csv", in_report=len(rows) <= 25)


def _sets_table(fis: FIS) -> Table:
    rows = [[v.name, m.name, m.kind, " ".join(f"{p:.6g}" for p in m.params)]
            for v in (*fis.inputs, *fis.outputs) for m in v.mfs]
    return Table("Membership functions (MATLAB parameter order)",
                 ["variable", "set", "type", "parameters"], rows, csv="fuzzy_sets.csv",
                 in_report=False)


def run_stage(scenario, out: Path | None = None, fis_file: str | Path | None = None,
              grid: int = SURFACE_GRID, extrapolate: bool = False) -> StageOutput:
    """Build (or load) the supervisory FIS, tabulate its surface, measure the interpolation
    error; figures and tables under ``out`` if given.

    fis_file : a MATLAB .fis file instead of the built-in system (default: built-in)
    grid : points per input of the interpolated surface table [-]
    extrapolate : evaluate the sets beyond the input ranges, as MATLAB (default: saturate)
    """
    fis = load_system(scenario, fis_file, extrapolate)
    own = fis_file is None  # the scenario's own controllers (else a file given to analyse)
    if own and scenario.control.supervisor.fis_file:
        fis_file = scenario.control.supervisor.fis_file  # the scenario's own: the loop's
    builtin = fis_file is None
    outputs = [{"name": v.name, "range": list(v.range), "sets": list(v.labels)}
               for v in fis.outputs]
    summary: dict = {
        "system": fis.name,
        "source": str(fis_file) if fis_file is not None else "built-in (docs/theory/control.md#rule-table)",
        "inputs": [{"name": v.name, "range": list(v.range), "sets": list(v.labels)}
                   for v in fis.inputs],
        **({"output": outputs[0]} if fis.n_outputs == 1 else {"outputs": outputs}),
        "type": fis.kind,
        "n_rules": len(fis.rules),
        "operators": {k: getattr(fis, k) for k in ("and_method", "or_method", "implication",
                                                   "aggregation", "defuzzification")},
        "resolution": fis.resolution,
    }
    criteria: dict[str, bool] = {}
    surf = None
    if fis.n_inputs == 2 and fis.n_outputs == 1:
        surf = fis.surface(grid=grid)
        lo, hi = np.array([v.range[0] for v in fis.inputs]), np.array([v.range[1] for v in fis.inputs])
        q = np.random.default_rng(1).uniform(lo, hi, (4000, 2))
        mid = 0.5 * (lo + hi)
        summary["u_at_centre"] = fis(mid)
        summary["surface"] = {"grid": grid, "max_error": surf.max_error,
                              "error_bound": surf.error_bound, "checked_points": surf.n_checked}
        summary["symmetry_error"] = float(np.max(np.abs(fis(q) + fis(2 * mid - q))))
        criteria["surface_interpolation_error_below_0.01"] = surf.max_error < 0.01
        if builtin:
            criteria["surface_odd_symmetric"] = summary["symmetry_error"] < 1e-9
    if own:
        fill = fill_map_of(scenario)
        summary["fill_map_source"] = scenario.control.fill.fis_file or "built-in (docs/theory/control.md#sifsmc)"
        summary["fill_map"] = {"d": [-1.0, 0.0, 0.25, 0.5, 0.75, 1.0],
                               "fill": [fill(d) for d in (-1.0, 0.0, 0.25, 0.5, 0.75, 1.0)]}
    tables = [_rule_table(fis), _sets_table(fis)]
    figures: list[Figure] = []
    if out is not None:
        figures = _write(Path(out), fis, tables, scenario if own else None)
    return StageOutput(name=NAME, summary=summary, figures=figures, tables=tables,
                       criteria=criteria)


def _write(out: Path, fis: FIS, tables: list[Table], scenario=None) -> list[Figure]:
    """Figures and tables of ``fis``; with ``scenario``, its fill map as well."""
    from flexlift.output.plots._style import draw
    from flexlift.output.plots.fuzzy import (
        plot_map,
        plot_memberships,
        plot_surface_3d,
        plot_surface_contour,
    )

    fdir, tdir = out / "figures", out / "tables"
    figures = [Figure(draw(fdir / "fuzzy_memberships.png", plot_memberships, fis),
                      f"Membership functions of the {fis.name} inputs and output.")]
    if fis.n_inputs == 2 and fis.n_outputs == 1:
        g = grid_values(fis, PLOT_GRID)
        labels = (fis.inputs[0].name, fis.inputs[1].name, fis.output.name)
        u = np.array(g["u"])
        figures.append(Figure(
            draw(fdir / "fuzzy_surface_3d.png", plot_surface_3d, g["ze"], g["w"], u, labels,
                 title=f"Control surface of {fis.name}"),
            f"Control surface {labels[2]}({labels[0]}, {labels[1]}) by exact inference."))
        centres = [[m.params[1] if m.kind == "gaussmf" else np.nan for m in v.mfs]
                   for v in fis.inputs]
        figures.append(Figure(
            draw(fdir / "fuzzy_surface_contour.png", plot_surface_contour, g["ze"], g["w"], u,
                 labels, centres=centres, title=f"Control surface of {fis.name}"),
            "Control surface as contours; the black line is u = 0."))
    if scenario is not None:  # the fill map the simulation uses (built in or the user's)
        fill = fill_map_of(scenario)
        d = np.linspace(-1.0, 1.0, 401)
        figures.append(Figure(draw(fdir / "fuzzy_fill_map.png", plot_map, d, fill(d)),
                              "SIFSMC fill map: signed distance d to the fill fraction of "
                              "Q_in,max (zero for d <= 0)."))
    for t in tables:
        write_text(tdir / t.csv, t.to_csv())
    write_text(out / "fuzzy_supervisor.fis", to_fis_text(fis))
    return figures
