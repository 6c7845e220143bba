"""Loads on the hull and its longitudinal strength (docs/theory/strength.md#shear-moment).

Sign conventions (used by every function here):

- Forces and line loads are positive **upward** [N], [N/m]; x runs from the aft end (0) to
  the bow (L) [m].
- Shear force V(x) is the sum of the upward forces **aft of** x [N].
- Bending moment M(x) is the moment about x of the forces aft of x,
  ``M(x) = integral_0^x q(s) (x - s) ds + sum_i F_i (x - x_i)`` [N m]; with upward forces
  positive this makes **sagging positive** (ends up, middle down: a beam on two end supports
  under its own weight has M > 0), hogging negative, and dM/dx = V.
- For a load case in equilibrium V(L) = M(L) = 0; the values at the bow are the closing
  errors (the imbalance of the load case), reported, never hidden.

Consistent nodal loads (virtual work with the Hermite shape functions of
:mod:`flexlift.structure.beam`) are vectors of length 2 (n + 1) in the DOF order
``[w_0, theta_0, w_1, theta_1, ...]``: forces [N] on the w entries, moments [N m] (bow-up
positive) on the theta entries. They reproduce the resultant (sum of the force entries) and
its moment about the aft end (``sum f_w x_node + sum f_theta``) exactly.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from flexlift.errors import InputError
from flexlift.structure.beam import element_of, point_load_vector, shape_functions  # noqa: F401 (re-exported)
from flexlift.structure.hull import Hull

# 3-point Gauss-Legendre on [0, 1]: exact to degree 5 (a cubic shape function times a
# linearly varying load is degree 4)
_GL_T, _GL_W = np.polynomial.legendre.leggauss(3)
_GL_T = 0.5 * (_GL_T + 1.0)
_GL_W = 0.5 * _GL_W


# ----------------------------------------------------------------------------- load data
@dataclass(frozen=True)
class PointLoad:
    """A concentrated force: name, position x [m], force (upward positive) [N]."""

    name: str
    x: float
    force: float


@dataclass(frozen=True)
class LineLoad:
    """A distributed load over [x0, x1] [m], linear from q0 at x0 to q1 at x1 (q1 = q0 when
    omitted), upward positive [N/m]."""

    name: str
    x0: float
    x1: float
    q0: float
    q1: float | None = None

    @property
    def q_end(self) -> float:
        return self.q0 if self.q1 is None else self.q1

    @property
    def resultant(self) -> float:
        """Total force [N]."""
        return 0.5 * (self.q0 + self.q_end) * (self.x1 - self.x0)

    @property
    def moment_about_aft(self) -> float:
        """Moment of the load about x = 0, sum of force times x [N m]."""
        h = self.x1 - self.x0
        # centroid of a trapezoid
        return self.x0 * self.resultant + h * h * (self.q0 / 6.0 + self.q_end / 3.0)


@dataclass(frozen=True)
class LoadCase:
    """A static load case on a beam of length ``length`` [m]."""

    length: float
    line_loads: tuple[LineLoad, ...] = ()
    point_loads: tuple[PointLoad, ...] = ()

    def __post_init__(self):
        L = self.length
        tol = 1e-9 * L
        for p in self.point_loads:
            if not -tol <= p.x <= L + tol:
                raise InputError(f"load {p.name}.x", p.x, f"must lie on the hull, 0..{L:g} m")
        for d in self.line_loads:
            if not (-tol <= d.x0 < d.x1 <= L + tol):
                raise InputError(
                    f"load {d.name}.span", [d.x0, d.x1], f"must be increasing within 0..{L:g} m"
                )

    @property
    def total_force(self) -> float:
        """Resultant of all loads, upward positive [N]."""
        return float(sum(d.resultant for d in self.line_loads) + sum(p.force for p in self.point_loads))

    @property
    def moment_about_aft(self) -> float:
        """Sum of force times x of all loads [N m] (bow-down moment of upward forces)."""
        return float(
            sum(d.moment_about_aft for d in self.line_loads)
            + sum(p.force * p.x for p in self.point_loads)
        )

    def line_load(self, x: np.ndarray, from_aft: np.ndarray | bool = False) -> np.ndarray:
        """The distributed load sampled at ``x`` [m], upward positive [N/m].

        At a span end the value is the limit from the forward side, or from the aft side
        where ``from_aft`` is True (a bool or a bool array like x).
        """
        x = np.asarray(x, dtype=float)
        fa = np.broadcast_to(np.asarray(from_aft, dtype=bool), x.shape)
        q = np.zeros_like(x)
        # on a sorted 1-D grid each load touches only the samples of its span (found by
        # bisection): a structure of thousands of per-element loads costs O(samples), not
        # O(samples x loads)
        ordered = x.ndim == 1 and bool(np.all(np.diff(x) >= 0))
        for d in self.line_loads:
            lo, hi = ((int(np.searchsorted(x, d.x0, "left")), int(np.searchsorted(x, d.x1, "right")))
                      if ordered else (0, x.size))
            xs, fs = x.reshape(-1)[lo:hi], fa.reshape(-1)[lo:hi]
            inside = np.where(fs, (xs > d.x0) & (xs <= d.x1), (xs >= d.x0) & (xs < d.x1))
            t = (xs - d.x0) / (d.x1 - d.x0)
            q.reshape(-1)[lo:hi] += np.where(inside, d.q0 + (d.q_end - d.q0) * t, 0.0)
        return q

    def mirrored(self) -> LoadCase:
        """The same loads with the beam turned end for end (x -> L - x)."""
        L = self.length
        return LoadCase(
            L,
            tuple(LineLoad(d.name, L - d.x1, L - d.x0, d.q_end, d.q0) for d in self.line_loads),
            tuple(PointLoad(p.name, L - p.x, p.force) for p in self.point_loads),
        )


# ----------------------------------------------------------------------------- nodal loads
def line_load_vector(
    hull: Hull, x0: float, x1: float, q0: float, q1: float | None = None
) -> np.ndarray:
    """Consistent nodal loads of a distributed load over any span [x0, x1] [m], which may
    start and end inside elements; linear from q0 to q1 (uniform when q1 is None) [N/m,
    upward positive]. Integrated exactly (3-point Gauss-Legendre on each element piece).

    returns : ndarray (2 (n + 1),) — nodal forces [N] and moments [N m]
    """
    L = hull.length
    tol = 1e-9 * L
    if not (np.isfinite(x0) and np.isfinite(x1) and -tol <= x0 < x1 <= L + tol):
        raise InputError("line load span", [x0, x1], f"must be increasing within 0..{L:g} m")
    x0, x1 = max(float(x0), 0.0), min(float(x1), L)
    q1 = q0 if q1 is None else q1
    l = hull.element_length
    edges = hull.x_nodes
    e_lo = max(int(np.searchsorted(edges, x0, side="right")) - 1, 0)
    e_hi = min(int(np.searchsorted(edges, x1, side="left")), hull.n_elements)
    elems = np.arange(e_lo, e_hi)
    a = np.maximum(edges[elems], x0)
    b = np.minimum(edges[elems + 1], x1)
    keep = b > a
    elems, a, b = elems[keep], a[keep], b[keep]
    xg = a[:, None] + (b - a)[:, None] * _GL_T[None, :]  # (ne, 3)
    qg = q0 + (q1 - q0) * (xg - x0) / (x1 - x0)
    xi = (xg - edges[elems][:, None]) / l
    N = shape_functions(xi, l)  # (ne, 3, 4)
    fe = np.einsum("eg,eg,egk->ek", (b - a)[:, None] * _GL_W[None, :], qg, N)
    f = np.zeros(2 * hull.n_nodes)
    dofs = 2 * elems[:, None] + np.arange(4)[None, :]
    np.add.at(f, dofs, fe)
    return f


def nodal_loads(hull: Hull, case: LoadCase) -> np.ndarray:
    """Consistent nodal force/moment vector of a whole load case, shape (2 (n + 1),)."""
    f = np.zeros(2 * hull.n_nodes)
    for d in case.line_loads:
        f += line_load_vector(hull, d.x0, d.x1, d.q0, d.q1)
    for p in case.point_loads:
        f += point_load_vector(hull, p.x, p.force)
    return f


def resultant_of(hull: Hull, f: np.ndarray) -> tuple[float, float]:
    """Resultant force [N] and its moment about the aft end (sum of force times x) [N m]
    of a nodal load vector ``f`` (the virtual work on heave and on w = x, theta = 1)."""
    f = np.asarray(f, dtype=float)
    return float(f[0::2].sum()), float(f[0::2] @ hull.x_nodes + f[1::2].sum())


def bag_load_matrix(plan, hull: Hull) -> np.ndarray:
    """Consistent nodal loads of each bag per newton of its lift, one column per bag in
    ``plan.bags`` order: external bags as point forces, internal bags as uniform loads over
    their spans. ``B @ lifts`` [N] gives the nodal force/moment vector of the bags.

    returns : ndarray (2 (n + 1), n_bags) [N/N, N m/N]
    """
    cols = []
    for b in plan.bags:
        if b.kind == "external":
            cols.append(point_load_vector(hull, b.x, 1.0))
        else:
            x0, x1 = b.span
            cols.append(line_load_vector(hull, x0, x1, 1.0 / (x1 - x0)))
    return np.column_stack(cols) if cols else np.zeros((2 * hull.n_nodes, 0))


# ----------------------------------------------------------------------------- the lift case
def lift_load_case(
    plan, hull: Hull, bag_lifts: dict[str, float] | None = None, weight_factor: float | None = None
) -> LoadCase:
    """The lift plan's load case: downward weight plus breakout, bags pulling up.

    plan : :class:`~flexlift.loads.liftplan.LiftPlan`
    hull : the beam the plan was laid out on
    bag_lifts : lift of each bag by name [N]; default every bag at its full rated lift
    weight_factor : total downward load / wet weight [-]; default the plan's breakout
        factor (1.3: weight plus suction breakout, docs/theory/factors.md#breakout-factor)

    The downward load follows the mass distribution: each element carries
    ``weight_factor * (W'/W) * m_e g`` per metre, point masses give point loads. For a uniform
    hull (the tanker) this is the uniform line load ``weight_factor * W' / L`` of docs/theory/strength.md#load-case
    External bags are point forces at their positions, internal bags uniform loads over
    their spans.
    """
    k = plan.breakout_factor if weight_factor is None else float(weight_factor)
    wet_ratio = plan.wet_weight / plan.dry_weight
    g = plan.gravity
    q_el = -k * wet_ratio * g * hull.mass_per_length  # [N/m] per element
    if hull.density is not None:  # a pipe: each element's own wet weight
        q_el = -k * hull.wet_weight_per_length(g, plan.seawater_density, plan.steel_density)
    edges = hull.x_nodes
    line: list[LineLoad] = []
    if np.allclose(q_el, q_el[0], rtol=1e-12, atol=0.0):
        line.append(LineLoad("weight", 0.0, hull.length, float(q_el[0])))
    else:
        line += [
            LineLoad(f"weight_e{e + 1}", float(edges[e]), float(edges[e + 1]), float(q))
            for e, q in enumerate(q_el)
        ]
    pw = k * wet_ratio * g * hull.point_masses
    if hull.density is not None:
        pw = k * hull.point_wet_weights(g, plan.seawater_density, plan.steel_density)
    points = [
        PointLoad(f"weight_n{j + 1}", float(edges[j]), float(-pw[j]))
        for j, m in enumerate(hull.point_masses)
        if m > 0
    ]
    lifts = {} if bag_lifts is None else dict(bag_lifts)
    unknown = sorted(set(lifts) - {b.name for b in plan.bags})
    if unknown:
        raise InputError("bag_lifts", unknown, f"known bags are {[b.name for b in plan.bags]}")
    for b in plan.bags:
        F = float(lifts.get(b.name, b.lift))
        if b.kind == "external":
            points.append(PointLoad(b.name, b.x, F))
        else:
            x0, x1 = b.span
            line.append(LineLoad(b.name, x0, x1, F / (x1 - x0)))
    return LoadCase(hull.length, tuple(line), tuple(points))


# ----------------------------------------------------------------------------- statics
def line_integrals(x: np.ndarray, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The line load's shear and moment (..., nx) of :func:`shear_moment` (no point loads):
    V by the trapezoidal rule, M by the exact moment of the piecewise-linear q, each summed
    from the aft end in grid order."""
    h = np.diff(x)
    Vq = np.concatenate(
        [np.zeros(q.shape[:-1] + (1,)), np.cumsum(0.5 * h * (q[..., :-1] + q[..., 1:]), -1)], -1
    )
    dM = Vq[..., :-1] * h + h * h * (q[..., :-1] / 3.0 + q[..., 1:] / 6.0)
    Mq = np.concatenate([np.zeros(q.shape[:-1] + (1,)), np.cumsum(dM, -1)], -1)
    return Vq, Mq


def shear_moment(x, q, point_loads: Sequence = (), keep=None,
                 integrate=line_integrals) -> tuple[np.ndarray, np.ndarray]:
    """Shear force and bending moment of a free beam by statics, integrated from the aft end.

    x : ndarray (nx,) — non-decreasing grid from 0 to L [m]. A repeated value marks a jump:
        the first sample of the pair is the limit from the aft side (a point load at that x
        not yet counted, q its aft value), the second the limit from the forward side.
    q : ndarray (..., nx) — distributed line load sampled on x, upward positive [N/m];
        leading dimensions (e.g. time) broadcast
    point_loads : sequence of (x_i [m], F_i [N]) — F_i a float or an ndarray broadcastable
        to q.shape[:-1], upward positive; x_i within [x[0], x[-1]]
    keep : ndarray of int, optional — only these points' values are returned (..., keep.size):
        the same numbers as ``V[..., keep]``, with the point loads added at those points
        alone (a run's strength keeps about one point in five)
    integrate : callable, optional — ``(x, q) -> (Vq, Mq)``, the line load's part
        (:func:`line_integrals`, or a compiled equivalent summing in the same order)
    returns : (V, M), each ndarray (..., nx)
        V(x) = integral of q from x[0] to x (trapezoidal, exact for the piecewise-linear
        interpolant of the samples) plus the point loads at x_i <= x [N];
        M(x) = moment about x of the forces aft of x, sagging positive (upward forces at
        the ends and downward in the middle give M > 0), dM/dx = V [N m]; the moment of the
        piecewise-linear q is integrated exactly.

    The values at x = L are the closing errors: zero for a load case in equilibrium.
    """
    x = np.asarray(x, dtype=float)
    q = np.asarray(q, dtype=float)
    if x.ndim != 1 or x.size < 2 or not np.all(np.isfinite(x)):
        raise InputError("x", f"shape {x.shape}", "need a finite 1-D grid of at least 2 points [m]")
    if np.any(np.diff(x) < 0):
        raise InputError("x", "decreasing values", "the grid must be non-decreasing [m]")
    if q.ndim < 1 or q.shape[-1] != x.size:
        raise InputError("q", f"shape {q.shape}", f"last dimension must match x ({x.size})")
    Vq, Mq = integrate(x, q)
    pts = [(float(xi), np.asarray(F, dtype=float)) for xi, F in point_loads]
    lead = np.broadcast_shapes(q.shape[:-1], *(F.shape for _, F in pts))
    idx = np.arange(x.size)
    xk = x
    if keep is not None:  # each value is its point's own sum: the kept points' alone
        idx = np.asarray(keep, dtype=np.intp)
        Vq, Mq, xk = Vq[..., idx], Mq[..., idx], x[idx]
    V = np.broadcast_to(Vq, lead + (idx.size,)).copy()
    M = np.broadcast_to(Mq, lead + (idx.size,)).copy()
    span = x[-1] - x[0]
    for xi, F in pts:
        if not (np.isfinite(xi) and x[0] - 1e-12 * span <= xi <= x[-1] + 1e-12 * span):
            raise InputError("point load x", xi, f"must lie on the grid, {x[0]:g}..{x[-1]:g} m")
        start = int(np.searchsorted(x, xi, side="left"))
        if start + 1 < x.size and x[start] == xi and x[start + 1] == xi:
            start += 1  # the first of a repeated pair is the aft-side limit
        V += F[..., None] * (idx >= start)
        M += F[..., None] * np.clip(xk - xi, 0.0, None)
    return V, M


# ----------------------------------------------------------------------------- strength
def sample_grid(case: LoadCase, n_elements: int, per_element: int = 50) -> np.ndarray:
    """A fine grid over the beam for :func:`shear_moment`: ``per_element`` intervals per
    element plus every load discontinuity (span ends, point-load positions), the
    discontinuities inside the beam repeated so that both one-sided limits are sampled.
    returns : ndarray — non-decreasing positions [m]
    """
    if int(per_element) < 1:
        raise InputError("per_element", per_element, "need at least 1 sample interval per element")
    L = case.length
    base = np.linspace(0.0, L, int(n_elements) * int(per_element) + 1)
    breaks = {min(max(p.x, 0.0), L) for p in case.point_loads}
    breaks |= {min(max(v, 0.0), L) for d in case.line_loads for v in (d.x0, d.x1)}
    tol = 1e-9 * L
    pts = list(base)
    for b in sorted(breaks):
        k = int(np.argmin(np.abs(base - b)))
        if abs(base[k] - b) <= tol:
            pts[k] = b  # snap the grid point onto the break (exact comparisons later)
    pts_arr = np.array(pts)
    jumps = [b for b in sorted(breaks) if (0.0 < b < L) or any(p.x == b for p in case.point_loads)]
    extra = [b for b in sorted(breaks) if not np.any(pts_arr == b)]
    return np.sort(np.concatenate([pts_arr, extra, jumps]))


def line_load_on_grid(case: LoadCase, x: np.ndarray) -> np.ndarray:
    """``case``'s distributed load on a grid from :func:`sample_grid` [N/m]: the aft-side
    value at the first of a repeated pair and at the bow, the forward-side value elsewhere."""
    x = np.asarray(x, dtype=float)
    from_aft = np.zeros(x.shape, dtype=bool)
    from_aft[:-1] = x[:-1] == x[1:]
    from_aft[-1] = True
    return case.line_load(x, from_aft)


@dataclass(frozen=True)
class Extreme:
    """An extreme value along the hull: the signed value at the extreme of the magnitude
    (its unit is the quantity's), its position x [m] and the nearest node (1-based)."""

    value: float
    x: float
    node: int


@dataclass(frozen=True)
class Strength:
    """Shear force and bending moment of a load case (conventions: module docstring).

    x : sample positions [m]; V : shear force [N]; M : bending moment, sagging positive [N m]
    max_shear, max_moment : largest |V| and |M| [N], [N m]
    max_sagging, max_hogging : largest positive and most negative M [N m]
    closing_shear, closing_moment : V and M at the bow, the imbalance [N], [N m]
    total_force : resultant of the loads, upward positive [N]
    moment_about_aft : sum of force times x [N m]
    """

    x: np.ndarray
    V: np.ndarray
    M: np.ndarray
    max_shear: Extreme
    max_moment: Extreme
    max_sagging: Extreme
    max_hogging: Extreme
    closing_shear: float
    closing_moment: float
    total_force: float
    moment_about_aft: float


def strength(case: LoadCase, hull: Hull, per_element: int = 50) -> Strength:
    """V(x) and M(x) of ``case`` on ``hull``, sampled finely (``per_element`` intervals per
    element plus both sides of every load discontinuity), with their extremes."""
    x = sample_grid(case, hull.n_elements, per_element)
    q = line_load_on_grid(case, x)
    V, M = shear_moment(x, q, [(p.x, p.force) for p in case.point_loads])

    def extreme(values: np.ndarray, k: int) -> Extreme:
        return Extreme(float(values[k]), float(x[k]), hull.nearest_node(float(x[k])) + 1)

    return Strength(
        x=x,
        V=V,
        M=M,
        max_shear=extreme(V, int(np.argmax(np.abs(V)))),
        max_moment=extreme(M, int(np.argmax(np.abs(M)))),
        max_sagging=extreme(M, int(np.argmax(M))),
        max_hogging=extreme(M, int(np.argmin(M))),
        closing_shear=float(V[-1]),
        closing_moment=float(M[-1]),
        total_force=case.total_force,
        moment_about_aft=case.moment_about_aft,
    )
