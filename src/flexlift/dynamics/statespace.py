"""Modal state space of the free-free hull (docs/theory/reduction.md#modal-state-space), with closed-form responses.

One equation per mode, ``q̈_i + 2 ζ_i ω_i q̇_i + ω_i² q_i = φ_iᵀ F(t)``; the state is
``x = [q_1, q̇_1, q_2, q̇_2, ...]`` so A is block diagonal with blocks
``[0 1; -ω_i² -2 ζ_i ω_i]`` (rigid modes: ω = 0 and ζ = 0, a double integrator).

Signal names (1-based node numbers, as in the scenario file and the SPEC's figures):

- inputs: ``"f_node_5"`` a vertical point force at node 5 [N]; ``"f_bag_1"`` the force of
  bag_1 [N] (a point force for an external bag, a uniform load over its span for an internal
  bag); or ``(name, vector)`` with any force distribution over the DOFs [N, N m per unit input].
- outputs: ``"w_node_5"`` displacement [m], ``"v_node_5"`` velocity [m/s], ``"theta_node_5"``
  rotation [rad]; ``"w_bag_1"``/``"v_bag_1"`` the displacement/velocity work-conjugate to the
  bag's force (at its node, or averaged over an internal bag's span) — the collocated output.

The model keeps ω, ζ and the modal coefficients ``b`` (m, n_in) and ``c_disp``/``c_vel``
(n_out, m), so that G(jω) = Σ_i (c_d,i + jω c_v,i) b_i / (ω_i² − ω² + 2jζ_iω_iω) + D is
evaluated in closed form, vectorised over frequencies and modes.
"""

from __future__ import annotations

import logging
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from flexlift.errors import InputError
from flexlift.structure.beam import point_load_vector, shape_functions
from flexlift.structure.hull import Hull
from flexlift.structure.modes import NEGATIVE_EIGENVALUE_TOL, Modes

log = logging.getLogger(__name__)

#: default ω_lo as a fraction of the first flexible frequency (docs/theory/reduction.md#dc-gain)
OMEGA_LO_FRACTION = 0.1

_SIGNAL = re.compile(r"^(f|w|v|theta)_(node|bag)_(\w+)$")


@dataclass(frozen=True)
class ModalStateSpace:
    """A modal state-space model x' = A x + B u, y = C x + D u.

    A, B, C, D : ndarrays (2m, 2m), (2m, n_in), (n_out, 2m), (n_out, n_in) — SI units of the
        named signals (inputs N, outputs m, m/s or rad)
    inputs, outputs : tuple of str — signal names
    omega : ndarray (m,) — natural frequencies of the retained modes [rad/s]
    zeta : ndarray (m,) — modal damping ratios, 0 for rigid modes [-]
    b : ndarray (m, n_in) — modal input coefficients φ_iᵀ f_k [1/sqrt(kg)]
    c_disp, c_vel : ndarrays (n_out, m) — output coefficients of q_i and of q̇_i
    mode_numbers : ndarray (m,) of int — 1-based numbers of the retained modes in the model
        they came from (rigid modes are 1 and 2)
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    omega: np.ndarray
    zeta: np.ndarray
    b: np.ndarray
    c_disp: np.ndarray
    c_vel: np.ndarray
    mode_numbers: np.ndarray

    @classmethod
    def from_modal(cls, omega, zeta, b, c_disp, c_vel, feedthrough=None, inputs=None,
                   outputs=None, mode_numbers=None) -> ModalStateSpace:
        """Build A, B, C from the modal data (see the class docstring for shapes and units);
        ``feedthrough``: D (zeros when None)."""
        omega = np.asarray(omega, float)
        zeta = np.asarray(zeta, float)
        b = np.atleast_2d(np.asarray(b, float))
        c_disp = np.atleast_2d(np.asarray(c_disp, float))
        c_vel = np.atleast_2d(np.asarray(c_vel, float))
        m, n_in = b.shape
        n_out = c_disp.shape[0]
        A = np.zeros((2 * m, 2 * m))
        i = np.arange(m)
        A[2 * i, 2 * i + 1] = 1.0
        A[2 * i + 1, 2 * i] = -(omega**2)
        A[2 * i + 1, 2 * i + 1] = -2.0 * zeta * omega
        B = np.zeros((2 * m, n_in))
        B[1::2] = b
        C = np.zeros((n_out, 2 * m))
        C[:, 0::2] = c_disp
        C[:, 1::2] = c_vel
        D = (np.zeros((n_out, n_in)) if feedthrough is None
             else np.array(feedthrough, float).reshape(n_out, n_in))
        inputs = tuple(inputs) if inputs is not None else tuple(f"u{k}" for k in range(n_in))
        outputs = tuple(outputs) if outputs is not None else tuple(f"y{k}" for k in range(n_out))
        numbers = np.arange(1, m + 1) if mode_numbers is None else np.asarray(mode_numbers, int)
        return cls(A, B, C, D, inputs, outputs, omega, zeta, b, c_disp, c_vel, numbers)

    # ------------------------------------------------------------------ sizes and names
    @property
    def n_modes(self) -> int:
        return self.omega.size

    @property
    def n_states(self) -> int:
        return 2 * self.omega.size

    @property
    def rigid(self) -> np.ndarray:
        """Boolean mask of the rigid modes (ω = 0)."""
        return self.omega == 0.0

    @property
    def n_rigid(self) -> int:
        return int(np.count_nonzero(self.rigid))

    @property
    def states(self) -> tuple[str, ...]:
        return tuple(s for n in self.mode_numbers for s in (f"q{n}", f"q{n}_dot"))

    def index(self, name: str, kind: str = "output") -> int:
        """Position of a named output (or input, kind="input")."""
        names = self.outputs if kind == "output" else self.inputs
        if name not in names:
            raise InputError(kind, name, f"known {kind}s are {', '.join(names)}")
        return names.index(name)

    def subsystem(self, outputs: Sequence[str] | None = None,
                  inputs: Sequence[str] | None = None) -> ModalStateSpace:
        """The same modes with a subset of the named outputs and inputs."""
        oi = [self.index(o) for o in (outputs or self.outputs)]
        ii = [self.index(i, "input") for i in (inputs or self.inputs)]
        return ModalStateSpace.from_modal(
            self.omega, self.zeta, self.b[:, ii], self.c_disp[oi], self.c_vel[oi],
            self.D[np.ix_(oi, ii)], [self.inputs[k] for k in ii], [self.outputs[k] for k in oi],
            self.mode_numbers,
        )

    def with_modes(self, keep: Sequence[int],
                   feedthrough: np.ndarray | None = None) -> ModalStateSpace:
        """The model restricted to the modes at 0-based positions ``keep`` (its feedthrough D
        replaced by ``feedthrough`` when given)."""
        keep = np.sort(np.asarray(keep, int))
        return ModalStateSpace.from_modal(
            self.omega[keep], self.zeta[keep], self.b[keep], self.c_disp[:, keep],
            self.c_vel[:, keep], self.D if feedthrough is None else feedthrough, self.inputs,
            self.outputs,
            self.mode_numbers[keep],
        )


# ---------------------------------------------------------------------- building
def _unit_uniform_load(hull: Hull, span: tuple[float, float]) -> np.ndarray:
    """Consistent nodal loads of a uniform load of unit total force over span [m] (N,)."""
    a, b = float(span[0]), float(span[1])
    l = hull.element_length
    f = np.zeros(2 * hull.n_nodes)
    gx, gw = np.polynomial.legendre.leggauss(4)  # exact for the cubic shape functions
    for e in range(hull.n_elements):
        x0, x1 = max(a, e * l), min(b, (e + 1) * l)
        if x1 <= x0:
            continue
        x = 0.5 * (x0 + x1) + 0.5 * (x1 - x0) * gx
        N = shape_functions(x / l - e, l)
        f[2 * e : 2 * e + 4] += (0.5 * (x1 - x0) * gw) @ N / (b - a)
    return f


def _parse(name: str, kind: str, hull: Hull, bags: Mapping) -> tuple[str, str, object]:
    m = _SIGNAL.match(name) if isinstance(name, str) else None
    ok = {"input": ("f",), "output": ("w", "v", "theta")}[kind]
    if m is None or m.group(1) not in ok:
        raise InputError(kind, name, f"use {'/'.join(ok)}_node_N (N = 1..{hull.n_nodes})"
                         f" or {'/'.join(ok)}_bag_NAME" + (" or (name, force vector)"
                                                           if kind == "input" else ""))
    quantity, where, key = m.groups()
    if where == "node":
        if not key.isdigit() or not 1 <= int(key) <= hull.n_nodes:
            raise InputError(kind, name, f"nodes are 1..{hull.n_nodes}")
        return quantity, "node", int(key) - 1
    bag = bags.get(f"bag_{key}", bags.get(key))
    if bag is None:
        raise InputError(kind, name, f"known bags are {', '.join(bags) or 'none'}")
    if quantity == "theta" and bag.node is None:
        raise InputError(kind, name, "a rotation needs a bag at a node; use theta_node_N")
    return quantity, "bag", bag


def _shape(hull: Hull, where: str, what) -> np.ndarray:
    """Unit force distribution (== displacement-extraction vector) for a node or a bag."""
    if where == "bag" and what.node is None:
        if what.span is None:  # an external bag between nodes: a point load (Hermite)
            return point_load_vector(hull, what.x, 1.0)
        return _unit_uniform_load(hull, what.span)
    node = what if where == "node" else what.node
    f = np.zeros(2 * hull.n_nodes)
    f[2 * node] = 1.0
    return f


def _zeta_vector(modes: Modes, zeta) -> np.ndarray:
    rigid = modes.omega == 0.0
    z = np.asarray(zeta, float)
    if z.ndim == 0:
        z = np.where(rigid, 0.0, float(z))
    if z.shape != modes.omega.shape or not np.all((z >= 0) & (z < 1)):
        raise InputError("zeta", np.asarray(zeta).tolist(),
                         f"a damping ratio 0 <= zeta < 1 or one per mode ({modes.n_modes})")
    if np.any(z[rigid] != 0):
        raise InputError("zeta", z[rigid].tolist(), "rigid modes take zeta = 0")
    return z


def modal_state_space(modes: Modes, inputs: Sequence, outputs: Sequence[str], zeta=0.02,
                      bags: Sequence | Mapping | None = None) -> ModalStateSpace:
    """Modal state space of ``modes`` with named inputs and outputs (module docstring).

    modes : the free-free modes (all of them or the lowest few)
    inputs : names ("f_node_N", "f_bag_NAME") or (name, force vector (N_dof,)) pairs [N]
    outputs : names ("w_node_N", "v_node_N", "theta_node_N", "w_bag_NAME", "v_bag_NAME")
    zeta : damping ratio of every flexible mode, or one per mode (rigid entries 0) [-]
    bags : the :class:`~flexlift.loads.liftplan.Bag` objects that "bag" names refer to
    """
    hull = modes.hull
    if isinstance(bags, Mapping):
        bag_map = dict(bags)
    else:
        bag_map = {b.name: b for b in (bags or ())}
    if len(inputs) == 0 or len(outputs) == 0:
        raise InputError("inputs/outputs", (len(inputs), len(outputs)), "need at least one of each")
    n_dof = modes.phi.shape[0]
    in_names, F = [], []
    for spec in inputs:
        if isinstance(spec, tuple):
            name, vec = spec
            vec = np.asarray(vec, float)
            if vec.shape != (n_dof,) or not np.all(np.isfinite(vec)):
                raise InputError(f"input {name}", vec.shape, f"a finite vector of {n_dof} DOF loads")
            in_names.append(str(name))
            F.append(vec)
        else:
            _, where, what = _parse(spec, "input", hull, bag_map)
            in_names.append(spec)
            F.append(_shape(hull, where, what))
    cd, cv = [], []
    for name in outputs:
        quantity, where, what = _parse(name, "output", hull, bag_map)
        if quantity == "theta":
            vec = np.zeros(n_dof)
            vec[2 * (what if where == "node" else what.node) + 1] = 1.0
        else:
            vec = _shape(hull, where, what)
        row = vec @ modes.phi
        cd.append(row if quantity != "v" else np.zeros_like(row))
        cv.append(row if quantity == "v" else np.zeros_like(row))
    b = np.column_stack(F).T @ modes.phi  # (n_in, m)
    return ModalStateSpace.from_modal(modes.omega, _zeta_vector(modes, zeta), b.T,
                                      np.array(cd), np.array(cv), None, in_names, outputs)


def bag_state_space(modes: Modes, bags: Sequence, zeta=0.02, velocity: bool = False
                    ) -> ModalStateSpace:
    """MIMO model: every bag's force [N] to every bag's own displacement [m] (and, with
    ``velocity``, then their velocities [m/s])."""
    names = [b.name.removeprefix("bag_") for b in bags]
    outputs = [f"w_bag_{n}" for n in names] + ([f"v_bag_{n}" for n in names] if velocity else [])
    return modal_state_space(modes, [f"f_bag_{n}" for n in names], outputs, zeta, bags)


def bag_siso(modes: Modes, bag, zeta=0.02, output: str | None = None, bags: Sequence = ()
             ) -> ModalStateSpace:
    """SISO model of one bag: its force [N] to its own displacement [m] (or to ``output``,
    whose bag names may refer to ``bags``)."""
    n = bag.name.removeprefix("bag_")
    known = {b.name: b for b in bags} | {bag.name: bag}
    return modal_state_space(modes, [f"f_bag_{n}"], [output or f"w_bag_{n}"], zeta, known)


# ---------------------------------------------------------------------- gains
def default_omega_lo(sys: ModalStateSpace) -> float:
    """ω_lo = one tenth of the first flexible frequency of ``sys`` [rad/s]."""
    flex = sys.omega[~sys.rigid]
    if flex.size == 0:
        raise InputError("omega_lo", None, "the model has no flexible mode; give omega_lo")
    return OMEGA_LO_FRACTION * float(flex.min())


def modal_dc_gains(sys: ModalStateSpace) -> np.ndarray:
    """Signed dc gain of every mode, c_d,i b_i / ω_i², shape (n_out, n_in, m); NaN for the
    rigid modes, which have no finite dc gain [output unit per N]."""
    w2 = np.where(sys.rigid, np.nan, sys.omega**2)
    return np.einsum("om,mi->oim", sys.c_disp, sys.b) / w2


def flexible_dc_gain(sys: ModalStateSpace) -> np.ndarray:
    """Static gain of the flexible part, Σ_flexible c_d,i b_i / ω_i², plus D,
    shape (n_out, n_in) [output unit per N]."""
    return np.nansum(modal_dc_gains(sys), axis=-1) + sys.D


def mode_gains(sys: ModalStateSpace, omega_lo: float | None = None, output=0, input=0
               ) -> np.ndarray:
    """Per-mode gain (m,) from one input to one output (names or positions):
    |c_i b_i| / ω_i² (dc gain) for a flexible mode, |G_i(jω_lo)| for a rigid one (for a
    velocity output every flexible dc gain is 0, so rank displacement outputs).
    ``output=None, input=None``: the root-sum-square over all input/output pairs.
    omega_lo : low frequency for the rigid modes [rad/s], default :func:`default_omega_lo`"""
    w_lo = default_omega_lo(sys) if omega_lo is None else float(omega_lo)
    if output is None:
        oi = slice(None)
    else:
        oi = [sys.index(output) if isinstance(output, str) else int(output)]
    if input is None:
        ii = slice(None)
    else:
        ii = [sys.index(input, "input") if isinstance(input, str) else int(input)]
    cd, cv, b = sys.c_disp[oi], sys.c_vel[oi], sys.b[:, ii]
    rigid = sys.rigid
    s = np.where(rigid, 1j * w_lo, 0.0)  # evaluate rigid modes at jω_lo, flexible at 0
    num = (cd.T[:, :, None] + s[:, None, None] * cv.T[:, :, None]) * b[:, None, :]
    den = sys.omega**2 + s**2 + 2 * sys.zeta * sys.omega * s
    g = np.abs(num / den[:, None, None])  # (m, n_out, n_in)
    return np.sqrt(np.sum(g**2, axis=(1, 2)))


def gain_ranking(sys: ModalStateSpace, omega_lo: float | None = None, output=0, input=0
                 ) -> np.ndarray:
    """0-based mode positions, largest gain first (ties: lower frequency first)."""
    g = mode_gains(sys, omega_lo, output, input)
    return np.lexsort((np.arange(g.size), -g))


# ---------------------------------------------------------------------- responses
#: frequencies per block in :func:`frequency_response` (bounds the work arrays to
#: block × modes complex numbers, about 16 MB for 400 modes)
_BLOCK_ELEMENTS = 1 << 20


def frequency_response(sys: ModalStateSpace, omega) -> np.ndarray:
    """G(jω) for every output, input and frequency, shape (n_out, n_in, n_freq), closed form.

    omega : frequencies [rad/s]; at ω = 0 a model with rigid modes has no finite response
        (NaN is returned there)

    Vectorised over modes and frequencies (frequencies in blocks to bound memory):
    H = 1 / (ω_i² − ω² + 2jζ_iω_iω) for all (ω, i), then one matrix product with the
    modal residues c_i b_i.
    """
    w = np.atleast_1d(np.asarray(omega, float))
    n_out, n_in = sys.D.shape
    m = sys.n_modes
    Wd = (sys.c_disp.T[:, :, None] * sys.b[:, None, :]).reshape(m, n_out * n_in)  # (m, o*i)
    has_v = bool(np.any(sys.c_vel))
    Wv = (sys.c_vel.T[:, :, None] * sys.b[:, None, :]).reshape(m, n_out * n_in) if has_v else None
    w2 = sys.omega**2
    c = 2.0 * sys.zeta * sys.omega
    G = np.empty((w.size, n_out * n_in), complex)
    step = max(1, _BLOCK_ELEMENTS // max(m, 1))
    for k in range(0, w.size, step):  # blocks of frequencies, not one by one
        wk = w[k : k + step, None]
        H = np.empty((wk.shape[0], m), complex)
        H.real = w2 - wk**2
        H.imag = c * wk
        with np.errstate(divide="ignore", invalid="ignore"):
            np.reciprocal(H, out=H)
        Gk = H @ Wd
        if has_v:
            Gk += 1j * wk * (H @ Wv)
        G[k : k + step] = Gk
    G += sys.D.reshape(1, -1)
    return np.moveaxis(G.reshape(w.size, n_out, n_in), 0, -1)


def _modal_time(sys: ModalStateSpace, t, kind: str) -> tuple[np.ndarray, np.ndarray]:
    """Exact q(t), q̇(t) per mode (m, n_t) for a unit step or unit impulse input."""
    t = np.asarray(t, float)[None, :]
    w = sys.omega[:, None]
    z = sys.zeta[:, None]
    rigid = (sys.omega == 0.0)[:, None]
    wd = np.where(rigid, 1.0, w * np.sqrt(1.0 - z**2))
    ws = np.where(rigid, 1.0, w)
    e = np.exp(-z * w * t)
    sn, cs = np.sin(wd * t), np.cos(wd * t)
    if kind == "step":
        q = np.where(rigid, 0.5 * t**2, (1 - e * (cs + z * w / wd * sn)) / ws**2)
        qd = np.where(rigid, t, e * sn / wd)
    else:
        q = np.where(rigid, t, e * sn / wd)
        qd = np.where(rigid, 1.0, e * (cs - z * w / wd * sn))
    return q, qd


def _time_response(sys: ModalStateSpace, t, kind: str) -> np.ndarray:
    q, qd = _modal_time(sys, t, kind)
    y = np.einsum("om,mi,mt->oit", sys.c_disp, sys.b, q)
    y += np.einsum("om,mi,mt->oit", sys.c_vel, sys.b, qd)
    if kind == "step":
        y += sys.D[:, :, None]
    return y


def step_response(sys: ModalStateSpace, t) -> np.ndarray:
    """Exact response to a unit step at t = 0 from rest, shape (n_out, n_in, n_t).
    t : times >= 0 [s]; a unit input is 1 N, so displacements are in m per N"""
    return _time_response(sys, t, "step")


def impulse_response(sys: ModalStateSpace, t) -> np.ndarray:
    """Exact response to a unit impulse (1 N s) at t = 0, shape (n_out, n_in, n_t).
    The D δ(t) part of a model with feedthrough is not representable and left out (as
    scipy.signal and python-control do). t : times >= 0 [s]"""
    return _time_response(sys, t, "impulse")


# ---------------------------------------------------------------------- python-control
def to_control(sys: ModalStateSpace):
    """The model as a ``control.StateSpace`` with named inputs, outputs and states
    (python-control is needed only for this; it is imported here)."""
    import control

    return control.StateSpace(sys.A, sys.B, sys.C, sys.D, inputs=list(sys.inputs),
                              outputs=list(sys.outputs), states=list(sys.states))


def from_control(ss, rtol: float = 1e-9) -> ModalStateSpace:
    """A :class:`ModalStateSpace` from a ``control.StateSpace`` already in modal form (2x2
    blocks [0 1; −ω² −2ζω] on the diagonal, zero first row of B in each block); any other
    realisation is refused with an InputError. Modes are numbered 1.. in state order."""
    A, B, C, D = (np.asarray(x, float) for x in (ss.A, ss.B, ss.C, ss.D))
    n = A.shape[0]
    scale = max(1.0, np.abs(A).max())
    m = n // 2
    mask = np.zeros_like(A, bool)
    i = np.arange(m)
    for r, c in ((0, 0), (0, 1), (1, 0), (1, 1)):
        mask[2 * i + r, 2 * i + c] = True
    ok = n % 2 == 0 and np.all(np.abs(A[~mask]) <= rtol * scale)
    ok = ok and np.allclose(A[2 * i, 2 * i], 0, atol=rtol * scale)
    ok = ok and np.allclose(A[2 * i, 2 * i + 1], 1.0, rtol=rtol)
    ok = ok and np.all(np.abs(B[0::2]) <= rtol * max(1.0, np.abs(B).max()))
    omega2 = -A[2 * i + 1, 2 * i] if ok else np.zeros(m)
    if not ok or np.any(omega2 < -rtol * scale):
        raise InputError("state space", f"{n} states",
                         "needs the modal form x = [q1, q1', ...] with blocks [0 1; -w^2 -2 zeta w]")
    rigid = omega2 <= rtol * scale
    flexible = omega2[~rigid]
    w1 = float(flexible.min()) if flexible.size else scale  # omega_1^2, the lowest flexible
    neg = np.flatnonzero(omega2 < -NEGATIVE_EIGENVALUE_TOL * w1)
    if neg.size:  # a negative stiffness is not a rigid mode: never made one silently
        k = int(neg[0])
        raise InputError(f"state space mode {k + 1}", f"omega^2 = {omega2[k]:.3e} rad^2/s^2",
                         f"a mode's omega^2 must not be negative (below -{NEGATIVE_EIGENVALUE_TOL:g} "
                         f"omega_1^2 = {-NEGATIVE_EIGENVALUE_TOL * w1:.3e}): an unstable block is "
                         "not a rigid mode")
    omega = np.sqrt(np.clip(omega2, 0.0, None))
    omega[rigid] = 0.0
    c2 = -A[2 * i + 1, 2 * i + 1]
    if np.any(np.abs(c2[omega == 0]) > rtol * scale):
        raise InputError("state space", c2[omega == 0].tolist(), "rigid modes must be undamped")
    zeta = np.divide(c2, 2 * omega, out=np.zeros(m), where=omega > 0)
    return ModalStateSpace.from_modal(omega, zeta, B[1::2], C[:, 0::2], C[:, 1::2], D,
                                      getattr(ss, "input_labels", None),
                                      getattr(ss, "output_labels", None))
