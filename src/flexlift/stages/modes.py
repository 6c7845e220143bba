"""The modal stage (docs/theory/modes.md): frequencies and mode shapes of the hull as a free-free beam, dry
and wet (with the added mass and entrained water the ascent integrates), the nodes of its
first flexible modes, and the convergence study, as data, figures and tables.

Modes are named as everywhere else (:mod:`flexlift.output.modenames`): "heave", "pitch", then
flexible modes 1, 2, ...; the report lists the flexible modes the mesh resolves
(:func:`mesh_resolved`), the CSV every mode computed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flexlift.ascent.plant import wet_beam
from flexlift.errors import InputError
from flexlift.output.modenames import mode_label, mode_title
from flexlift.output.stage import Figure, StageOutput, Table
from flexlift.plumbing.atomic import write_text
from flexlift.structure.beam import assemble
from flexlift.structure.convergence import Convergence, convergence_study, is_uniform
from flexlift.structure.hull import hull_from_scenario
from flexlift.structure.modes import Modes, analytic_free_free_hz, compute_modes, mode_nodes

NAME = "modes"
NODE_MODES = 5
RATE_RANGE = (-4.5, -3.5)
#: flexible modes listed on the page at most (the CSV has every mode computed)
PAGE_MODES = 20
#: how the report chooses the modes it lists (see :func:`mesh_resolved`)
RESOLVED_RULE = (
    "Listed: flexible modes 1 to N/2 of a mesh of N elements, the ones it resolves: Hermite "
    "cubics put them within 1 % of the converged frequency (0.2 to 0.6 % at mode N/2 on 2 to "
    "50 elements), while beyond mode N they are 10 % off or more, artefacts of the mesh. "
    "Every mode computed is in the CSV."
)


def mesh_resolved(modes: Modes) -> int:
    """How many flexible modes the mesh resolves: floor(N/2) of N elements (at least one),
    as far as computed [-]. Flexible mode k <= N/2 lies within 1 % of its converged
    frequency for N >= 2 (tested in tests/test_cli_modes.py); the error grows with k/N and
    passes 10 % beyond k = N."""
    n_flex = modes.n_modes - modes.n_rigid
    return max(0, min(n_flex, max(1, modes.hull.n_elements // 2)))


def wet_modes(scenario, hull, n_modes: int, solver: str = "auto") -> tuple[Modes, float]:
    """The wet modes of ``hull``, as the ascent's coupled plant integrates them (its beam with
    the added mass and entrained water, :func:`flexlift.ascent.plant.wet_beam`), and that
    extra mass per length [kg/m]."""
    beam, extra = wet_beam(scenario, hull)
    return compute_modes(beam, n_modes=n_modes, solver=solver), extra


def _nodes_of(modes: Modes) -> dict[str, list[int]]:
    """Nodes (1-based) of the first flexible modes, by flexible mode number ("1", "2", ...)."""
    k = min(NODE_MODES, modes.n_modes - modes.n_rigid)
    return {str(j): [n + 1 for n in mode_nodes(modes, modes.flexible_index(j))]
            for j in range(1, k + 1)}


def _quality(modes: Modes) -> dict:
    """Orthonormality and rigid-mode residuals of the computed modes [-]."""
    beam = assemble(modes.hull)
    phi = modes.phi
    G = phi.T @ np.asarray(beam.M @ phi)
    KR = np.asarray(beam.K @ phi[:, :2])
    k_scale = abs(beam.K).max() * np.abs(phi[:, :2]).max()
    return {
        "mass_orthonormality_error": float(np.abs(G - np.eye(G.shape[0])).max()),
        "rigid_mode_residual": float(np.abs(KR).max() / k_scale),
    }


def summary_of(scenario, modes: Modes, conv: Convergence | None, solver: str,
               wet: Modes | None = None, wet_extra_kg_m: float | None = None) -> dict:
    """The JSON summary (frequencies in Hz, nodes 1-based; ``mode_labels`` names the entries
    of the frequency lists, ``mode_nodes`` is keyed by flexible mode number)."""
    hull = modes.hull
    n_flex = modes.n_modes - modes.n_rigid
    wet_hz = [] if wet is None else [float(f) for f in wet.frequencies_hz]
    s = {
        "scenario": scenario.name,
        "elements": hull.n_elements,
        "nodes": hull.n_nodes,
        "solver": "sparse" if solver == "auto" else solver,
        "mode_labels": [mode_label(i, modes.n_rigid) for i in range(modes.n_modes)],
        "frequencies_hz": [float(f) for f in modes.frequencies_hz],
        "wet_frequencies_hz": (wet_hz + [None] * modes.n_modes)[:modes.n_modes],
        "wet_extra_mass_per_length_kg_m": wet_extra_kg_m,
        "mesh_resolved_flexible_modes": mesh_resolved(modes),
        "rigid_modes": modes.n_rigid,
        # the solver returns only the modes it resolves to docs/theory/modes.md#mass-normalisation (flexlift.structure.modes)
        "modes_requested": modes.n_requested or modes.n_modes,
        "modes_resolved": modes.n_modes,
        "mode_nodes": _nodes_of(modes),
        "analytic_hz": (
            [float(f) for f in analytic_free_free_hz(hull, min(5, n_flex))]
            if is_uniform(hull) else None
        ),
    }
    s.update(_quality(modes))
    if conv is not None:
        s["convergence"] = conv.to_dict()
    return s


def _frequency_rows(summary: dict, modes: Modes) -> list[list]:
    """[label, kind, dry, wet, analytic, nodes, resolved] for every mode computed."""
    fa = summary["analytic_hz"] or []
    n_res = summary["mesh_resolved_flexible_modes"]
    rows = []
    for i, (f, fw) in enumerate(zip(summary["frequencies_hz"], summary["wet_frequencies_hz"])):
        kind = "rigid" if i < modes.n_rigid else "flexible"
        j = i - modes.n_rigid
        ref = fa[j] if 0 <= j < len(fa) else None
        nodes = summary["mode_nodes"].get(mode_label(i, modes.n_rigid)) if j >= 0 else None
        rows.append([mode_label(i, modes.n_rigid), kind, round(f, 6),
                     None if fw is None else round(fw, 6), None if ref is None else round(ref, 6),
                     None if nodes is None else " ".join(map(str, nodes)), j < n_res])
    return rows


def _tables(summary: dict, modes: Modes) -> list[Table]:
    rows = _frequency_rows(summary, modes)
    n_res = summary["mesh_resolved_flexible_modes"]
    n_el = modes.hull.n_elements
    wet_note = (f"Wet: with the added mass and entrained water, "
                f"{summary['wet_extra_mass_per_length_kg_m']:,.0f} kg/m, moving with the hull "
                "(the ascent integrates the wet modes).")
    n_page = min(n_res, PAGE_MODES)
    shown = [[mode_title(i, modes.n_rigid), r[2], r[3],
              None if r[3] is None or not r[2] else round(r[3] / r[2], 4), r[4], r[5]]
             for i, r in enumerate(rows[:modes.n_rigid + n_page])]
    more = (f" Flexible modes {n_page + 1} to {n_res}, also resolved, are in the CSV."
            if n_res > n_page else "")
    tables = [
        Table(
            f"Natural frequencies, dry and wet: heave, pitch and flexible modes 1 to {n_page} "
            f"({n_res} resolved by {n_el} elements)" if n_res > n_page else
            f"Natural frequencies, dry and wet: heave, pitch and the {n_res} flexible modes "
            f"{n_el} elements resolve",
            ["mode", "dry [Hz]", "wet [Hz]", "wet / dry", "analytic uniform beam, dry [Hz]",
             "nodes (1-based)"],
            shown,
            f"{n_el} Hermite cubic elements, consistent mass; rigid modes exact. {wet_note} "
            f"{RESOLVED_RULE}{more}",
        ),
        Table(
            f"Natural frequencies of all {len(rows)} modes computed, dry and wet",
            ["mode", "kind", "dry [Hz]", "wet [Hz]", "analytic uniform beam, dry [Hz]",
             "nodes (1-based)", "resolved by the mesh"],
            rows, csv="modes_frequencies.csv", in_report=False,
        ),
    ]
    conv = summary.get("convergence")
    if conv:
        n = len(conv["reference_hz"])
        rows = [[e] + [None if f is None else round(f, 6) for f in fr]
                + [None if not any(x is not None for x in er)
                   else float(f"{max(abs(x) for x in er if x is not None):.3e}")]
                for e, fr, er in zip(conv["elements"], conv["frequencies_hz"], conv["rel_error"])]
        rows.append(["reference"] + [round(f, 6) for f in conv["reference_hz"]] + [None])
        rows.append(["rate p"] + [None if r is None else round(r, 3) for r in conv["rates"]]
                    + [None])
        tables.append(Table(
            "Convergence of the first flexible frequencies with element count",
            ["elements"] + [f"flexible mode {j + 1} [Hz]" for j in range(n)] + ["max |rel. error|"],
            rows,
            f"Reference: {conv['reference']}; error ~ elements^p, p = -4 expected.",
            csv="modes_convergence.csv",
        ))
    return tables


def run_stage(
    scenario,
    out: Path | None = None,
    elements: int | None = None,
    n_modes: int | None = None,
    solver: str = "auto",
    convergence: bool = True,
) -> StageOutput:
    """Modal analysis of ``scenario``'s hull; figures and CSV tables under ``out`` if given.

    elements : re-mesh with this many equal elements (default: the scenario's) [-]
    n_modes : total modes, rigid included (default: all up to 400 elements, else 22) [-]
    solver : "auto", "sparse" or "dense" (see :func:`flexlift.structure.modes.compute_modes`)
    convergence : also run the convergence study on the scenario's hull
    """
    base = hull_from_scenario(scenario)
    if elements is not None and int(elements) < 1:
        raise InputError("--elements", elements, "need at least one element")
    hull = base if elements is None else base.refined(int(elements))
    n_dof = 2 * hull.n_nodes
    if n_modes is not None and not 3 <= int(n_modes) <= n_dof:
        raise InputError("--modes", n_modes,
                         f"choose 3..{n_dof} (2 rigid + flexible) for {hull.n_elements} elements")
    modes = compute_modes(hull, n_modes=n_modes, solver=solver)
    wet, extra = wet_modes(scenario, hull, modes.n_modes, solver)
    conv = convergence_study(base) if convergence else None
    summary = summary_of(scenario, modes, conv, solver, wet, extra)
    tables = _tables(summary, modes)
    rates = np.array([np.nan if r is None else r for r in (conv.rates if conv else [])])
    criteria = {
        "mass_normalised": summary["mass_orthonormality_error"] < 1e-8,
        "rigid_modes_clean": summary["rigid_mode_residual"] < 1e-10,
    }
    if conv is not None:
        criteria["convergence_rate_h4"] = bool(
            np.all((rates > RATE_RANGE[0]) & (rates < RATE_RANGE[1]))
        )
    figures: list[Figure] = []
    if out is not None:
        figures = _write(Path(out), scenario, modes, wet, conv, summary, tables)
    return StageOutput(name=NAME, summary=summary, figures=figures, tables=tables,
                       criteria=criteria)


def layout_mode(scenario) -> int | None:
    """The flexible mode whose nodes carry the external bags (``lift.layout: mode_nodes``
    without an explicit ``lift.bags``), else None."""
    lift = scenario.lift
    if lift.bags is None and lift.layout == "mode_nodes":
        return int(lift.layout_flexible_mode)
    return None


def _write(out: Path, scenario, modes: Modes, wet: Modes, conv, summary: dict,
           tables: list[Table]) -> list[Figure]:
    from flexlift.output.plots._style import draw
    from flexlift.output.plots.modes import plot_convergence, plot_frequencies, plot_mode_shapes

    fdir, tdir = out / "figures", out / "tables"
    n_flex = modes.n_modes - modes.n_rigid
    bags_on = layout_mode(scenario)
    k = min(max(NODE_MODES, bags_on or 0), n_flex)
    on = "" if bags_on is None or bags_on > k else (
        f" The external bags sit at the nodes of {mode_title(modes.flexible_index(bags_on))} "
        "(lift.layout_flexible_mode).")
    figures = [Figure(
        draw(fdir / "modes_shapes.png", plot_mode_shapes, modes, k, highlight=bags_on),
        f"Flexible modes 1 to {k} (unit peak, dry) with the beam nodes nearest their zero "
        f"crossings marked: a lift point there does not excite that mode.{on}",
    )]
    n_res = summary["mesh_resolved_flexible_modes"]
    figures.append(Figure(
        draw(fdir / "modes_frequencies.png", plot_frequencies, modes, wet, n_res),
        f"Natural frequencies of flexible modes 1 to {n_res}, dry and wet (heave and pitch: "
        "0 Hz)" + ("; crosses: analytic uniform free-free beam." if summary["analytic_hz"]
                   else "."),
    ))
    if conv is not None:
        figures.append(Figure(
            draw(fdir / "modes_convergence.png", plot_convergence, conv),
            f"Relative error of flexible modes 1 to {conv.reference_hz.size} against element "
            f"count (reference: {conv.reference}); Hermite cubics converge as h^4.",
        ))
    for t in tables:
        if t.csv:
            write_text(tdir / t.csv, t.to_csv())
    return figures
