"""The coupled plant of the ascent: a wet flexible hull, its bags' gas and the seabed (SPEC §5-8).

Hull motion w(x, t) = sum_j psi_j(x) q_j(t) over the wet modes (mass-normalised with the
structural plus added mass): rigid heave and pitch and ``retained_flexible_modes`` flexible
modes integrated in time; the higher modes enter the reported displacements as their static
(mdc) correction, sum over eliminated modes of psi_j(x) Q_j / omega_j^2.

State vector ``x = [q (nr), q' (nr), n (nb), H]``: modal coordinates [m sqrt(kg)], their rates,
the bags' gas [mol] and the suction holding force [N]. Inputs ``u = [Q_in (nb), u_v (nb)]``:
fill flows at local pressure [m^3/s] and purge valve openings [-]. The one dynamics function
is :func:`dynamics` ``f(t, x, u, params) -> (dx/dt, aux)``.

Distributed loads are integrated over the hull with 4-point Gauss-Legendre per element
("strips"); the bags act at their points (external) or as uniform loads over their spans
(internal; their gas pressure is taken at the span centre).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from flexlift import constants as C
from flexlift.bags import GasModel, gas_model_from_scenario
from flexlift.beam import assemble
from flexlift.hull import Hull, hull_from_scenario
from flexlift.hydro import added_mass_per_length, sphere_diameter, sphere_frontal_area
from flexlift.liftplan import LiftPlan, plan_lift
from flexlift.modes import Modes, compute_modes
from flexlift.seabed import SeabedModel, seabed_from_scenario

_GP, _GW = np.polynomial.legendre.leggauss(4)
_GP, _GW = 0.5 * (_GP + 1.0), 0.5 * _GW


def slope_at(modes: Modes, x) -> np.ndarray:
    """Mode rotations dw/dx interpolated with the Hermite shape functions at x [m],
    shape (len(x), m) [rad per unit modal coordinate]."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    hull = modes.hull
    l = hull.element_length
    e = np.clip((x / l).astype(int), 0, hull.n_elements - 1)
    xi = x / l - e
    dN = np.stack(
        [(-6 * xi + 6 * xi**2) / l, 1 - 4 * xi + 3 * xi**2, (6 * xi - 6 * xi**2) / l, -2 * xi + 3 * xi**2],
        axis=-1,
    )
    dofs = 2 * e[:, None] + np.arange(4)[None, :]
    return np.einsum("pk,pkm->pm", dN, modes.phi[dofs])


@dataclass(frozen=True)
class Plant:
    """Everything the ascent dynamics needs, precomputed (SI).

    names, external : bag names and whether each is an external (parachute) bag
    x_point : bag points (external: attachment; internal: span centre) [m]
    capacity, lift : bag capacity [m^3] and rated lift [N]
    top_offset : height of a bag's top above the hull bottom at its point [m]
    nr : number of modes integrated in time (2 rigid + retained flexible)
    """

    hull: Hull
    modes: Modes  # wet modes, all of them
    plan: LiftPlan
    gas: GasModel
    seabed: SeabedModel
    names: tuple[str, ...]
    external: np.ndarray
    x_point: np.ndarray
    spans: tuple
    capacity: np.ndarray
    lift: np.ndarray
    top_offset: np.ndarray
    wet_weight: float
    nr: int
    xs: np.ndarray  # strip points [m]
    ws: np.ndarray  # strip weights [m]
    psi_s: np.ndarray  # (ns, nm) mode displacement at strips
    psi_b: np.ndarray  # (nb, nm) generalised force per unit bag force
    psi_p: np.ndarray  # (nb, nm) displacement at bag points
    dpsi_p: np.ndarray  # (nb, nm) slope at bag points
    omega2: np.ndarray  # (nm,)
    damp: np.ndarray  # (nm,) 2 zeta omega
    q_weight_s: np.ndarray  # (ns,) wet weight line load [N/m] (negative)
    Q_weight: np.ndarray  # (nm,) generalised wet weight incl. point masses
    hold_s: np.ndarray  # (ns,) holding shape at strips [1/m]
    mass_line: float  # added mass + entrained per length [kg/m]
    drag_line: float  # 1/2 rho C_D B [kg/m^2]
    drag_bag: np.ndarray  # (nb,) 1/2 rho C_D,bag A [kg/m]
    zeta: float
    pitch_slope: float  # rotation of the rigid pitch mode per unit coordinate [rad]
    extra: dict = field(default_factory=dict)

    @property
    def nb(self) -> int:
        return len(self.names)

    @property
    def n_state(self) -> int:
        return 2 * self.nr + self.nb + 1

    def neutral_volumes(self) -> np.ndarray:
        """Initial gas volumes (SPEC §5): internal bags full, external bags sharing the rest of
        W' equally so the hull rests neutral [m^3]."""
        V = np.where(self.external, 0.0, self.capacity)
        rest = self.wet_weight / (self.gas.rho * self.gas.g) - V.sum()
        n_ext = int(self.external.sum())
        if n_ext:
            V = np.where(self.external, rest / n_ext, V)
        return V

    def initial_state(self) -> np.ndarray:
        x = np.zeros(self.n_state)
        p = self.gas.pressure(np.zeros(self.nb))
        x[2 * self.nr : 2 * self.nr + self.nb] = self.gas.moles(self.neutral_volumes(), p)
        x[-1] = self.seabed.H0
        return x


def build_plant(scenario, hull: Hull | None = None, plan: LiftPlan | None = None) -> Plant:
    """Precompute the plant of ``scenario`` (wet modes, strips, bag maps, weights)."""
    env, hy = scenario.environment, scenario.hydro
    hull = hull or hull_from_scenario(scenario)
    if plan is None:
        plan = plan_lift(scenario, hull, compute_modes(hull))
    rho, g = env.seawater_density_kg_m3, env.gravity_m_s2
    a33 = added_mass_per_length(hull.breadth, rho, hy.added_mass_coefficient)
    extra_m = a33 + hy.entrained_water_t * C.TONNE / hull.length
    modes = compute_modes(assemble(hull, extra_mass_per_length=extra_m))
    nr = min(2 + scenario.simulation.retained_flexible_modes, modes.n_modes)
    l = hull.element_length
    e = np.arange(hull.n_elements)
    xs = ((e[:, None] + _GP[None, :]) * l).ravel()
    ws = np.tile(_GW * l, hull.n_elements)
    psi_s = modes.shape_at(xs)
    bags = plan.bags
    external = np.array([b.kind == "external" for b in bags])
    x_point = np.array([b.x for b in bags], dtype=float)
    psi_p = modes.shape_at(x_point)
    dpsi_p = slope_at(modes, x_point)
    psi_b = psi_p.copy()
    for i, b in enumerate(bags):
        if b.span is not None:
            a, bb = b.span
            xm = a + (np.arange(400) + 0.5) * (bb - a) / 400
            psi_b[i] = modes.shape_at(xm).mean(axis=0)
    capacity = np.array([b.capacity for b in bags])
    lift = np.array([b.lift for b in bags])
    buoy = 1.0 - rho / env.steel_density_kg_m3
    m_el = hull.mass_per_length[np.clip((xs / l).astype(int), 0, hull.n_elements - 1)]
    q_weight_s = -m_el * g * buoy
    Q_weight = psi_s.T @ (ws * q_weight_s)
    Q_weight = Q_weight - (modes.displacement.T @ hull.point_masses) * g * buoy
    seabed = seabed_from_scenario(scenario, plan.wet_weight)
    omega2 = modes.omega**2
    zeta = scenario.hull.modal_damping
    damp = 2 * zeta * modes.omega
    d_bag = sphere_diameter(capacity)
    top = hull.depth + np.where(external, d_bag, 0.0)
    pitch_slope = float(slope_at(modes, [0.5 * hull.length])[0, 1])
    return Plant(
        hull=hull,
        modes=modes,
        plan=plan,
        gas=gas_model_from_scenario(scenario),
        seabed=seabed,
        names=tuple(b.name for b in bags),
        external=external,
        x_point=x_point,
        spans=tuple(b.span for b in bags),
        capacity=capacity,
        lift=lift,
        top_offset=top,
        wet_weight=plan.wet_weight,
        nr=nr,
        xs=xs,
        ws=ws,
        psi_s=psi_s,
        psi_b=psi_b,
        psi_p=psi_p,
        dpsi_p=dpsi_p,
        omega2=omega2,
        damp=damp,
        q_weight_s=q_weight_s,
        Q_weight=Q_weight,
        hold_s=seabed.shape(xs, hull.length),
        mass_line=extra_m,
        drag_line=0.5 * rho * hy.drag_coefficient * hull.breadth,
        drag_bag=np.where(
            external, 0.5 * rho * hy.bag_drag_coefficient * sphere_frontal_area(capacity), 0.0
        ),
        zeta=zeta,
        pitch_slope=pitch_slope,
    )


@dataclass
class Switches:
    """The plant's discrete state and fault effects (mutable, owned by the simulation loop).

    separated : the hull has separated from the seabed (suction releasing)
    attached : (nb,) 1 while a bag's sling holds, 0 after it breaks
    supply : (nb,) 1 while a bag's gas supply works
    leak : (nb,) gas escape rate of ruptured bags [1/s]
    current : vertical current, positive up [m/s]
    noise_s : (ns,) random line load at the strips [N/m]
    """

    nb: int
    ns: int
    separated: bool = False
    current: float = 0.0
    attached: np.ndarray = None  # type: ignore[assignment]
    supply: np.ndarray = None  # type: ignore[assignment]
    leak: np.ndarray = None  # type: ignore[assignment]
    noise_s: np.ndarray = None  # type: ignore[assignment]
    noisy: bool = False
    full: bool = False  # compute the strip loads even while held (for recording)
    intact: bool = True  # attached and supply all 1 and leak all 0 (cleared by a bag fault)
    # (z, zdot, p, V) at the bag points of the state the next dynamics call gets, when the
    # caller has them (the controllers' measurements); the caller clears it after that call
    meas: tuple | None = None
    rates: bool = True  # False: leave the mechanical rates (unused by the ETD2 loop) out of dx

    def __post_init__(self):
        self.attached = np.ones(self.nb)
        self.supply = np.ones(self.nb)
        self.leak = np.zeros(self.nb)
        self.noise_s = np.zeros(self.ns)


class Aux:
    """Quantities computed with the rates that the loop records.

    z : bag point heights (retained modes) [m]; zdot : their velocities [m/s]
    volume : gas volumes [m^3]; pressure : ambient pressure at the bag points [Pa]
    bag_force : buoyancy force on the hull [N]; fill, purge : fill and purge flows [m^3/s]
    uplift : U = sum lift - W' [N]
    contact : (ns,) contact line load [N/m]; active : (ns,) bool contact active (None: held)
    w_s : (ns,) strip displacement [m]; w_min : its lowest value [m] (None: held)
    accel : (nr,) modal accelerations (None: left out, Switches.rates)
    line : (ns,) line load at the strips except weight [N/m]
    point : (nb,) forces at the bags' points incl. bag drag [N]
    Qext : (nr,) generalised force without stiffness, damping, contact
    ``line`` and ``point`` may be given as None with ``parts`` = (Fast, v|v| at strips and
    bags, contact, bag_force): then they are formed when first read (recording only).
    """

    __slots__ = ("z", "zdot", "volume", "pressure", "bag_force", "fill", "purge", "uplift",
                 "contact", "active", "w_s", "accel", "_line", "_point", "Qext", "w_min", "_parts")

    def __init__(self, z, zdot, volume, pressure, bag_force, fill, purge, uplift, contact, active,
                 w_s, accel, line, point, Qext=None, w_min=None, parts=None):
        self.z, self.zdot, self.volume, self.pressure = z, zdot, volume, pressure
        self.bag_force, self.fill, self.purge, self.uplift = bag_force, fill, purge, uplift
        self.contact, self.active, self.w_s, self.accel = contact, active, w_s, accel
        self._line, self._point, self.Qext, self.w_min, self._parts = line, point, Qext, w_min, parts

    def _form(self):
        F, ad, qc, F_bag = self._parts
        ns = F.ns
        line = F.neg_drag * ad[:ns]
        self._line = line if qc is F.zero_ns else line + qc
        self._point = F_bag - F.drag_bag * ad[ns:]
        self._parts = None

    @property
    def line(self):
        if self._parts is not None:
            self._form()
        return self._line

    @property
    def point(self):
        if self._parts is not None:
            self._form()
        return self._point


class Fast:
    """Arrays of a :class:`Plant` sliced to the retained modes, for the inner loop."""

    def __init__(self, P: Plant):
        nr = P.nr
        self.nr, self.nb = nr, P.nb
        self.ps = np.ascontiguousarray(P.psi_s[:, :nr])  # (ns, nr)
        self.G = np.ascontiguousarray((P.psi_s[:, :nr] * P.ws[:, None]).T)  # (nr, ns)
        self.pp = np.ascontiguousarray(P.psi_p[:, :nr])  # (nb, nr)
        self.pspp = np.vstack([self.ps, self.pp])  # (ns + nb, nr)
        self.ns = self.ps.shape[0]
        self.Gb = np.ascontiguousarray(P.psi_b[:, :nr].T)  # (nr, nb)
        self.Qw = P.Q_weight[:nr].copy()
        self.om2 = P.omega2[:nr].copy()
        self.damp = P.damp[:nr].copy()
        self.Qhold = self.G @ P.hold_s  # generalised force per unit holding force (down: -)
        g = P.gas
        self.RT, self.p_atm, self.rg, self.depth = g.RT, g.p_atm, g.rho * g.g, g.water_depth
        self.cap = P.capacity
        self.inv_cap = 1.0 / P.capacity
        self.purge_max = g.purge_max
        self.k, self.c = P.seabed.stiffness, P.seabed.damping
        self.H0, self.Tb, self.tau = P.seabed.H0, P.seabed.breakout_time, P.seabed.release_time
        self.drag, self.drag_bag = P.drag_line, P.drag_bag
        self.neg_k, self.neg_drag, self.inv_RT = -self.k, -self.drag, 1.0 / self.RT
        self.W = P.wet_weight
        Kc = self.k * self.G @ self.ps
        self.static = np.linalg.inv(np.diag(self.om2) + Kc)  # held: quasi-static compliance
        self.zero_nb, self.zero_nr = np.zeros(self.nb), np.zeros(nr)
        self.zero_ns, self.no_contact = np.zeros(self.ns), np.zeros(self.ns, dtype=bool)  # read-only
        # drag of strips and bags at once: generalised force per unit v|v| (strips, then bags)
        self.Gdrag = np.hstack([self.G * -self.drag, self.Gb * -self.drag_bag[None, :]])
        self.psppT = np.ascontiguousarray(self.pspp.T)  # (nr, ns + nb)


def dynamics(t: float, x: np.ndarray, u: np.ndarray, params):
    """f(t, x, u, params) -> (dx/dt, Aux) of the coupled plant; params = (Plant, Switches)
    (a third element, the plant's :class:`Fast` arrays, saves rebuilding them)."""
    P, sw = params[0], params[1]
    F = params[2] if len(params) > 2 else Fast(P)
    nr, nb = F.nr, F.nb
    q, v = x[:nr], x[nr : 2 * nr]
    n, H = x[2 * nr : 2 * nr + nb], x[-1]
    meas = sw.meas
    if not (sw.separated or sw.full):
        return _held_rates(F, sw, q, n, u, meas)
    if sw.intact and not sw.noisy and not sw.current:
        return _free_rates(F, sw, x, u, meas)
    if meas is None:
        WZ = F.pspp @ x[: 2 * nr].reshape(2, nr).T  # displacements and velocities, strips and bags
        ns = F.ns
        w_s, v_s, z, zd = WZ[:ns, 0], WZ[:ns, 1], WZ[ns:, 0], WZ[ns:, 1]
        p = F.p_atm + F.rg * np.maximum(F.depth - z, 0.0)
        V = np.minimum(n * (F.RT / p), F.cap)
    else:  # the bags' heights, velocities, pressures and volumes of this state, given
        z, zd, p, V = meas
        WS = F.ps @ x[: 2 * nr].reshape(2, nr).T
        w_s, v_s = WS[:, 0], WS[:, 1]
    intact = sw.intact  # every sling and supply holds, no leak: skip the unit factors
    F_bag = F.rg * V if intact else F.rg * V * sw.attached
    cur = sw.current
    vr = v_s - cur if cur else v_s
    w_min = min(w_s.tolist())
    if sw.separated and w_min >= 0.0:  # clear of the seabed: no spring is active
        qc, active = F.zero_ns, F.no_contact
    else:
        qc = F.neg_k * w_s - F.c * v_s
        if sw.separated:
            active = (w_s < 0.0) & (qc > 0.0)
            qc = qc * active
        else:
            active = None
    vb = zd - cur if cur else zd
    if intact:
        F_pt = F_bag - F.drag_bag * np.abs(vb) * vb
    else:
        F_pt = F_bag - F.drag_bag * np.abs(vb) * vb * sw.attached
    ext = F.neg_drag * np.abs(vr) * vr
    if sw.noisy:
        ext = ext + sw.noise_s
    Qext = F.G @ ext + F.Gb @ F_pt + F.Qw
    if sw.separated:
        Qext = Qext - H * F.Qhold
    fill = u[:nb].copy() if intact else u[:nb] * sw.supply
    purge = F.purge_max * u[nb:] * np.sqrt(V * F.inv_cap)
    ndot = p * (fill - purge) * F.inv_RT
    if not intact:
        ndot = ndot - sw.leak * n
    U = sum(F_bag.tolist()) - F.W
    if sw.separated:
        Hdot = -H / F.tau
    else:
        Hdot = -(F.H0 / F.Tb) * min(U / F.H0, 1.0) if U > 0 else 0.0
    if sw.rates or sw.full:
        acc = Qext + F.G @ qc - F.om2 * q - F.damp * v
        dx = np.concatenate([v, acc, ndot, [Hdot]])
    else:  # the mechanical rates left out (zero): the caller steps the mechanics itself
        acc = None
        dx = np.zeros(2 * nr + nb + 1)
        dx[2 * nr : 2 * nr + nb] = ndot
        dx[-1] = Hdot
    line = ext if qc is F.zero_ns else ext + qc
    return dx, Aux(z, zd, V, p, F_bag, fill, purge, U, qc, active, w_s, acc, line, F_pt, Qext, w_min)


def _free_rates(F: Fast, sw, x, u, meas):
    """:func:`dynamics` (not held, or recording) with every sling and supply intact, no leak,
    force noise or current: the strip and bag drag in one product; Aux.line and Aux.point are
    formed only when read."""
    nr, nb, ns = F.nr, F.nb, F.ns
    m2 = 2 * nr
    n, H = x[m2 : m2 + nb], x[-1]
    WZ = x[:m2].reshape(2, nr) @ F.psppT  # rows: displacements, velocities (strips, then bags)
    w_s, vel = WZ[0, :ns], WZ[1]
    if meas is None:
        z, zd = WZ[0, ns:], vel[ns:]
        p = F.p_atm + F.rg * np.maximum(F.depth - z, 0.0)
        V = np.minimum(n * (F.RT / p), F.cap)
    else:
        z, zd, p, V = meas
    F_bag = F.rg * V
    w_min = min(w_s.tolist())
    if sw.separated and w_min >= 0.0:  # clear of the seabed: no spring is active
        qc, active = F.zero_ns, F.no_contact
    else:
        qc = F.neg_k * w_s - F.c * vel[:ns]
        if sw.separated:
            active = (w_s < 0.0) & (qc > 0.0)
            qc = qc * active
        else:
            active = None
    ad = np.abs(vel) * vel
    Qext = F.Gdrag @ ad + F.Gb @ F_bag + F.Qw
    if sw.separated:
        Qext = Qext - H * F.Qhold
    fill = u[:nb].copy()
    purge = F.purge_max * u[nb:] * np.sqrt(V * F.inv_cap)
    ndot = p * (fill - purge) * F.inv_RT
    U = sum(F_bag.tolist()) - F.W
    if sw.separated:
        Hdot = -H / F.tau
    else:
        Hdot = -(F.H0 / F.Tb) * min(U / F.H0, 1.0) if U > 0 else 0.0
    dx = np.zeros(m2 + nb + 1)
    acc = None
    if sw.rates or sw.full:
        acc = Qext + F.G @ qc - F.om2 * x[:nr] - F.damp * x[nr:m2]
        dx[:nr] = x[nr:m2]
        dx[nr:m2] = acc
    dx[m2 : m2 + nb] = ndot
    dx[-1] = Hdot
    return dx, Aux(z, zd, V, p, F_bag, fill, purge, U, qc, active, w_s, acc, None, None, Qext, w_min,
                   (F, ad, qc, F_bag))


def _held_rates(F: Fast, sw, q, n, u, meas=None):
    """The rates while the hull is held (its mechanics quasi-static: see :func:`held_state`);
    the strip loads are left out of Aux (None) unless ``sw.full``; ``meas`` as Switches.meas."""
    nb = F.nb
    if meas is None:
        z = F.pp @ q
        p = F.p_atm + F.rg * np.maximum(F.depth - z, 0.0)
        V = np.minimum(n * (F.RT / p), F.cap)
    else:
        z, _, p, V = meas
    F_bag = F.rg * V * sw.attached
    fill = u[:nb] * sw.supply
    purge = F.purge_max * u[nb:] * np.sqrt(V * F.inv_cap)
    ndot = p * (fill - purge) * (1.0 / F.RT) - sw.leak * n
    U = sum(F_bag.tolist()) - F.W
    Hdot = -(F.H0 / F.Tb) * min(U / F.H0, 1.0) if U > 0 else 0.0
    dx = np.zeros(2 * F.nr + nb + 1)
    dx[2 * F.nr : 2 * F.nr + nb] = ndot
    dx[-1] = Hdot
    zero = F.zero_nb
    return dx, Aux(z, zero, V, p, F_bag, fill, purge, U, None, None, None, F.zero_nr, None, F_bag)


def held_state(F: Fast, x: np.ndarray, sw) -> np.ndarray:
    """The held hull's quasi-static modal coordinates on the tension-capable seabed spring,
    under its weight and the bag forces at the gas state of ``x`` (velocities zero)."""
    nr, nb = F.nr, F.nb
    q = x[:nr]
    for _ in range(1):  # the bags' depth barely depends on millimetres of q: one pass
        z = F.pp @ q
        p = F.p_atm + F.rg * np.maximum(F.depth - z, 0.0)
        V = np.minimum(x[2 * nr : 2 * nr + nb] * (F.RT / p), F.cap)
        Q = F.Gb @ (F.rg * V * sw.attached) + F.Qw
        if sw.noisy:
            Q = Q + F.G @ sw.noise_s
        q = F.static @ Q
    return q


def uplift(F: Fast, x: np.ndarray, sw) -> float:
    """U = sum of the bags' lift - W' at the state ``x`` [N]."""
    nr, nb = F.nr, F.nb
    z = F.pp @ x[:nr]
    p = F.p_atm + F.rg * np.maximum(F.depth - z, 0.0)
    V = np.minimum(x[2 * nr : 2 * nr + nb] * (F.RT / p), F.cap)
    return float(F.rg * (V @ sw.attached)) - F.W


def observe(P: Plant, x: np.ndarray):
    """Bag-point heights [m], velocities [m/s] and gas volumes [m^3] of state ``x``."""
    nr, nb = P.nr, P.nb
    pp = P.psi_p[:, :nr]
    z = pp @ x[:nr]
    p = P.gas.pressure(z)
    V = np.minimum(x[2 * nr : 2 * nr + nb] * P.gas.RT / p, P.capacity)
    return z, pp @ x[nr : 2 * nr], V


def etd_matrices(P: Plant, dt: float, active: np.ndarray | None):
    """Exact step of the linear mechanics over ``dt`` [s] under a generalised force that varies
    linearly over the step (second-order exponential time differencing, ETD2):
    y(t + dt) = E y + Phi1 b + Phi2 (b - b_prev), y = [q, q'] and b the generalised force
    without modal stiffness, damping and the contact springs active at the strips ``active``
    (None: none), b_prev its value one step earlier. Returns (E, Phi1 + Phi2, -Phi2), from one
    matrix exponential of the augmented system (valid with the singular rigid-body modes)."""
    from scipy.linalg import expm

    nr = P.nr
    K = np.diag(P.omega2[:nr])
    Cm = np.diag(P.damp[:nr])
    if active is not None and np.any(active):
        ps = P.psi_s[:, :nr] * (P.ws * active)[:, None]
        K = K + P.seabed.stiffness * ps.T @ P.psi_s[:, :nr]
        Cm = Cm + P.seabed.damping * ps.T @ P.psi_s[:, :nr]
    n = 2 * nr
    A = np.zeros((n + 2 * nr, n + 2 * nr))
    A[:nr, nr:n] = np.eye(nr)
    A[nr:n, :nr] = -K
    A[nr:n, nr:n] = -Cm
    A[nr:n, n : n + nr] = np.eye(nr)  # b(tau) = b + (tau / dt) d drives the accelerations
    A[n : n + nr, n + nr :] = np.eye(nr) / dt
    X = expm(dt * A)
    E, P1, P2 = X[:n, :n], X[:n, n : n + nr], X[:n, n + nr :]
    return np.ascontiguousarray(E), np.ascontiguousarray(P1 + P2), np.ascontiguousarray(-P2)
