"""Static equilibrium of the structure on the seabed under given bag lifts (docs/theory/statics.md#equilibrium).

The finite-element beam (:mod:`flexlift.structure.beam`) under its wet weight, point masses
and the bags' lifts rests on a one-sided seabed: a spring at every node, of the scenario's
contact stiffness times the node's tributary length, acting only where the node would sink
below its resting level (w < 0). The contact set is found by an active-set iteration: solve
(K + K_s(A)) u = f with the springs of the set A, take as the new set the nodes below the
seabed, repeat until the set no longer changes (each solve is one banded sparse
factorisation; a few to a few dozen for a peeled pipeline).

When the lifts carry the whole wet weight (within :data:`FLOAT_TOLERANCE`) nothing holds the
structure on the seabed and there is no static equilibrium with contact: the structure hangs
in its bags. Its shape is then the inertia-relief solution (the load less its rigid-body
resultant, which would accelerate it; that resultant is reported) with the lowest point put
on the seabed. The mass that accelerates is the structure's plus the water moving with it
(added mass and entrained water, :func:`flexlift.physics.hydro.moving_water_per_length`), as
in the ascent and the design cases of :mod:`flexlift.loads.design`.

The suction of a buried structure is a breakout effect of the ascent, not part of these
statics. Bending moment by statics of all the loads (:func:`flexlift.loads.strength.shear_moment`,
sagging positive), stress M / Z against the allowable stress.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from flexlift.errors import SimulationError
from flexlift.loads.strength import line_load_vector, point_load_vector, shear_moment
from flexlift.structure.beam import assemble
from flexlift.structure.hull import Hull

#: lifts within this fraction of the wet weight carry it all: the structure floats
FLOAT_TOLERANCE = 1e-6
MAX_ITERATIONS = 500
#: a free span lower than this between two contacts is the seabed springs' ripple [m]
TOUCH_TOLERANCE_M = 1e-3


def suspended_length(EI: float, q: float, h: float) -> float:
    """Length [m] a long heavy beam lifted off a rigid seabed at one end to a height ``h`` [m]
    hangs free over (docs/theory/statics.md#peel-off, small slopes): l = (24 EI h / q)^(1/4), EI [N m^2], q its wet
    weight per length [N/m]; the lifting force is q l / 2 and the largest moment q l^2 / 8."""
    return (24.0 * EI * h / q) ** 0.25


@dataclass(frozen=True)
class Statics:
    """The static state: node heights, slopes, contact, moment and utilisation (SI)."""

    x: np.ndarray  # (N,) node positions [m]
    w: np.ndarray  # (N,) height above the resting level [m]
    slope: np.ndarray  # (N,) dw/dx [rad]
    contact: np.ndarray  # (N,) bool, node on the seabed
    reaction: np.ndarray  # (N,) seabed force on each node, up positive [N]
    moment: np.ndarray  # (N,) bending moment, sagging positive [N m]
    utilisation: np.ndarray  # (N,) |M| / Z / sigma_allow [-]
    lifts: dict  # bag name -> lift [N]
    net_force: float  # sum of lifts - wet weight (> 0: the structure would rise) [N]
    floating: bool  # no contact: the lifts carry the whole wet weight
    iterations: int
    warnings: tuple[str, ...] = field(default=())

    @property
    def touchdown_x(self) -> list[float]:
        """Where the structure leaves or meets the seabed along the line [m] (midway between
        the nodes). A free span that never rises :data:`TOUCH_TOLERANCE_M` above the seabed
        (the spring seabed's ripple just beyond a touchdown) counts as resting."""
        down = self.contact.copy()
        edges = np.flatnonzero(np.diff(down.astype(int))) + 1
        for a, b in zip(np.r_[0, edges], np.r_[edges, down.size]):
            if not down[a] and self.w[a:b].max() < TOUCH_TOLERANCE_M and a > 0 and b < down.size:
                down[a:b] = True
        i = np.flatnonzero(np.diff(down.astype(int)))
        return [float(0.5 * (self.x[k] + self.x[k + 1])) for k in i]

    @property
    def max_slope_deg(self) -> float:
        return float(np.degrees(np.arctan(np.max(np.abs(self.slope)))))

    def peak_moment(self) -> tuple[float, float]:
        """(M [N m], x [m]) of the largest |M|."""
        i = int(np.argmax(np.abs(self.moment)))
        return float(self.moment[i]), float(self.x[i])


def weight_vector(hull: Hull, q_el: np.ndarray, point_weights: np.ndarray) -> np.ndarray:
    """Consistent nodal loads of the downward wet weight: ``q_el`` [N/m] uniform on each
    element and ``point_weights`` [N] at the nodes (both downward positive)."""
    l = hull.element_length
    n = hull.n_elements
    fe = -q_el[:, None] * l * np.array([0.5, l / 12.0, 0.5, -l / 12.0])[None, :]
    f = np.zeros(2 * hull.n_nodes)
    np.add.at(f, 2 * np.arange(n)[:, None] + np.arange(4)[None, :], fe)
    f[0::2] -= point_weights
    return f


def bag_vector(hull: Hull, plan, lifts: dict) -> np.ndarray:
    f = np.zeros(2 * hull.n_nodes)
    for b in plan.bags:
        F = lifts[b.name]
        if b.kind == "external":
            f += point_load_vector(hull, b.x, F)
        else:
            x0, x1 = b.span
            f += line_load_vector(hull, x0, x1, F / (x1 - x0))
    return f


def solve(hull: Hull, plan, lifts: dict, stiffness: float, q_el: np.ndarray,
          point_weights: np.ndarray, modulus: np.ndarray, allowable: float,
          slope_validity_deg: float, water_mass: float = 0.0) -> Statics:
    """The static state of ``hull`` under bag ``lifts`` [N by name] on a seabed of spring
    ``stiffness`` [N/m per m]; ``q_el`` wet weight per element [N/m], ``point_weights`` [N]
    per node, ``modulus`` Z: section modulus per element [m^3], ``allowable`` stress [Pa]; slopes
    beyond ``slope_validity_deg`` (the small-deflection beam's validity) are warned about;
    ``water_mass`` [kg/m] the water accelerating with a floating structure."""
    n_nodes = hull.n_nodes
    K = assemble(hull).K.tocsc()
    f = weight_vector(hull, q_el, point_weights) + bag_vector(hull, plan, lifts)
    wet = float(q_el.sum() * hull.element_length + point_weights.sum())
    net = float(sum(lifts.values()) - wet)
    k_node = stiffness * tributary_lengths(hull.x_nodes)
    accel = (0.0, 0.0)
    if net >= -FLOAT_TOLERANCE * wet:
        u, accel = _inertia_relief(hull, K, f, water_mass)
        active, iterations = np.zeros(n_nodes, dtype=bool), 0
    else:
        u, active, iterations = _active_set(K, f, k_node)
    w, th = u[0::2], u[1::2]
    reaction = np.where(active, -k_node * w, 0.0)
    M = _moment(hull, q_el, point_weights, plan, lifts, reaction, accel, water_mass)
    Z = modulus
    Zn = np.minimum(np.r_[Z[0], Z], np.r_[Z, Z[-1]])  # the weaker element at each node
    util = np.abs(M) / Zn / allowable
    return Statics(x=hull.x_nodes, w=w, slope=th, contact=active, reaction=reaction, moment=M,
                   utilisation=util, lifts=dict(lifts), net_force=net,
                   floating=not active.any(), iterations=iterations,
                   warnings=tuple(_warnings(hull, th, net, wet, plan.gravity,
                                            slope_validity_deg)))


def _active_set(K, f, k_node) -> tuple[np.ndarray, np.ndarray, int]:
    n_nodes = k_node.size
    active = np.ones(n_nodes, dtype=bool)
    seen = set()
    for it in range(1, MAX_ITERATIONS + 1):
        diag = np.zeros(2 * n_nodes)
        diag[0::2] = np.where(active, k_node, 0.0)
        u = spla.spsolve((K + sp.diags(diag)).tocsc(), f)
        if not np.all(np.isfinite(u)):
            raise SimulationError("statics: the contact solve failed (a structure balanced on "
                                  "one point); change the lifts")
        new = u[0::2] < 0.0
        if np.array_equal(new, active):
            return u, active, it
        key = new.tobytes()
        if key in seen:  # a cycle between contact sets
            raise SimulationError("statics: the contact set does not settle (cycling); "
                                  "refine the mesh or change the lifts")
        seen.add(key)
        active = new
        if not active.any():  # lifted clear while the lifts are short of the weight: cannot be
            raise SimulationError("statics: no contact found although the lifts are short of "
                                  "the wet weight")
    raise SimulationError(f"statics: the contact set did not settle in {MAX_ITERATIONS} "
                          "iterations")


def _inertia_relief(hull: Hull, K, f, water_mass: float = 0.0
                    ) -> tuple[np.ndarray, tuple[float, float]]:
    """The free structure's elastic shape under ``f`` less its rigid-body resultant (the
    resultant shared by mass, as inertia), levelled and with its lowest node at w = 0; and
    the rigid accelerations (heave [m/s^2], pitch about the mid-length [rad/s^2]) that
    resultant gives to the structure and the ``water_mass`` [kg/m] moving with it."""
    M = assemble(hull, extra_mass_per_length=water_mass).M.tocsc()
    x = hull.x_nodes
    R = np.zeros((2 * hull.n_nodes, 2))
    R[0::2, 0] = 1.0
    R[0::2, 1] = x - x.mean()
    R[1::2, 1] = 1.0
    MR = M @ R
    acc = np.linalg.solve(R.T @ MR, R.T @ f)
    f_rel = f - MR @ acc
    keep = np.arange(2, 2 * hull.n_nodes)  # clamp node 0, then remove the rigid part
    u = np.zeros(2 * hull.n_nodes)
    u[keep] = spla.spsolve(K[keep][:, keep].tocsc(), f_rel[keep])
    u -= R @ np.linalg.solve(R.T @ MR, MR.T @ u)
    u[0::2] -= u[0::2].min()
    return u, (float(acc[0]), float(acc[1]))


def _moment(hull, q_el, point_weights, plan, lifts, reaction, accel, water_mass=0.0
            ) -> np.ndarray:
    x = hull.x_nodes
    xg = np.repeat(x, 2)[1:-1]  # each element's two ends: the weight is uniform on it
    a = accel[0] + accel[1] * (xg - x.mean())  # rigid acceleration of a floating structure
    qg = -np.repeat(q_el, 2) - np.repeat(hull.mass_per_length + water_mass, 2) * a
    a_nodes = accel[0] + accel[1] * (x - x.mean())
    point = reaction - point_weights - hull.point_masses * a_nodes
    pts = [(float(xj), float(Fj)) for xj, Fj in zip(x, point) if Fj]
    for b in plan.bags:
        if b.kind == "external":
            pts.append((b.x, lifts[b.name]))
        else:
            x0, x1 = b.span
            inside = (xg >= x0) & (xg <= x1)  # on the element grid (its nodes)
            qg = qg + np.where(inside, lifts[b.name] / (x1 - x0), 0.0)
    _, M = shear_moment(xg, qg, pts)
    return np.r_[M[0::2], M[-1]]


def _warnings(hull, th, net, wet, g, limit_deg) -> list[str]:
    out = []
    slope = np.degrees(np.arctan(np.abs(th)))
    over = slope > limit_deg
    if over.any():
        xs = hull.x_nodes[over]
        out.append(f"slope up to {slope.max():.1f} deg at x = {xs.min():.1f}..{xs.max():.1f} m "
                   f"exceeds the small-deflection beam's validity ({limit_deg:g} deg, "
                   "limits.slope_validity_deg)")
    if net > FLOAT_TOLERANCE * wet:
        out.append(f"the lifts exceed the wet weight by {net / (1e3 * g):.1f} t: the structure "
                   "rises (no static equilibrium); shown is its shape hanging in the bags")
    return out


def scenario_statics(scenario, lifts_t: dict | None = None, hull: Hull | None = None,
                     stiffness: float | None = None) -> Statics:
    """:func:`solve` for a scenario: its hull, plan and seabed; ``lifts_t`` bag lifts in tonnes
    by bag (or cluster) name, the rest at the plan's holding lifts."""
    from flexlift import constants as C
    from flexlift.errors import InputError
    from flexlift.loads.liftplan import plan_lift
    from flexlift.physics.hydro import moving_water_per_length
    from flexlift.structure.hull import hull_from_scenario

    env = scenario.environment
    g, rho, rho_s = env.gravity_m_s2, env.seawater_density_kg_m3, env.steel_density_kg_m3
    hull = hull or hull_from_scenario(scenario)
    plan = plan_lift(scenario, hull)
    lifts = dict(zip([b.name for b in plan.bags], plan.holding_lifts().tolist()))
    for name, t in (lifts_t or {}).items():
        members = [b for b in lifts if b == name or b.rsplit("_", 1)[0] == name]
        if not members:
            raise InputError("--lift", name, f"no such bag; bags are {_names(lifts)}")
        if not (math.isfinite(t) and t >= 0):
            raise InputError(f"--lift {name}", t, "must be a lift of 0 t or more")
        for b in members:
            lifts[b] = t * C.TONNE * g
    Z = np.broadcast_to(np.asarray(scenario.hull.section_modulus_m3, dtype=float),
                        (scenario.hull.elements,))
    if Z.size != hull.n_elements:
        Z = Z[np.minimum((np.arange(hull.n_elements) + 0.5) / hull.n_elements * Z.size,
                         Z.size - 1).astype(int)]
    k = scenario.seabed.contact_stiffness_N_m2 if stiffness is None else stiffness
    hy = scenario.hydro
    water = moving_water_per_length(hull.breadth, rho, hy.added_mass_coefficient,
                                    hy.entrained_water_t * C.TONNE, hull.length)
    return solve(hull, plan, lifts, k, hull.wet_weight_per_length(g, rho, rho_s),
                 hull.point_wet_weights(g, rho, rho_s), Z,
                 scenario.hull.allowable_stress_MPa * 1e6, scenario.limits.slope_validity_deg,
                 water)


def _names(lifts: dict) -> str:
    names = list(lifts)
    return ", ".join(names[:8]) + (f", ... ({len(names)})" if len(names) > 8 else "")


def tributary_lengths(x: np.ndarray) -> np.ndarray:
    """Length of structure each node stands for [m]: half of each neighbouring element (the
    end nodes half an element); they sum to the length."""
    h = np.diff(np.asarray(x, dtype=float))
    return np.r_[0.5 * h, 0.0] + np.r_[0.0, 0.5 * h]


def contact_length(st: Statics) -> float:
    """Length of structure on the seabed [m]: the tributary lengths of the nodes in contact
    (every node in contact: the whole length)."""
    return float(tributary_lengths(st.x)[st.contact].sum())


def summary(st: Statics, g: float) -> dict:
    """The JSON summary (tonnes, metres, MN m, degrees)."""
    M, xm = st.peak_moment()
    i = int(np.argmax(st.utilisation))
    return {
        "touchdown_x_m": st.touchdown_x,
        "max_height_m": float(st.w.max()),
        "max_moment_MNm": {"value": M / 1e6, "x_m": xm},
        "max_slope_deg": st.max_slope_deg,
        "max_utilisation": float(st.utilisation[i]),
        "max_utilisation_x_m": float(st.x[i]),
        "lift_t": {k: v / (1e3 * g) for k, v in st.lifts.items()},
        "net_lift_t": st.net_force / (1e3 * g),
        "contact_length_m": contact_length(st),
        "floating": st.floating,
        "iterations": st.iterations,
        "warnings": list(st.warnings),
    }
