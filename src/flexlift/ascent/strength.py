"""Shear force and bending moment along the structure during the ascent (SPEC §3, §8).

From the loop's strength snapshots (modal state and accelerations, holding forces, gas
volumes, slings, current, noise), the loads on a fine grid along the hull come from the same
laws the simulation integrates (:mod:`flexlift.physics`): submerged weight, inertia of the
structural and added mass, hull drag, seabed contact, the released suction, the force noise,
the internal bags' buoyancy over their spans; and point loads: the external bags' buoyancy
with their drag, and the point masses with their inertia. Shear and moment follow by statics
(:func:`flexlift.loads.strength.shear_moment`).

The seabed's contact and released suction are taken as the loop applies them: at its strips
(:func:`flexlift.ascent.plant.strip_points`), each strip's line load over its cell (the cells
tile the structure, a cell as long as the strip's quadrature weight; their edges are jumps of
the grid). So the loads integrate to exactly the forces the simulation felt, also where a stiff
contact spring changes from strip to strip (a held stretch beside a lifted one).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexlift.loads.strength import shear_moment
from flexlift.physics import gas, hydro, seabed

#: most grid points along the structure (fine meshes are sampled more coarsely)
MAX_POINTS = 1001
#: snapshots evaluated at once (bounds the temporary arrays of long runs on fine grids)
CHUNK = 64


def strip_cells(plant) -> np.ndarray:
    """Edges [m] (ns + 1,) of the strips' cells: each strip's quadrature weight laid end to
    end from the aft end."""
    return np.concatenate([[0.0], np.cumsum(plant.arrays.strip_weight)])


def strength_grid(plant) -> tuple[np.ndarray, np.ndarray]:
    """Grid x [m] along the structure (internal bags' span ends and the strips' cell edges
    doubled: the jumps of their loads) and the evaluation points just aft/forward of them [m]."""
    hull = plant.hull
    L = hull.length
    n = min(8 * hull.n_elements, MAX_POINTS - 1)
    base = np.linspace(0.0, L, n + 1)
    cells = strip_cells(plant)[1:-1]
    ends = sorted({float(e) for s in plant.spans if s is not None for e in s if 0 < e < L}
                  | {float(e) for e in cells if 0 < e < L})
    x = np.sort(np.concatenate([base, ends, ends]))
    side = np.zeros_like(x)
    for e in ends:
        k = np.flatnonzero(np.isclose(x, e))
        side[k[0]], side[k[-1]] = -1.0, 1.0
    return x, np.clip(x + side * 1e-9 * L, 0.0, L)


@dataclass(frozen=True)
class _Grid:
    """What the line loads need at the grid points, computed once per run."""

    psi: np.ndarray  # (nx, nr) retained mode shapes
    weight: np.ndarray  # (nx,) submerged weight per length [N/m]
    mass: np.ndarray  # (nx,) structural plus added mass per length [kg/m]
    drag: np.ndarray  # (nx,) 1/2 rho C_D B [kg/m^2]
    cell: np.ndarray  # (nx,) the strip whose cell holds each point

    @classmethod
    def of(cls, plant, xe: np.ndarray) -> _Grid:
        a, hull = plant.arrays, plant.hull
        el = hull.element_of(xe)
        m = hull.mass_per_length[el]
        xs = plant.strip_x
        cell = np.clip(np.searchsorted(strip_cells(plant), xe, side="right") - 1, 0, xs.size - 1)
        return cls(plant.modes.shape_at(xe)[:, : a.nr],
                   hull.wet_weight_per_length(plant.gravity, plant.seawater_density,
                                              plant.steel_density)[el],
                   m + plant.mass_line, np.interp(xe, xs, a.strip_drag), cell)


def line_loads(plant, xe: np.ndarray, snaps: dict, grid: _Grid | None = None) -> np.ndarray:
    """Line loads [N/m] (nt, nx) at points ``xe`` [m] in every snapshot (up positive);
    ``snaps`` holds the snapshot arrays stacked over time (see
    :func:`flexlift.ascent.result.snapshots`)."""
    G = grid or _Grid.of(plant, xe)
    a = plant.arrays
    w, v, acc = snaps["q"] @ G.psi.T, snaps["v"] @ G.psi.T, snaps["a"] @ G.psi.T
    q = -G.weight - G.mass * acc
    q += hydro.drag(v - snaps["current"][:, None], G.drag)
    q += seabed_loads(plant, snaps)[:, G.cell]
    if np.any(snaps["noise"]):
        q += np.array([np.interp(xe, plant.strip_x, row) for row in snaps["noise"]])
    for i, span in enumerate(plant.spans):
        if span is not None:
            lift = gas.buoyancy(snaps["V"][:, i], a.rho_g) * snaps["attached"][:, i]
            inside = (xe >= span[0]) & (xe <= span[1])
            q += np.outer(lift / (span[1] - span[0]), inside)
    return q


def seabed_loads(plant, snaps: dict) -> np.ndarray:
    """Line loads [N/m] (nt, ns) of the seabed at the loop's strips in every snapshot: the
    contact (tension-capable where the strip's group is held) and the released suction."""
    a = plant.arrays
    w, v = snaps["q"] @ a.strip_shape.T, snaps["v"] @ a.strip_shape.T
    held = ~snaps["sep"][:, a.strip_group]
    q = seabed.contact_load(w, v, a.strip_k, a.strip_c, held)
    return q - np.where(held, 0.0, snaps["H"][:, a.strip_group] * a.strip_hold)


def point_loads(plant, snaps: dict) -> list[tuple[float, np.ndarray]]:
    """(x [m], force [N] per snapshot) of the external bags and the point masses."""
    a, hull = plant.arrays, plant.hull
    out = []
    zd = snaps["v"] @ a.bag_shape.T  # (nt, nb) bag speeds
    for i in np.flatnonzero(plant.external):
        F = (gas.buoyancy(snaps["V"][:, i], a.rho_g)
             + hydro.drag(zd[:, i] - snaps["current"], a.bag_drag[i])) * snaps["attached"][:, i]
        out.append((float(plant.x_point[i]), F))
    if np.any(hull.point_masses > 0):
        acc = snaps["a"] @ plant.modes.displacement[:, : a.nr].T
        for j, mp in enumerate(hull.point_masses):
            if mp > 0:
                wt = hydro.submerged_weight(mp, plant.gravity, plant.seawater_density,
                                            plant.steel_density)
                out.append((float(hull.x_nodes[j]), -wt - mp * acc[:, j]))
    return out


def strength(plant, snaps: dict):
    """(x [m], V [N] (nt, nx), M [N m] (nt, nx)) along the structure at the snapshots
    (``snaps``: the snapshot arrays stacked over time, names as in the loop's record)."""
    x, xe = strength_grid(plant)
    nt = snaps["t"].size
    V, M = np.empty((nt, x.size)), np.empty((nt, x.size))
    grid = _Grid.of(plant, xe)
    for a in range(0, nt, CHUNK):
        part = {k: v[a:a + CHUNK] for k, v in snaps.items()}
        V[a:a + CHUNK], M[a:a + CHUNK] = shear_moment(x, line_loads(plant, xe, part, grid),
                                                      point_loads(plant, part))
    return x, V, M
