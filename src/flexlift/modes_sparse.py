"""Lowest flexible modes of large free-free beams, in O(N) memory and time per iteration.

The trap with thousands of short elements: K's entries grow like EI / l^3 (~1e20 at 20,000
elements of the tanker) while its smallest flexible eigenvalues stay ~1e3, so the assembled
K and any factorisation of K + sigma M carry round-off of ~eps * 1e20 ~ 1e4 — as large as the
eigenvalues wanted. The rigid modes come out polluted and the low flexible ones lose digits.

The default method here ("flexibility") never forms or factorises K. It uses the factor form
of the Hermite element, ``K = S^-1 D^T W D S^-1`` (:func:`flexlift.beam.deformation_matrix`):

* S scales the DOFs (rotations times the element length, so every DOF is a length);
* D (entries 0, +-1) maps the DOFs to two deformations per element; its null space is
  exactly the rigid heave and pitch, so they are removed exactly, not by round-off;
* W = blockdiag(EI_e / l^3 [[4, 2], [2, 4]]) = L L^T is block diagonal.

With the deformations d as unknowns, the flexible modes in the M-orthogonal complement of
the rigid modes R are ``y = P d`` where P integrates the deformations along the beam (two
cumulative sums, "statics") and then removes the rigid part M-orthogonally. The problem
``W d = lambda P^T M P d`` becomes the symmetric standard problem

    A z = mu z,   A = L^-1 P^T M P L^-T,   mu = 1 / lambda,   d = L^-T z,

whose largest eigenvalues are the lowest flexible modes. Lanczos (ARPACK ``eigsh``) finds
them with a matrix-vector product of a few vectorised passes over the beam and no
factorisation: the flexibility operator is as well separated as a shift-invert at zero,
without its ill conditioning. This is the beam's flexibility (compliance) formulation.

"shift-invert" (kept for models whose K is not the bare hull's, and for comparison) uses the
same scaling, factorises K + sigma M (sigma > 0) with a sparse LU and works in the
M-orthogonal complement of R.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexlift.beam import Beam, assemble, dof_scale
from flexlift.errors import SimulationError

log = logging.getLogger(__name__)

_SQRT3 = np.sqrt(3.0)
#: below this many flexible DOFs the reduced operator is formed densely
_DENSE_BELOW = 64


def _inner(A, B):
    """A^T B for tall, skinny A (N, 2) and B (N, k), without BLAS: these products are memory
    bound, and a multithreaded BLAS under CPU contention makes them 10x slower."""
    return np.einsum("ni,nk->ik", A, B)


def _outer(A, C):
    """A @ C for A (N, 2), C (2, k), without BLAS (see :func:`_inner`)."""
    return np.einsum("ni,ik->nk", A, C)


class _Flexibility:
    """The operator A = L^-1 P^T M P L^-T of the module docstring, for blocks of vectors."""

    def __init__(self, beam: Beam, R: np.ndarray):
        hull = beam.hull
        self.n = hull.n_elements
        self.s = dof_scale(hull)
        M = beam.M.tocsr(copy=True)  # scaled mass S M S [kg], scaling the entries in place
        M.data *= self.s[np.repeat(np.arange(M.shape[0]), np.diff(M.indptr))]
        M.data *= self.s[M.indices]
        self.M = M
        self.R = R / self.s[:, None]  # scaled rigid modes, still M-orthonormal
        self.MR = np.asarray(self.M @ self.R)
        c = hull.EI / hull.element_length**3  # [N/m]
        # overall scale: lambda_ref ~ the first flexible eigenvalue, so mu ~ 1
        m_bar = hull.total_mass / hull.length
        self.lam_ref = (4.73 / hull.length) ** 4 * float(np.mean(hull.EI)) / m_bar
        self.rc = np.sqrt(c)[:, None]  # sqrt of the element stiffness scale

    @property
    def size(self) -> int:
        return 2 * self.n

    # d <-> z (block Cholesky factor of W)
    def _LinvT(self, z):  # d = L^-T z
        d2 = z[1::2] / (_SQRT3 * self.rc)
        d1 = (z[0::2] / self.rc - d2) / 2.0
        return d1, d2

    def _Linv(self, g1, g2):  # q = L^-1 g
        q = np.empty((2 * self.n, g1.shape[1]))
        q[0::2] = g1 / (2.0 * self.rc)
        q[1::2] = (g2 / self.rc - q[0::2]) / _SQRT3
        return q

    def integrate(self, d1, d2):
        """P0: deformations -> scaled DOFs with w_0 = theta_0 = 0 (two cumulative sums)."""
        k = d1.shape[1]
        zero = np.zeros((1, k))
        t = np.vstack([zero, np.cumsum(d2 - d1, axis=0)])  # l theta at the nodes
        w = np.vstack([zero, np.cumsum(t[:-1] - d1, axis=0)])
        y = np.empty((2 * (self.n + 1), k))
        y[0::2] = w
        y[1::2] = t
        return y

    def integrate_T(self, u):
        """P0^T: the adjoint of :meth:`integrate` (reverse cumulative sums)."""

        def cT(v):  # (C^T v)_e = sum_{k > e} v_k
            return np.cumsum(v[:0:-1], axis=0)[::-1]

        uw, ut = u[0::2], u[1::2]
        cw = cT(uw)  # (n, k)
        ga = cT(ut) + cT(np.vstack([cw, np.zeros((1, u.shape[1]))]))
        return -ga - cw, ga  # gradients for d1, d2

    def project(self, y):
        """Remove the rigid part M-orthogonally."""
        return y - _outer(self.R, _inner(self.MR, y))

    def modes(self, z):
        """Scaled-back mode shapes (original DOFs) of the eigenvectors z."""
        return self.s[:, None] * self.project(self.integrate(*self._LinvT(z)))

    def matmat(self, z):
        z = np.asarray(z, dtype=float)
        if z.ndim == 1:
            return self.matmat(z[:, None])[:, 0]
        y = self.integrate(*self._LinvT(z))
        u = np.asarray(self.M @ y) - _outer(self.MR, _inner(self.MR, y))  # P^T M P, projected
        return self._Linv(*self.integrate_T(u)) * self.lam_ref


def _k_matches_hull(beam: Beam) -> bool:
    """True when beam.K is the bare hull's stiffness (no springs or extra terms), whose
    factor form D^T W D the flexibility method uses."""
    K0 = assemble(beam.hull).K
    diff = abs(beam.K - K0).max() if beam.K.shape == K0.shape else np.inf
    return bool(diff <= 1e-12 * abs(K0).max())


def flexibility_flexible(
    beam: Beam, R: np.ndarray, n_flex: int, tol: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Lowest ``n_flex`` flexible eigenvalues [rad^2/s^2] and modes (N, n_flex), ascending,
    by Lanczos on the flexibility operator (module docstring)."""
    op = _Flexibility(beam, R)
    m = op.size
    if n_flex > m:
        raise ValueError(f"n_flex {n_flex} > {m} flexible modes of this mesh")
    if m <= max(_DENSE_BELOW, 2 * n_flex + 2):
        A = op.matmat(np.eye(m))
        mu, Z = sla.eigh(0.5 * (A + A.T), subset_by_index=[m - n_flex, m - 1])
    else:
        lin = spla.LinearOperator((m, m), matvec=op.matmat, matmat=op.matmat, dtype=float)
        v0 = np.cos(np.arange(m) * 0.7 + 0.3)  # deterministic start vector
        ncv = min(m, max(2 * n_flex + 1, n_flex + 20))
        mu, Z = spla.eigsh(lin, k=n_flex, which="LA", v0=v0, ncv=ncv, tol=tol)
    order = np.argsort(mu)[::-1]
    mu, Z = mu[order], Z[:, order]
    lam = op.lam_ref / mu
    return lam, op.modes(Z)


def shift_invert_flexible(
    beam: Beam, R: np.ndarray, n_flex: int, tol: float = 0.0, sigma: float | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Lowest flexible modes by scaled, deflated shift-invert Lanczos with a sparse LU of
    K + sigma M (sigma > 0 [rad^2/s^2], default the uniform-beam estimate of
    the first flexible eigenvalue). Works for any K whose null space is R."""
    hull = beam.hull
    s = sp.diags(dof_scale(hull))
    k_ref = float(np.mean(hull.EI)) / hull.element_length**3
    m_ref = hull.total_mass / hull.length * hull.element_length
    Ks = (s @ beam.K @ s).tocsc() / k_ref
    Ms = (s @ beam.M @ s).tocsc() / m_ref
    Rs = R / dof_scale(hull)[:, None] * np.sqrt(m_ref)  # Ms-orthonormal
    MR = np.asarray(Ms @ Rs)
    lam_scale = k_ref / m_ref
    if sigma is None:
        sigma = (4.73 / hull.length) ** 4 * float(np.mean(hull.EI)) / (
            hull.total_mass / hull.length
        )
    sig = sigma / lam_scale
    try:
        lu = spla.splu((Ks + sig * Ms).tocsc())
    except RuntimeError as exc:  # the trap: K + sigma M singular to working precision
        raise SimulationError(
            f"shift-invert at sigma = {sigma:.3g} rad^2/s^2 failed ({exc}) on "
            f"{hull.n_elements} elements; use the flexibility method"
        ) from None
    n = Ks.shape[0]

    def op(b):  # (K + sigma M)^-1 b, in the M-orthogonal complement of R
        b = b - MR @ (Rs.T @ b)
        x = lu.solve(np.asarray(b))
        return x - Rs @ (MR.T @ x)

    opinv = spla.LinearOperator((n, n), matvec=op, dtype=float)
    v0 = np.cos(np.arange(n) * 0.7 + 0.3)
    v0 = v0 - Rs @ (MR.T @ v0)
    ncv = min(n, max(2 * n_flex + 1, n_flex + 20))
    # eigsh's OPinv is [K - sigma' M]^-1, so sigma' = -sig for our K + sig M
    nu, Y = spla.eigsh(
        Ks, k=n_flex, M=Ms, sigma=-sig, which="LM", OPinv=opinv, v0=v0, ncv=ncv, tol=tol
    )
    order = np.argsort(nu)
    lam = nu[order] * lam_scale
    Y = Y[:, order]
    Y = Y - Rs @ (MR.T @ Y)
    return lam, dof_scale(hull)[:, None] * Y


def sparse_flexible(
    beam: Beam, R: np.ndarray, n_flex: int, method: str = "auto"
) -> tuple[np.ndarray, np.ndarray]:
    """Lowest ``n_flex`` flexible eigenvalues lambda = omega^2 [rad^2/s^2] (ascending) and
    their mode shapes V (N, n_flex) in the M-orthogonal complement of the rigid modes R.

    method : "flexibility" (default when K is the hull's own stiffness), "shift-invert"
        (any K with null space R), or "auto".
    """
    if method == "auto":
        method = "flexibility" if _k_matches_hull(beam) else "shift-invert"
    log.debug("sparse modal solve: %s, %d elements, %d flexible modes", method,
              beam.hull.n_elements, n_flex)
    if method == "flexibility":
        return flexibility_flexible(beam, R, n_flex)
    if method == "shift-invert":
        return shift_invert_flexible(beam, R, n_flex)
    raise ValueError(f"method {method!r}: use 'flexibility', 'shift-invert' or 'auto'")
