"""The modal stage (SPEC §2): frequencies and mode shapes of the hull as a free-free beam, the
nodes of its first flexible modes, and the convergence study, as data, figures and tables.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from flexlift.errors import InputError
from flexlift.output.files import write_text
from flexlift.output.stage import Figure, StageOutput, Table
from flexlift.structure.beam import assemble
from flexlift.structure.convergence import Convergence, convergence_study, is_uniform
from flexlift.structure.hull import hull_from_scenario
from flexlift.structure.modes import Modes, analytic_free_free_hz, compute_modes, mode_nodes

NAME = "modes"
NODE_MODES = 5
RATE_RANGE = (-4.5, -3.5)


def _nodes_of(modes: Modes) -> dict[str, list[int]]:
    k = min(NODE_MODES, modes.n_modes - modes.n_rigid)
    out = {}
    for j in range(1, k + 1):
        col = modes.flexible_index(j)
        out[str(col + 1)] = [n + 1 for n in mode_nodes(modes, col)]
    return out


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


def summary_of(scenario, modes: Modes, conv: Convergence | None, solver: str) -> dict:
    """The JSON summary (frequencies in Hz, nodes 1-based)."""
    hull = modes.hull
    n_flex = modes.n_modes - modes.n_rigid
    s = {
        "scenario": scenario.name,
        "elements": hull.n_elements,
        "nodes": hull.n_nodes,
        "solver": "sparse" if solver == "auto" else solver,
        "frequencies_hz": [float(f) for f in modes.frequencies_hz],
        "rigid_modes": modes.n_rigid,
        # the solver returns only the modes it resolves to SPEC section 2 (flexlift.structure.modes)
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


def _tables(summary: dict, modes: Modes) -> list[Table]:
    fa = summary["analytic_hz"] or []
    rows = []
    for i, f in enumerate(summary["frequencies_hz"]):
        kind = ("heave" if i == 0 else "pitch") if i < modes.n_rigid else "flexible"
        j = i - modes.n_rigid
        ref = fa[j] if 0 <= j < len(fa) else None
        nodes = summary["mode_nodes"].get(str(i + 1))
        rows.append([i + 1, kind, round(f, 6), None if ref is None else round(ref, 6),
                     None if nodes is None else " ".join(map(str, nodes))])
    tables = [Table(
        "Natural frequencies (dry) and nodes of the first flexible modes",
        ["mode", "kind", "frequency [Hz]", "analytic uniform beam [Hz]", "nodes (1-based)"],
        rows,
        f"{modes.hull.n_elements} Hermite cubic elements, consistent mass; rigid modes exact.",
    )]
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
            ["elements"] + [f"f{j + 1} [Hz]" for j in range(n)] + ["max |rel. error|"],
            rows,
            f"Reference: {conv['reference']}; error ~ elements^p, p = -4 expected.",
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
    conv = convergence_study(base) if convergence else None
    summary = summary_of(scenario, modes, conv, solver)
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
        from flexlift.output.plots._style import save
        from flexlift.output.plots.modes import plot_convergence, plot_frequencies, plot_mode_shapes

        out = Path(out)
        fdir, tdir = out / "figures", out / "tables"
        k = min(NODE_MODES, modes.n_modes - modes.n_rigid)
        figures.append(Figure(
            save(plot_mode_shapes(modes, k), fdir / "modes_shapes.png"),
            f"First {k} flexible mode shapes (unit peak) with the beam nodes nearest their "
            "zero crossings marked: lift points there do not excite that mode.",
        ))
        figures.append(Figure(
            save(plot_frequencies(modes), fdir / "modes_frequencies.png"),
            "Natural frequency against mode number (modes 1-2 rigid)"
            + ("; crosses: analytic uniform free-free beam." if summary["analytic_hz"] else "."),
        ))
        if conv is not None:
            figures.append(Figure(
                save(plot_convergence(conv), fdir / "modes_convergence.png"),
                f"Relative error of the first flexible frequencies against element count "
                f"(reference: {conv.reference}); Hermite cubics converge as h^4.",
            ))
        write_text(tdir / "modes_frequencies.csv", tables[0].to_csv())
        if conv is not None:
            write_text(tdir / "modes_convergence.csv", tables[1].to_csv())
    return StageOutput(name=NAME, summary=summary, figures=figures, tables=tables,
                       criteria=criteria)
