"""What a failed numerical check of the analysis means, its number, and what to do.

The stages check their own numerics (``StageOutput.criteria``: the modes' normalisation, the
mesh convergence, the reduction's static gain, the fuzzy table's interpolation error, the
still-water stress). A failed one turns the report's verdict red; :func:`explain_check` gives
the sentence the verdict shows for it. Each criterion is named where its stage sets it
(``grep -rn CRITERION src/flexlift/stages``).
"""

from __future__ import annotations


def _get(summary: dict, *path, default=None):
    v = summary
    for p in path:
        if not isinstance(v, dict) or p not in v:
            return default
        v = v[p]
    return v


def _num(v, fmt: str = ".3g") -> str:
    return "?" if v is None else format(v, fmt)


def _surface(s: dict) -> str:
    err, grid = _get(s, "surface", "max_error"), _get(s, "surface", "grid")
    src = s.get("source", "the supervisor")
    return (f"the supervisor ({src}) sampled on a {grid} x {grid} table and interpolated "
            f"differs from exact inference by up to {_num(err)} in u (of [-1, 1]), more than "
            "0.01: its sets or rules change faster than a table cell, so a tabulated supervisor "
            "is not the file's. Widen the narrowest sets or smooth the rules (flexlift fuzzy "
            "--fis FILE --grid N shows the surface), or check the ascent with exact inference "
            "(Python: simulate(scenario, engine=\"exact\")), which the 201 x 201 table of the "
            "loop approximates")


def _symmetry(s: dict) -> str:
    return (f"the built-in rule base is not odd-symmetric: u(-e, -de) + u(e, de) reaches "
            f"{_num(s.get('symmetry_error'))} (at most 1e-9): the supervisor pushes one way "
            "harder than the other. A changed control.supervisor operator or resolution does "
            "this; restore them, or accept the asymmetry knowingly")


def _mass(s: dict) -> str:
    return (f"the modes are not mass-orthonormal: error {_num(s.get('mass_orthonormality_error'))}"
            " (at most 1e-8): the eigen-solution is inaccurate, often from a mass or stiffness "
            "spread over many orders of magnitude; try the dense solver or fewer elements")


def _rigid(s: dict) -> str:
    return (f"the rigid-body modes are not clean: residual {_num(s.get('rigid_mode_residual'))} "
            "(at most 1e-10): the free-free beam has a spurious constraint or a near-zero "
            "flexible mode; check hull.bending_stiffness_Nm2 and the point masses")


def _rate(s: dict) -> str:
    rates = _get(s, "convergence", "rates", default=[]) or []
    shown = ", ".join(_num(r) for r in rates if r is not None)
    return (f"the frequencies do not converge at the Hermite element's rate h^4: rates {shown} "
            "(between -4.5 and -3.5): the mesh is too coarse for the retained modes or the "
            "section properties jump between elements; raise hull.elements")


def _mdc(s: dict) -> str:
    return ("the mdc reduction does not keep the static gain of every bag's input exactly: the "
            "reduced model's response to a steady lift differs from the full one's; keep more "
            "modes (simulation.retained_flexible_modes) and look at the reduce stage's gains table")


def _stress(s: dict) -> str:
    u = _get(s, "static_stress", "max_utilisation")
    return (f"with every bag at full lift in still water the hull girder stress reaches "
            f"{_num(u)} of the allowable (at most 1): the plan overloads the hull; spread the lift "
            "over more lift points, or lower the bags' lift (the loads stage's strength table "
            "says where)")


EXPLAIN = {
    ("fuzzy", "surface_interpolation_error_below_0.01"): _surface,
    ("fuzzy", "surface_odd_symmetric"): _symmetry,
    ("modes", "mass_normalised"): _mass,
    ("modes", "rigid_modes_clean"): _rigid,
    ("modes", "convergence_rate_h4"): _rate,
    ("reduce", "mdc_static_gain_exact"): _mdc,
    ("loads", "static_stress_within_allowable"): _stress,
}


def explain_check(stage: str, criterion: str, summary: dict) -> str:
    """One sentence for a failed numerical check ``criterion`` of ``stage`` (its summary
    gives the number); a check without its own sentence says where it is set."""
    how = EXPLAIN.get((stage.split(":", 1)[0], criterion))
    if how is None:
        return (f"the {stage} stage's check {criterion} failed (its stage sets it: grep -rn "
                f"'{criterion}' in flexlift's stages; the stage's summary has its numbers)")
    return how(summary if isinstance(summary, dict) else {})
