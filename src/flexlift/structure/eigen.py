"""Lowest flexible modes of large free-free beams, in O(N) memory and time per iteration.

The trap with thousands of short elements: K's entries grow like EI / l^3 (~1e20 at 20,000
elements of the tanker) while its smallest flexible eigenvalues stay ~1e3, so the assembled
K and any factorisation of K + sigma M carry round-off of ~eps * 1e20 ~ 1e4 — as large as the
eigenvalues wanted. The rigid modes come out polluted and the low flexible ones lose digits.

The default method here ("flexibility") never forms or factorises K. It uses the factor form
of the Hermite element, ``K = S^-1 D^T W D S^-1`` (:func:`flexlift.structure.beam.deformation_matrix`):

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

The highest modes: the eigenpairs of A are resolved to round-off of its largest eigenvalue
(mu_1 ~ 1), so mode k keeps M-orthogonality only to ~eps mu_1 / mu_k = eps lambda_k /
lambda_1. For the lowest twenty modes that is 1e-12 to 4e-11 (the more, the finer the mesh),
but all 600 modes of 300 elements reach lambda / lambda_1 ~ 6e10 and lose M-orthogonality to
5e-6. The stiffness form (a dense ``eigh`` of K and M) is the mirror image: M-orthonormal to
round-off and good to ~eps lambda_max / lambda_k, so accurate for the high modes and not for
the low ones (the trap above). So when the requested modes reach above the geometric mean
sqrt(lambda_1 lambda_max) on a model small enough for a dense solve (DENSE_MAX_DOF), those
above it come from the stiffness form and those below from the flexibility form; both are
good to ~eps sqrt(lambda_max / lambda_1) there (all 2,002 modes of 1,000 elements pass
GRAM_TOL with 4e-11).

Every solve ends in one check of the SPEC's contract (section 2): the block is
M-orthonormalised by a Cholesky factor of its Gram matrix (lowest mode first, so that the
accurate low modes are not mixed with the high ones), and then Phi^T K Phi must be
diag(omega^2) to GRAM_TOL, entry by entry relative to the larger omega^2 of the pair. The
stiffness Gram matrix is z^T z with z = L^T D y (the factor form), not y^T K y with the
assembled K. The modes from the first one that fails on are not resolved (see
:func:`flexlift.structure.modes.compute_modes`).

"shift-invert" (kept for models whose K is not the bare hull's, and for comparison) uses the
same scaling, factorises K + sigma M (sigma > 0) with a sparse LU and works in the
M-orthogonal complement of R. Its check uses the assembled K.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexlift.errors import SimulationError
from flexlift.structure.beam import Beam, assemble, dof_scale, element_mass, element_stiffness

log = logging.getLogger(__name__)

_SQRT3 = np.sqrt(3.0)
#: below this many flexible DOFs the reduced operator is formed densely
_DENSE_BELOW = 64
#: up to this many columns, products of tall blocks are computed without BLAS
_FEW_COLUMNS = 64
#: docs/theory/modes.md#mass-normalisation: Phi^T M Phi = I and Phi^T K Phi = diag(omega^2) to this (each entry of the
#: latter relative to the larger omega^2 of its pair); modes that miss it are not resolved [-]
GRAM_TOL = 1e-10
#: largest model (DOFs) solved densely (~130 MB per dense matrix)
DENSE_MAX_DOF = 4002


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
        """Mode shapes in the scaled DOFs (M-orthogonal to the rigid modes) of vectors z."""
        return self.project(self.integrate(*self._LinvT(z)))

    def stiffness_coordinates(self, y):
        """z = L^T D y of scaled DOFs y, so that y^T K_s y = z^T z (inverse of :meth:`modes`
        on the complement of the rigid modes)."""
        w, t = y[0::2], y[1::2]
        d1 = w[:-1] + t[:-1] - w[1:]
        d2 = w[:-1] - w[1:] + t[1:]
        z = np.empty((2 * self.n, y.shape[1]))
        z[0::2] = self.rc * (2.0 * d1 + d2)
        z[1::2] = _SQRT3 * self.rc * d2
        return z

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


def _flexibility_solve(op: _Flexibility, n_flex: int, tol: float = 0.0):
    """Lowest ``n_flex`` flexible eigenvalues [rad^2/s^2] (ascending), their scaled mode shapes
    y and stiffness coordinates z, from the flexibility operator (dense or Lanczos)."""
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
    return op.lam_ref / mu, op.modes(Z), Z


def _stiffness_solve(beam: Beam, op: _Flexibility, lo: int, hi: int):
    """Flexible modes lo..hi-1 (0-based) of the stiffness form K_s y = lambda M_s y by a dense
    generalised ``eigh`` (indices 0 and 1 are the rigid modes, polluted and skipped): lambda
    [rad^2/s^2], scaled shapes y and their stiffness coordinates z."""
    Ks = beam.K.toarray()
    Ks *= op.s[:, None]
    Ks *= op.s[None, :]
    Ms = op.M.toarray()
    if 4 * (hi - lo) > Ks.shape[0]:  # many vectors: divide and conquer on all is faster
        lam, Y = sla.eigh(Ks, Ms, driver="gvd")
        lam, Y = lam[lo + 2:hi + 2], Y[:, lo + 2:hi + 2]
    else:
        lam, Y = sla.eigh(Ks, Ms, subset_by_index=[lo + 2, hi + 1])
    Y = op.project(Y)
    return lam, Y, op.stiffness_coordinates(Y)


#: largest eigenvalue of the Hermite element of unit length, stiffness and mass per length
_UNIT_ELEMENT_LAM_MAX = float(
    sla.eigh(element_stiffness(1.0, 1.0), element_mass(1.0, 1.0), eigvals_only=True)[-1]
)


def _lam_max_bound(beam: Beam) -> float:
    """Upper bound of the largest eigenvalue: the largest of the elements' own [rad^2/s^2]
    (extra and point masses only lower it)."""
    hull = beam.hull
    ratio = float(np.max(hull.EI / hull.mass_per_length))
    return _UNIT_ELEMENT_LAM_MAX * ratio / hull.element_length**4


def _gram(A, B=None):
    """A^T B (A^T A if B is None): without BLAS for a few columns (memory bound, see
    :func:`_inner`), else BLAS (the symmetric rank-k update for A^T A)."""
    if A.shape[1] <= _FEW_COLUMNS:
        return np.einsum("ni,nk->ik", A, A if B is None else B)
    if B is None:
        C = sla.blas.dsyrk(1.0, A, trans=1)
        return np.triu(C) + np.triu(C, 1).T
    return A.T @ B


def _leading_max(E: np.ndarray) -> np.ndarray:
    """e_k = max |E_ij| over the leading (k+1) x (k+1) block, for each k."""
    a = np.abs(E)
    return np.maximum.accumulate(np.tril(np.maximum(a, a.T)).max(axis=1))


def orthonormalised(mass, lam, shapes, coords=None, stiffness=None):
    """M-orthonormalise the columns of Y (a Cholesky factor of their Gram matrix, lowest mode
    first) and check them: returns lam, Y and err, where err[k] is the largest
    |Y^T K Y - diag(lam)|_ij / max(lam_i, lam_j) over modes i, j <= k [-].

    mass : the (scaled) mass matrix M; lam : (k,) eigenvalues [rad^2/s^2], ascending;
    shapes : (N, k) the shapes Y; coords : (2 n_el, k) their stiffness coordinates Z
    (Y^T K Y = Z^T Z), or None to use ``stiffness``, the assembled (scaled) stiffness K.
    Columns from the first one that is linearly dependent on those before it (no Cholesky
    factor) are dropped.
    """
    G = _gram(shapes, np.asarray(mass @ shapes))
    GK = (_gram(coords) if coords is not None
          else _gram(shapes, np.asarray(stiffness @ shapes)))
    d = 1.0 / np.sqrt(np.diag(G))  # unit columns first: G = I + (loss of orthogonality)
    G = G * np.outer(d, d)
    U, info = sla.lapack.dpotrf(G, lower=0, clean=1)
    k = lam.size if info == 0 else info - 1
    if k == 0:
        return lam[:0], shapes[:, :0], np.zeros(0)
    if info:  # factor the leading block that is positive definite
        U, _ = sla.lapack.dpotrf(G[:k, :k], lower=0, clean=1)
    lam, Yd, GK = lam[:k], shapes[:, :k] * d[:k], GK[:k, :k] * np.outer(d[:k], d[:k])
    if k <= _FEW_COLUMNS:
        T = sla.lapack.dtrtri(U)[0]  # U^-1 (a few columns: explicit, no BLAS on tall Y)
        Y = np.einsum("nk,kj->nj", Yd, T)
        C = T.T @ GK @ T
    else:
        Y = sla.solve_triangular(U, Yd.T, trans="T").T  # Y D U^-1
        C, _ = sla.lapack.dsygst(GK, U)  # U^-T D GK D U^-1, upper triangle
        C = np.triu(C) + np.triu(C, 1).T
    err = _leading_max((C - np.diag(lam)) / np.maximum.outer(lam, lam))
    return lam, Y, err


def flexibility_flexible(
    beam: Beam, rigid: np.ndarray, n_flex: int, tol: float = 0.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lowest ``n_flex`` flexible eigenvalues [rad^2/s^2] and M-orthonormal modes (N, n_flex),
    ascending, by the flexibility operator alone (module docstring), with the error of each
    (:func:`orthonormalised`)."""
    op = _Flexibility(beam, rigid)
    lam, Y, err = orthonormalised(op.M, *_flexibility_solve(op, n_flex, tol))
    return lam, op.s[:, None] * Y, err


def _split(beam: Beam, lam: np.ndarray) -> int:
    """Number of the modes lam (ascending) below sqrt(lambda_1 lambda_max), at least 1."""
    return max(1, int(np.searchsorted(lam, np.sqrt(lam[0] * _lam_max_bound(beam)))))


def flexibility_and_stiffness(
    beam: Beam, rigid: np.ndarray, n_flex: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """As :func:`flexibility_flexible`, except that on a model of at most DENSE_MAX_DOF the
    requested modes above sqrt(lambda_1 lambda_max) come from a dense solve of the stiffness
    form, which resolves them where the flexibility form cannot (module docstring)."""
    op = _Flexibility(beam, rigid)
    small = beam.n_dof <= DENSE_MAX_DOF
    if small and _DENSE_BELOW < op.size <= 2 * n_flex + 2:
        # nearly all modes: the stiffness form first (it places the split), then the
        # flexibility form for the few below the split
        lam_s, Y_s, Z_s = _stiffness_solve(beam, op, 0, n_flex)
        k = min(_split(beam, lam_s), n_flex)
        lam, Y, Z = _flexibility_solve(op, k)
        lam_s, Y_s, Z_s = lam_s[k:], Y_s[:, k:], Z_s[:, k:]
    else:
        lam, Y, Z = _flexibility_solve(op, n_flex)
        k = _split(beam, lam)
        lam_s = None
        if small and k < n_flex:
            lam_s, Y_s, Z_s = _stiffness_solve(beam, op, k, n_flex)
            lam, Y, Z = lam[:k], Y[:, :k], Z[:, :k]
    if lam_s is not None:
        log.debug("modes %d..%d of %d from the stiffness form", k + 1, n_flex, n_flex)
        lam, Y, Z = np.r_[lam, lam_s], np.hstack([Y, Y_s]), np.hstack([Z, Z_s])
    lam, Y, err = orthonormalised(op.M, lam, Y, Z)
    return lam, op.s[:, None] * Y, err


def shift_invert_flexible(
    beam: Beam, rigid: np.ndarray, n_flex: int, tol: float = 0.0, sigma: float | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lowest flexible modes by scaled, deflated shift-invert Lanczos with a sparse LU of
    K + sigma M (sigma > 0 [rad^2/s^2], default the uniform-beam estimate of
    the first flexible eigenvalue). Works for any K whose null space is R (``rigid``). Returns as
    :func:`flexibility_flexible`, checked against the assembled K."""
    hull = beam.hull
    s = sp.diags(dof_scale(hull))
    k_ref = float(np.mean(hull.EI)) / hull.element_length**3
    m_ref = hull.total_mass / hull.length * hull.element_length
    Ks = (s @ beam.K @ s).tocsc() / k_ref
    Ms = (s @ beam.M @ s).tocsc() / m_ref
    Rs = rigid / dof_scale(hull)[:, None] * np.sqrt(m_ref)  # Ms-orthonormal
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
    Y = Y[:, order]
    Y = Y - Rs @ (MR.T @ Y)
    nu, Y, err = orthonormalised(Ms, nu[order], Y, stiffness=Ks)
    return nu * lam_scale, dof_scale(hull)[:, None] * Y / np.sqrt(m_ref), err


def sparse_flexible(
    beam: Beam, rigid: np.ndarray, n_flex: int, method: str = "auto"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lowest ``n_flex`` flexible eigenvalues lambda = omega^2 [rad^2/s^2] (ascending), their
    M-orthonormal mode shapes V (N, n_flex) in the M-orthogonal complement of the rigid modes
    R, and the error err (n_flex,) of the Gram matrices up to each mode
    (:func:`orthonormalised`): the modes with err <= GRAM_TOL meet docs/theory/modes.md#mass-normalisation Fewer
    columns come back if the solver's vectors were linearly dependent.

    method : "flexibility" (default when K is the hull's own stiffness: the flexibility form,
        completed by the stiffness form for high modes it cannot resolve, see
        :func:`flexibility_and_stiffness`), "shift-invert" (any K with null space R), or "auto".
    """
    if method == "auto":
        method = "flexibility" if _k_matches_hull(beam) else "shift-invert"
    log.debug("sparse modal solve: %s, %d elements, %d flexible modes", method,
              beam.hull.n_elements, n_flex)
    if method == "flexibility":
        return flexibility_and_stiffness(beam, rigid, n_flex)
    if method == "shift-invert":
        return shift_invert_flexible(beam, rigid, n_flex)
    raise ValueError(f"method {method!r}: use 'flexibility', 'shift-invert' or 'auto'")
