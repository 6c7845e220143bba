"""Hermite cubic Euler-Bernoulli beam elements and their sparse assembly.

DOFs are ordered node by node, ``[w_0, theta_0, w_1, theta_1, ...]``: vertical displacement w
(positive up) [m] and rotation theta = dw/dx (positive bow-up) [rad]; node 0 is the aft end.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from flexlift.errors import InputError
from flexlift.structure.hull import Hull


def element_stiffness(EI: float, l: float) -> np.ndarray:
    """Stiffness matrix of one element, EI [N m^2], length l [m] (4x4)."""
    return (EI / l**3) * np.array(
        [
            [12.0, 6 * l, -12.0, 6 * l],
            [6 * l, 4 * l * l, -6 * l, 2 * l * l],
            [-12.0, -6 * l, 12.0, -6 * l],
            [6 * l, 2 * l * l, -6 * l, 4 * l * l],
        ]
    )


def element_mass(m: float, l: float) -> np.ndarray:
    """Consistent mass matrix of one element, mass per length m [kg/m], length l [m] (4x4)."""
    return (m * l / 420.0) * np.array(
        [
            [156.0, 22 * l, 54.0, -13 * l],
            [22 * l, 4 * l * l, 13 * l, -3 * l * l],
            [54.0, 13 * l, 156.0, -22 * l],
            [-13 * l, -3 * l * l, -22 * l, 4 * l * l],
        ]
    )


def shape_functions(xi: np.ndarray, l: float) -> np.ndarray:
    """Hermite shape functions at local coordinates xi in [0, 1] (shape (len(xi), 4)).

    w(xi) = N @ [w_a, theta_a, w_b, theta_b] for an element of length l [m].
    """
    xi = np.asarray(xi, dtype=float)
    return np.stack(
        [
            1 - 3 * xi**2 + 2 * xi**3,
            l * (xi - 2 * xi**2 + xi**3),
            3 * xi**2 - 2 * xi**3,
            l * (-(xi**2) + xi**3),
        ],
        axis=-1,
    )


def element_deformation(l: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """The factor form of the element stiffness: ``element_stiffness(EI, l) = EI/l^3 G^T C G``.

    Returns (G, C) for the scaled DOFs [w_a, l theta_a, w_b, l theta_b]: G (2x4) maps them to
    the element's two deformations, d_1 = w_a + l theta_a - w_b and d_2 = w_a - w_b + l theta_b
    (end rotations relative to the chord, times l), and C = [[4, 2], [2, 4]]. Rigid motions
    (w = a + b x, theta = b) give d = 0 exactly, which is what keeps the rigid modes clean.
    """
    del l  # the scaled form is independent of the length
    G = np.array([[1.0, 1.0, -1.0, 0.0], [1.0, 0.0, -1.0, 1.0]])
    C = np.array([[4.0, 2.0], [2.0, 4.0]])
    return G, C


def _assemble(blocks: np.ndarray, n_el: int) -> sp.csc_matrix:
    """Sum per-element 4x4 ``blocks`` (n_el, 4, 4) into a sparse global matrix."""
    dofs = 2 * np.arange(n_el)[:, None] + np.arange(4)[None, :]
    rows = np.repeat(dofs, 4, axis=1).ravel()
    cols = np.tile(dofs, (1, 4)).ravel()
    n = 2 * (n_el + 1)
    return sp.csc_matrix((blocks.ravel(), (rows, cols)), shape=(n, n))


@dataclass(frozen=True)
class Beam:
    """Assembled global matrices of a hull.

    K : sparse (N, N) — stiffness [N/m, N, N m per DOF pair]
    M : sparse (N, N) — mass, consistent plus point masses [kg, kg m, kg m^2]
    hull : Hull — the structure they came from
    """

    K: sp.csc_matrix
    M: sp.csc_matrix
    hull: Hull

    @property
    def n_dof(self) -> int:
        return self.K.shape[0]


def dof_scale(hull: Hull) -> np.ndarray:
    """Per-DOF scale s with [w, theta] = s * [w, l theta]: 1 for displacements, 1/l for
    rotations (l the element length [m]). With it K and M have entries of one size per block."""
    s = np.ones(2 * hull.n_nodes)
    s[1::2] = 1.0 / hull.element_length
    return s


def deformation_matrix(hull: Hull) -> sp.csr_matrix:
    """Sparse D (2 n_el x N) of 0/+-1 mapping the scaled DOFs [w, l theta] to element
    deformations; the scaled stiffness is D^T W D with W = blockdiag(EI_e / l^3 C)."""
    n = hull.n_elements
    G, _ = element_deformation()
    rows = np.repeat(np.arange(2 * n).reshape(n, 2), 4, axis=1).ravel()
    cols = np.tile((2 * np.arange(n)[:, None] + np.arange(4)[None, :]), (1, 2)).ravel()
    vals = np.tile(G.ravel(), n)
    return sp.csr_matrix((vals, (rows, cols)), shape=(2 * n, 2 * hull.n_nodes))


def assemble(hull: Hull, extra_mass_per_length: np.ndarray | float = 0.0) -> Beam:
    """Assemble K and M of ``hull`` (sparse CSC, banded with half-bandwidth 3).

    extra_mass_per_length : added mass (e.g. hydrodynamic) per element or uniform [kg/m]
    """
    n = hull.n_elements
    l = hull.element_length
    ke = element_stiffness(1.0, l)
    me = element_mass(1.0, l)
    m = hull.mass_per_length + np.broadcast_to(np.asarray(extra_mass_per_length, float), (n,))
    K = _assemble(hull.EI[:, None, None] * ke[None], n)
    M = _assemble(m[:, None, None] * me[None], n)
    if np.any(hull.point_masses):
        diag = np.zeros(2 * (n + 1))
        diag[0::2] = hull.point_masses
        M = (M + sp.diags(diag)).tocsc()
    return Beam(K=K, M=M, hull=hull)


def element_of(hull: Hull, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(element index, local coordinate xi in [0, 1]) of positions ``x`` [m] along ``hull``."""
    l = hull.element_length
    e = np.clip(np.floor(x / l).astype(int), 0, hull.n_elements - 1)
    return e, x / l - e


def point_load_vector(hull: Hull, x: float, force: float | np.ndarray = 1.0) -> np.ndarray:
    """Consistent nodal loads of a point force at any position.

    hull : the beam (equal elements)
    x : position of the force, 0..L [m]
    force : upward force [N]; an array gives one vector per value (shape force.shape + (N,))
    returns : ndarray (..., 2 (n + 1)) — nodal forces [N] and moments [N m]
    """
    L = hull.length
    if not (np.isfinite(x) and -1e-9 * L <= x <= L * (1 + 1e-9)):
        raise InputError("point load x", x, f"must lie on the hull, 0..{L:g} m")
    x = float(np.clip(x, 0.0, L))
    e, xi = element_of(hull, np.array([x]))
    f = np.zeros(2 * hull.n_nodes)
    f[2 * e[0] : 2 * e[0] + 4] = shape_functions(xi, hull.element_length)[0]
    return np.asarray(force, dtype=float)[..., None] * f
