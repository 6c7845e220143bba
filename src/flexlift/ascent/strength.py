"""Shear force and bending moment along the structure during the ascent (docs/theory/strength.md#dynamic-strength).

From the loop's strength snapshots (modal state and accelerations, holding forces, gas
volumes, slings, current, noise), the loads on a fine grid along the hull come from the same
laws the simulation integrates (:mod:`flexlift.physics`): submerged weight, inertia of the
structural and added mass, hull drag, seabed contact, the released suction, the force noise,
the internal bags' buoyancy over their spans; and point loads: the external bags' buoyancy
with their drag, and the point masses with their inertia. Shear and moment follow by statics
(:func:`flexlift.loads.strength.shear_moment`).

The seabed's contact and released suction are taken as the loop applies them: at its strips
(:func:`flexlift.ascent.plant.strip_points`), each strip's force spread over its cell (the
cells tile the structure, a cell as long as the strip's quadrature weight; their edges are
jumps of the grid) as a linear load with the strip's force as resultant and the strip's point
as centroid. So the loads have exactly the force and moment the simulation applied, also
where a stiff contact spring changes from strip to strip (a held stretch beside a lifted one).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexlift._jit import jit
from flexlift.loads.strength import shear_moment
from flexlift.physics import gas, hydro, seabed

#: most points of the stored shear and moment along the structure (fine meshes are sampled
#: more coarsely)
MAX_POINTS = 1001
#: the statics are integrated on up to this many times as many points (kept: every so many)
MAX_REFINE = 4
#: grid points per half-wave of the highest retained flexible mode: the loads of the
#: retained modes (inertia, drag) are smooth on this scale, and sampled less finely the
#: statics no longer close (the staged pipeline's 40 modes on 1,000 points: a closing moment
#: of 10 % of the largest; on 4,000: 0.6 %). The finer grid is only integrated on; the
#: stored values are those at the coarser grid's points.
POINTS_PER_HALF_WAVE = 100
#: values (snapshots x grid points) evaluated at once: bounds the temporary arrays of long runs
#: on fine grids to about 2 MB each (a dozen at a time); the tanker's 462 snapshots on 445
#: points are one chunk (at 0.25 MB each, six: 0.6 ms more per run in Python's calls)
CHUNK_VALUES = 262_144


def strip_cells(plant) -> np.ndarray:
    """Edges [m] (ns + 1,) of the strips' cells: each strip's quadrature weight laid end to
    end from the aft end."""
    return np.concatenate([[0.0], np.cumsum(plant.strips.weight)])


def strength_grid(plant) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`plant_grid` of ``plant``, kept per process for the last few grids asked, by
    the values it is built from (:func:`grid_key`): a run's strength and seabed profile, and
    the next cases of a sweep, ask again with the same hull and bags even when the case's
    plant is a new one (a varied valve or breakout time rebuilds the plant, not its grid)."""
    key = grid_key(plant)
    grid = _GRIDS.get(key)
    if grid is None:
        grid = plant_grid(plant)
        for a in grid:
            a.flags.writeable = False  # shared by the runs of the plant
        _GRIDS[key] = grid
        while len(_GRIDS) > GRIDS_KEPT:
            _GRIDS.pop(next(iter(_GRIDS)))
    return grid


def grid_key(plant) -> tuple:
    """Everything :func:`plant_grid` reads of ``plant``, exactly (floats by their bits)."""
    hull = plant.hull
    spans = tuple(None if s is None else tuple(float(e).hex() for e in s) for s in plant.spans)
    weight = np.ascontiguousarray(plant.strips.weight, dtype=float)
    return (float(hull.length).hex(), int(hull.n_elements), int(plant.modal.nr), spans,
            weight.shape, weight.tobytes())


#: strength grids kept per process (their keys: :func:`grid_key`), oldest first
GRIDS_KEPT = 4
_GRIDS: dict = {}


def plant_grid(plant) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Grid x [m] along the structure to integrate the statics on (internal bags' span ends
    and the strips' cell edges doubled: the jumps of their loads), the evaluation points just
    aft/forward of them [m], and the indices of the points whose values are stored: an even
    grid of up to :data:`MAX_POINTS` (8 per element) and the span ends; the integration grid
    refines it up to :data:`MAX_REFINE` times for :data:`POINTS_PER_HALF_WAVE`."""
    hull = plant.hull
    L = hull.length
    n_out = min(8 * hull.n_elements, MAX_POINTS - 1)
    n_half_waves = plant.modal.nr - 1  # the highest flexible mode's (n + 1 nodes)
    refine = int(np.clip(math.ceil(POINTS_PER_HALF_WAVE * n_half_waves / n_out), 1, MAX_REFINE))
    base = np.linspace(0.0, L, n_out * refine + 1)
    spans = {float(e) for s in plant.spans if s is not None for e in s if 0 < e < L}
    cells = {float(e) for e in strip_cells(plant)[1:-1] if 0 < e < L}
    ends = sorted(spans | cells)
    x = np.sort(np.concatenate([base, ends, ends]))
    side = np.zeros_like(x)
    stored = np.zeros(x.size, dtype=bool)
    for e in ends:  # the points np.isclose(x, e) (x sorted: a run of them, found by bisection)
        tol = 1e-8 + 1e-5 * abs(e)
        lo, hi = np.searchsorted(x, e - 2.0 * tol), np.searchsorted(x, e + 2.0 * tol, "right")
        k = lo + np.flatnonzero(np.abs(x[lo:hi] - e) <= tol)
        side[k[0]], side[k[-1]] = -1.0, 1.0
        stored[k] = e in spans
    on_base = np.searchsorted(x, base[::refine])  # the first of any equal values
    stored[on_base] = True
    return x, np.clip(x + side * 1e-9 * L, 0.0, L), np.flatnonzero(stored)


@dataclass(frozen=True)
class _Grid:
    """What the line loads need at the grid points, computed once per run."""

    psi: np.ndarray  # (nx, nr) retained mode shapes
    weight: np.ndarray  # (nx,) submerged weight per length [N/m]
    mass: np.ndarray  # (nx,) structural plus added mass per length [kg/m]
    drag: np.ndarray  # (nx,) 1/2 rho C_D B [kg/m^2]
    cell: np.ndarray  # (nx,) the strip whose cell holds each point
    spread: np.ndarray  # (nx,) line load there per unit line load of that strip [-]

    @classmethod
    def of(cls, plant, xe: np.ndarray) -> _Grid:
        hull = plant.hull
        el = hull.element_of(xe)
        m = hull.mass_per_length[el]
        xs = plant.strip_x
        edges = strip_cells(plant)
        cell = np.clip(np.searchsorted(edges, xe, side="right") - 1, 0, xs.size - 1)
        mid, wid = 0.5 * (edges[cell] + edges[cell + 1]), plant.strips.weight[cell]
        spread = 1.0 + 12.0 * (xs[cell] - mid) * (xe - mid) / wid**2  # centroid at the strip
        return cls(plant.modes.shape_at(xe)[:, : plant.modal.nr],
                   hull.wet_weight_per_length(plant.gravity, plant.seawater_density,
                                              plant.steel_density)[el],
                   m + plant.mass_line, np.interp(xe, xs, plant.strips.drag), cell, spread)


def line_loads(plant, xe: np.ndarray, snaps: dict, grid: _Grid | None = None) -> np.ndarray:
    """Line loads [N/m] (nt, nx) at points ``xe`` [m] in every snapshot (up positive);
    ``snaps`` holds the snapshot arrays stacked over time (see
    :func:`flexlift.ascent.result.snapshots`)."""
    G = grid or _Grid.of(plant, xe)
    v, acc = snaps["v"] @ G.psi.T, snaps["a"] @ G.psi.T
    q = np.empty_like(v)
    _weight_inertia_drag_seabed(G.weight, G.mass, acc, v, np.ascontiguousarray(
        snaps["current"], dtype=float), G.drag, seabed_loads(plant, snaps), G.cell, G.spread, q)
    if np.any(snaps["noise"]):
        q += np.array([np.interp(xe, plant.strip_x, row) for row in snaps["noise"]])
    for i, span in enumerate(plant.spans):
        if span is not None:
            lift = gas.buoyancy(snaps["V"][:, i], plant.bags.rho_g) * snaps["attached"][:, i]
            # added at the span's points only (an outer product with the span's mask added
            # zeros over the whole grid, seven passes for seven bags)
            cols = np.flatnonzero((xe >= span[0]) & (xe <= span[1]))
            q[:, cols] += (lift / (span[1] - span[0]))[:, None]
    return q


@jit
def _weight_inertia_drag_seabed(weight, mass, acc, v, current, coeff, bed, cell, spread, q):
    """q (nt, nx) = -weight - mass acc + drag(v - current, coeff) + bed[:, cell] spread, each
    value's operations in numpy's order for those arrays (the same numbers), in one pass
    (the arrays' expressions made eight passes over the grid and their temporaries)."""
    for r in range(q.shape[0]):
        for j in range(q.shape[1]):
            x = -weight[j] - mass[j] * acc[r, j]
            x = x + hydro.drag(v[r, j] - current[r], coeff[j])
            q[r, j] = x + bed[r, cell[j]] * spread[j]


def seabed_loads(plant, snaps: dict) -> np.ndarray:
    """Line loads [N/m] (nt, ns) of the seabed at the loop's strips in every snapshot: the
    contact (tension-capable where the strip's group is held) and the released suction."""
    w, v = snaps["q"] @ plant.strips.shape.T, snaps["v"] @ plant.strips.shape.T
    # C order always: numpy's layout of the indexed array varies with its shape, and each
    # layout is another compile of the law (1 s, in a sweep's worker mid-sweep)
    held = np.ascontiguousarray(~snaps["sep"][:, plant.strips.group])
    q = seabed.contact_load(w, v, plant.strips.contact_k, plant.strips.contact_c, held)
    return q - np.where(held, 0.0, snaps["H"][:, plant.strips.group] * plant.strips.hold)


def point_loads(plant, snaps: dict) -> list[tuple[float, np.ndarray]]:
    """(x [m], force [N] per snapshot) of the external bags and the point masses."""
    hull = plant.hull
    out = []
    zd = snaps["v"] @ plant.bags.shape.T  # (nt, nb) bag speeds
    for i in np.flatnonzero(plant.external):
        F = (gas.buoyancy(snaps["V"][:, i], plant.bags.rho_g)
             + hydro.drag(zd[:, i] - snaps["current"], plant.bags.drag[i])) * snaps["attached"][:, i]
        out.append((float(plant.x_point[i]), F))
    if np.any(hull.point_masses > 0):
        acc = snaps["a"] @ plant.modes.displacement[:, : plant.modal.nr].T
        for j, mp in enumerate(hull.point_masses):
            if mp > 0:
                wt = hydro.submerged_weight(mp, plant.gravity, plant.seawater_density,
                                            plant.steel_density)
                out.append((float(hull.x_nodes[j]), -wt - mp * acc[:, j]))
    return out


def strength(plant, snaps: dict):
    """(x [m], V [N] (nt, nx), M [N m] (nt, nx)) along the structure at the snapshots
    (``snaps``: the snapshot arrays stacked over time, names as in the loop's record)."""
    x, xe, keep = strength_grid(plant)
    nt = snaps["t"].size
    V, M = np.empty((nt, keep.size)), np.empty((nt, keep.size))
    grid = _Grid.of(plant, xe)
    chunk = max(1, CHUNK_VALUES // x.size)
    for a in range(0, nt, chunk):
        part = {k: v[a:a + chunk] for k, v in snaps.items()}
        V[a:a + chunk], M[a:a + chunk] = shear_moment(
            x, line_loads(plant, xe, part, grid), point_loads(plant, part), keep,
            integrate=compiled_integrals)
    return x[keep], V, M


def compiled_integrals(x: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`flexlift.loads.strength.line_integrals` of line loads ``q`` (nt, nx), compiled:
    the same sums in the same order (the same numbers), without its temporary arrays."""
    q = np.ascontiguousarray(q, dtype=float)
    Vq, Mq = np.empty_like(q), np.empty_like(q)
    _integrals(np.ascontiguousarray(x, dtype=float), q, Vq, Mq)
    return Vq, Mq


@jit
def _integrals(x, q, Vq, Mq):
    for r in range(q.shape[0]):
        Vq[r, 0] = Mq[r, 0] = 0.0
        for j in range(x.size - 1):
            h = x[j + 1] - x[j]
            dV = 0.5 * h * (q[r, j] + q[r, j + 1])
            dM = Vq[r, j] * h + h * h * (q[r, j] / 3.0 + q[r, j + 1] / 6.0)
            # a running sum's first term is the term itself (-0.0 stays -0.0), as numpy's
            Vq[r, j + 1] = dV if j == 0 else Vq[r, j] + dV
            Mq[r, j + 1] = dM if j == 0 else Mq[r, j] + dM


def seabed_profile(plant, snaps: dict) -> dict:
    """Where the structure lies on the seabed and how steep it is, at every snapshot.

    A strip is *grounded* while its group is held or it is within the plant's liftoff
    clearance (5 cm) of the seabed. Returns ``grounded_from``, ``grounded_to`` (nt,) [m]: the
    aft-most and forward-most grounded points (the touchdown points of a structure peeled
    from one end; nan when nothing is grounded), ``grounded_length`` (nt,) [m], and the slope
    of the retained modes on the strength grid as an angle, arctan(dw/dx): ``x`` (nx,) [m],
    ``slope`` (nt, nx) [rad]."""
    from flexlift.ascent.plant import slope_at

    w = snaps["q"] @ plant.strips.shape.T  # (nt, ns), as the loop sees the strips
    grounded = (w < plant.seabed.liftoff_clearance) | ~snaps["sep"][:, plant.strips.group]
    xs = plant.strip_x
    any_ = grounded.any(axis=1)
    first = np.where(any_, xs[np.argmax(grounded, axis=1)], np.nan)
    last = np.where(any_, xs[xs.size - 1 - np.argmax(grounded[:, ::-1], axis=1)], np.nan)
    x, _, keep = strength_grid(plant)
    x = x[keep]
    slope = np.arctan(snaps["q"] @ slope_at(plant.modes, x)[:, : plant.modal.nr].T)  # the angle
    return {"grounded_from": first, "grounded_to": last,
            "grounded_length": grounded @ plant.strips.weight, "x": x, "slope": slope}
