"""Free-free eigen analysis: clean rigid modes, mass-normalised flexible modes, nodes of a mode.

The generalised problem K phi = omega^2 M phi of a free-free beam has two rigid modes (heave
and pitch, omega = 0). Numerical solvers return them polluted by round-off, so they are built
exactly here (heave: w = 1; pitch: w = x - x_G, theta = 1; mass-orthonormalised) and the
flexible modes are solved in their M-orthogonal complement.
"""

from __future__ import annotations

import contextlib
import hashlib
import logging
import threading
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from flexlift.errors import InputError, SimulationError
from flexlift.structure.beam import Beam, assemble, shape_functions
from flexlift.structure.eigen import DENSE_MAX_DOF, GRAM_TOL, sparse_flexible
from flexlift.structure.hull import Hull

log = logging.getLogger(__name__)

#: beta_n L of the first free-free flexible modes of a uniform beam
#: (roots of cos(bL) cosh(bL) = 1, to double precision)
BETA_L_FREE_FREE = np.array(
    [4.730040744862704, 7.853204624095838, 10.995607838001671, 14.137165491257464,
     17.278759657399480]
)


@dataclass(frozen=True)
class Modes:
    """Modes of a free-free beam.

    omega : ndarray (m,) — natural circular frequencies, ascending; the first ``n_rigid``
        are exactly 0 [rad/s]
    phi : ndarray (N, m) — mass-normalised mode shapes (phi.T M phi = I), DOF order
        [w_0, theta_0, w_1, ...] [m/sqrt(kg) and rad/sqrt(kg)]
    hull : Hull — the structure
    n_rigid : int — number of rigid modes (2 for a free-free beam)
    n_requested : int — modes asked for, rigid included; ``n_modes`` (those returned) is
        smaller when the solver could not resolve the highest ones to docs/theory/modes.md#mass-normalisation [-]
    diagnostics : dict — what the solve had to correct: ``clipped_eigenvalues``, a list of
        (flexible mode number 1.., omega^2 [rad^2/s^2]) of round-off negatives set to 0
        (:data:`NEGATIVE_EIGENVALUE_TOL`)
    """

    omega: np.ndarray
    phi: np.ndarray
    hull: Hull
    n_rigid: int = 2
    n_requested: int | None = None
    diagnostics: dict = field(default_factory=dict)

    @property
    def n_modes(self) -> int:
        return self.omega.size

    @property
    def frequencies_hz(self) -> np.ndarray:
        """Natural frequencies [Hz]."""
        return self.omega / (2 * np.pi)

    @property
    def displacement(self) -> np.ndarray:
        """Vertical displacement of each mode at each node, shape (n_nodes, m)."""
        return self.phi[0::2]

    @property
    def rotation(self) -> np.ndarray:
        """Rotation of each mode at each node, shape (n_nodes, m)."""
        return self.phi[1::2]

    def flexible_index(self, k: int) -> int:
        """0-based column of the k-th flexible mode (k = 1 is the first flexible mode)."""
        if not 1 <= k <= self.n_modes - self.n_rigid:
            raise InputError(
                "flexible mode",
                k,
                f"the model has flexible modes 1..{self.n_modes - self.n_rigid}",
            )
        return self.n_rigid + k - 1

    def unit_peak(self) -> np.ndarray:
        """Displacement shapes scaled to a peak of +1 (for plotting), shape (n_nodes, m)."""
        w = self.displacement
        idx = np.argmax(np.abs(w), axis=0)
        peak = w[idx, np.arange(w.shape[1])]
        return w / np.where(peak == 0, 1.0, peak)

    def shape_at(self, x: np.ndarray, columns=None) -> np.ndarray:
        """Mode displacements interpolated with the Hermite shape functions at x [m],
        shape (len(x), m) (or (len(x), len(columns)) for the chosen 0-based ``columns``)."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        hull = self.hull
        l = hull.element_length
        e = np.clip((x / l).astype(int), 0, hull.n_elements - 1)
        xi = x / l - e
        N = shape_functions(xi, l)  # (nx, 4)
        dofs = 2 * e[:, None] + np.arange(4)[None, :]  # (nx, 4)
        phi = self.phi if columns is None else self.phi[:, np.atleast_1d(columns)]
        return np.einsum("pk,pkm->pm", N, phi[dofs])


def rigid_modes(beam: Beam) -> np.ndarray:
    """Exact mass-orthonormal heave and pitch shapes, shape (N, 2)."""
    x = beam.hull.x_nodes
    n = beam.n_dof
    heave = np.zeros(n)
    heave[0::2] = 1.0
    heave /= np.sqrt(heave @ (beam.M @ heave))
    # pitch about the centre of mass: M-orthogonal to heave by construction
    arm = np.zeros(n)
    arm[0::2] = x
    x_g = (heave @ (beam.M @ arm)) * heave[0]  # M-weighted mean of x (heave is constant)
    pitch = np.zeros(n)
    pitch[0::2] = x - x_g
    pitch[1::2] = 1.0
    pitch -= (heave @ (beam.M @ pitch)) * heave  # round-off clean-up
    pitch /= np.sqrt(pitch @ (beam.M @ pitch))
    return np.column_stack([heave, pitch])


def _complement_basis(beam: Beam, R: np.ndarray) -> np.ndarray:
    """Orthonormal basis (N, N-2) of the vectors M-orthogonal to the rigid modes R."""
    MR = np.asarray(beam.M @ R)
    return sla.null_space(MR.T)


def _dense_flexible(beam: Beam, R: np.ndarray, n_flex: int) -> tuple[np.ndarray, np.ndarray]:
    Q = _complement_basis(beam, R)
    K = beam.K.toarray()
    M = beam.M.toarray()
    Kc = Q.T @ K @ Q
    Mc = Q.T @ M @ Q
    Kc = 0.5 * (Kc + Kc.T)
    Mc = 0.5 * (Mc + Mc.T)
    lam, y = sla.eigh(Kc, Mc, subset_by_index=[0, n_flex - 1])
    return lam, Q @ y


#: a flexible eigenvalue below -NEGATIVE_EIGENVALUE_TOL omega_1^2 is a failed solve (raised);
#: a negative one above it is round-off, clipped to 0 and recorded in the modes' diagnostics
NEGATIVE_EIGENVALUE_TOL = 1e-8


def checked_omega(lam: np.ndarray, what: str = "modes") -> tuple[np.ndarray, list]:
    """sqrt of the flexible eigenvalues ``lam`` = omega^2 [rad^2/s^2], never turning a
    negative one into a zero-frequency mode silently: below -:data:`NEGATIVE_EIGENVALUE_TOL`
    omega_1^2 (omega_1^2 the lowest positive one) a :class:`~flexlift.errors.SimulationError`
    names the mode; above it the value is clipped to 0 and returned in the list of
    (flexible mode number 1.., omega^2) for the diagnostics."""
    lam = np.asarray(lam, dtype=float)
    pos = lam[lam > 0]
    ref = float(pos.min()) if pos.size else float(np.abs(lam).max(initial=0.0))
    bad = np.flatnonzero(lam < -NEGATIVE_EIGENVALUE_TOL * ref)
    if bad.size:
        k = int(bad[0])
        raise SimulationError(
            f"{what}: flexible mode {k + 1} has a negative eigenvalue omega^2 = {lam[k]:.3e} "
            f"rad^2/s^2 (below -{NEGATIVE_EIGENVALUE_TOL:g} omega_1^2 = "
            f"{-NEGATIVE_EIGENVALUE_TOL * ref:.3e}): the stiffness is not positive on the "
            "flexible modes or the eigen solve lost accuracy; check the stiffness and masses, "
            "or use fewer elements or solver='dense'")
    clipped = [(int(k) + 1, float(lam[k])) for k in np.flatnonzero(lam < 0)]
    return np.sqrt(np.clip(lam, 0.0, None)), clipped


#: with ``n_modes=None``, models above this many elements get the lowest DEFAULT_LARGE_MODES
LARGE_MODEL_ELEMENTS = 400
DEFAULT_LARGE_MODES = 22


def compute_modes(
    hull: Hull | Beam, n_modes: int | None = None, solver: str = "auto"
) -> Modes:
    """Modes of a free-free beam: two exact rigid modes then the lowest flexible ones.

    Parameters
    ----------
    hull : Hull or Beam
        The structure (:func:`~flexlift.structure.hull.hull_from_scenario`), or an assembled
        :class:`Beam`.
    n_modes : int, optional
        Total number of modes wanted, rigid included (default: all, 2 per node, up to 400
        elements; 22 = 2 rigid + 20 flexible above that) [-].
    solver : str, optional
        ``"sparse"`` (flexibility Lanczos of :mod:`flexlift.structure.eigen`: O(N) memory,
        accurate to round-off at any mesh size for the low modes; the high modes of a model
        up to DENSE_MAX_DOF = 4002 DOFs from a dense stiffness solve), ``"dense"``
        (generalised ``eigh`` of K and M projected on the complement of the rigid modes:
        O(N^2) memory, O(N^3) time, loses digits as eps * (N / 4.73)^4 on fine meshes), or
        ``"auto"`` (sparse).

    Returns
    -------
    Modes
        ``omega`` [rad/s] and ``frequencies_hz`` [Hz] (heave and pitch first, at 0), the
        mass-normalised shapes ``phi`` [1/sqrt(kg)] and the hull (``docs/theory/modes.md``).

    Examples
    --------
    >>> from flexlift import load_scenario
    >>> from flexlift.structure.hull import hull_from_scenario
    >>> from flexlift.structure.modes import compute_modes
    >>> modes = compute_modes(hull_from_scenario(load_scenario("tanker")))
    >>> modes.n_modes, round(float(modes.frequencies_hz[2]), 3)  # flexible mode 1 [Hz]
    (24, 5.003)

    Notes
    -----
    The sparse solver checks docs/theory/modes.md#mass-normalisation on what it returns: Phi^T M Phi = I and
    Phi^T K Phi = diag(omega^2) to GRAM_TOL (1e-10, relative to the larger omega^2 of each
    pair). When the highest requested modes miss it (many modes of a very fine mesh: the
    flexibility form resolves mode k only to ~eps omega_k^2 / omega_1^2), only the modes
    below the first that misses are returned, with a logged warning; ``n_requested`` on the
    result keeps the number asked for.
    """
    beam = hull if isinstance(hull, Beam) else assemble(hull)
    store = getattr(_reuse, "store", None)
    if store is None:
        return _compute_modes(beam, n_modes, solver)
    key = _beam_key(beam, n_modes, solver)
    if key not in store:
        store[key] = _compute_modes(beam, n_modes, solver)
        while len(store) > REUSE_SIZE:
            store.pop(next(iter(store)))
    return store[key]


#: most modes kept by :func:`reusing_modes` per store
REUSE_SIZE = 8
_reuse = threading.local()


@contextlib.contextmanager
def reusing_modes(store: dict):
    """Within the block (in this thread), :func:`compute_modes` returns the modes it already
    computed into ``store`` for the same beam (the same K, M and hull, bit for bit), the same
    count and solver, instead of solving again: the modes of a sweep's cases that change only
    loads, control or seabed are solved once per worker. The solvers are deterministic, so
    the result is what a new solve gives; it is shared, so treat it as read only (as every
    caller in flexlift does)."""
    previous = getattr(_reuse, "store", None)
    _reuse.store = store
    try:
        yield store
    finally:
        _reuse.store = previous


def _beam_key(beam: Beam, n_modes, solver: str) -> str:
    h = hashlib.sha256(repr((n_modes, solver, beam.K.shape, beam.hull.length, beam.hull.breadth,
                             beam.hull.depth)).encode())
    for a in (beam.K.data, beam.K.indices, beam.K.indptr, beam.M.data, beam.M.indices,
              beam.M.indptr, beam.hull.EI, beam.hull.mass_per_length, beam.hull.point_masses):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def _compute_modes(beam: Beam, n_modes: int | None, solver: str) -> Modes:
    n_dof = beam.n_dof
    if n_modes is None:
        large = beam.hull.n_elements > LARGE_MODEL_ELEMENTS
        n_modes = min(n_dof, DEFAULT_LARGE_MODES) if large else n_dof
    n_modes = int(n_modes)
    if not 3 <= n_modes <= n_dof:
        raise InputError("modes", n_modes, f"need 3..{n_dof} modes for this mesh (2 rigid + flexible)")
    if solver == "auto":
        solver = "sparse"
    if solver not in ("dense", "sparse"):
        raise InputError("solver", solver, "use 'dense', 'sparse' or 'auto'")
    if solver == "dense" and n_dof > DENSE_MAX_DOF:
        raise InputError(
            "solver", "dense",
            f"dense needs O(N^2) memory; use it up to {DENSE_MAX_DOF // 2 - 1} elements "
            f"(this mesh has {beam.hull.n_elements}), or 'sparse'",
        )
    R = rigid_modes(beam)
    n_flex = n_modes - 2
    if solver == "dense":
        lam, V = _dense_flexible(beam, R, n_flex)
        # mass-normalise (eigh already does; repeat against round-off of the projection)
        V = V / np.sqrt(np.einsum("ij,ij->j", V, np.asarray(beam.M @ V)))
    else:
        lam, V, err = sparse_flexible(beam, R, n_flex)
        resolved = int(np.sum(err <= GRAM_TOL))  # err is non-decreasing
        if resolved == 0:
            raise SimulationError(
                f"no flexible mode of this {beam.hull.n_elements}-element model meets "
                f"Phi^T K Phi = diag(omega^2) to {GRAM_TOL:g}"
                + (f" (the first is off by {err[0]:.1e})" if err.size else "")
                + "; use a coarser mesh or solver='dense'"
            )
        if resolved < n_flex:
            log.warning(
                "%d of the %d requested modes are resolved on %d elements (Phi^T M Phi = I "
                "and Phi^T K Phi = diag(omega^2) to %g; mode %d is off by %.1e); returning "
                "those. Ask for fewer modes%s.",
                resolved + 2, n_modes, beam.hull.n_elements, GRAM_TOL, resolved + 3,
                err[resolved] if resolved < err.size else np.inf,
                "" if n_dof <= DENSE_MAX_DOF
                else f" or use at most {DENSE_MAX_DOF // 2 - 1} elements (solved densely)",
            )
            lam, V = lam[:resolved], V[:, :resolved]
    # a sign convention: the bow displacement of each mode is positive
    sign = np.sign(V[-2])
    sign[sign == 0] = 1.0
    V = V * sign
    flex, clipped = checked_omega(lam)
    if clipped:
        log.warning("modes: %d flexible eigenvalue(s) slightly negative by round-off, set to 0: "
                    "%s", len(clipped), clipped[:3])
    omega = np.concatenate([[0.0, 0.0], flex])
    return Modes(omega=omega, phi=np.column_stack([R, V]), hull=beam.hull, n_rigid=2,
                 n_requested=n_modes,
                 diagnostics={"clipped_eigenvalues": clipped} if clipped else {})


def zero_crossings(modes: Modes, column: int, samples_per_element: int | None = None) -> np.ndarray:
    """Positions [m] where mode ``column`` (0-based) changes sign, from its Hermite interpolant
    sampled ``samples_per_element`` times per element (default 50, fewer on fine meshes so
    that at most ~200,000 points are evaluated)."""
    n_el = modes.hull.n_elements
    if samples_per_element is None:
        samples_per_element = int(np.clip(200_000 // n_el, 2, 50))
    x = np.linspace(0.0, modes.hull.length, n_el * samples_per_element + 1)
    w = modes.shape_at(x, columns=column)[:, 0]
    s = np.sign(w)
    k = np.nonzero(s[:-1] * s[1:] < 0)[0]
    return x[k] - w[k] * (x[k + 1] - x[k]) / (w[k + 1] - w[k])


def mode_nodes(modes: Modes, column: int) -> list[int]:
    """0-based indices of the nodes nearest the zero crossings of mode ``column`` (0-based)."""
    return [modes.hull.nearest_node(xc) for xc in zero_crossings(modes, column)]


def analytic_free_free_hz(hull: Hull, n: int = 5) -> np.ndarray:
    """First ``n`` (<= 5) flexible frequencies of the uniform free-free beam [Hz]:
    f = (beta L)^2 / (2 pi L^2) sqrt(EI / m)."""
    EI = float(hull.EI.mean())
    m = float(hull.mass_per_length.mean())
    bl = BETA_L_FREE_FREE[:n]
    return bl**2 / (2 * np.pi * hull.length**2) * np.sqrt(EI / m)
