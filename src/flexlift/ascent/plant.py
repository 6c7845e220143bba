"""The plant of the ascent as plain arrays: one form for the coupled hull and the paper's bags.

Both plants are linear modal mechanics loaded by the laws of :mod:`flexlift.physics`:

    q'' + 2 zeta omega q' + omega^2 q = Q(t),   w(x) = sum_j psi_j(x) q_j

with ``nr`` modal coordinates q [m sqrt(kg)], the loads integrated over ``ns`` *strips*
(quadrature points along the structure, each with a weight in metres) and ``nb`` *bags*
(points, or spans for internal bags). The seabed's holding force is split into ``ng``
*holding groups*, each with its own suction H_g, its own separation and its uplift
U_g = sum of its bags' lift - W_g.

- The coupled plant (:func:`coupled_plant`): the wet hull's rigid heave and pitch plus
  ``retained_flexible_modes`` flexible modes; strips at Gauss points along the hull; one
  holding group. Eliminated modes enter the recorded heights and slopes as their static
  correction (mdc).
- The paper's plant (:func:`flexlift.ascent.paper.paper_plant`): each external bag on its own
  4-state model, two modes per bag and no coupling; one strip and one holding group per bag.

:class:`PlantArrays` is what the compiled loop reads; :class:`Plant` adds the names and the
structure for the results. Units: SI throughout (N, m, s, mol, Pa).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from flexlift import constants as C
from flexlift.control.sequence import stage_groups
from flexlift.errors import InputError
from flexlift.loads.liftplan import LiftPlan, plan_lift
from flexlift.physics import gas, hydro, seabed
from flexlift.structure.beam import assemble
from flexlift.structure.hull import Hull, hull_from_scenario
from flexlift.structure.modes import Modes, compute_modes


class PlantArrays(NamedTuple):
    """Everything the compiled loop needs about a plant (read only), SI.

    Sizes: nr modal coordinates, nb bags, ns strips, ng holding groups.
    """

    nr: int
    nb: int
    ns: int
    ng: int
    omega2: np.ndarray  # (nr,) omega^2 [rad^2/s^2]
    damping: np.ndarray  # (nr,) 2 zeta omega [1/s]
    strip_shape: np.ndarray  # (ns, nr) displacement at each strip per unit q [m / (m sqrt kg)]
    strip_force: np.ndarray  # (nr, ns) generalised force per unit line load at a strip [m]
    strip_weight: np.ndarray  # (ns,) quadrature weight: a strip's line load times it is a force [m]
    strip_drag: np.ndarray  # (ns,) 1/2 rho C_D B [kg/m^2]
    strip_k: np.ndarray  # (ns,) seabed contact stiffness per length [N/m^2]
    strip_c: np.ndarray  # (ns,) seabed contact damping per length [N s/m^2]
    strip_group: np.ndarray  # (ns,) holding group of each strip
    strip_hold: np.ndarray  # (ns,) holding line load per unit H of its group [1/m]
    hold_force: np.ndarray  # (nr, ng) generalised force per unit H of each group (down) [-]
    H0: np.ndarray  # (ng,) initial holding force [N]
    group_weight: np.ndarray  # (ng,) wet weight W_g a group's bags must lift [N]
    breakout_time: float  # T_b [s]
    release_time: float  # tau_r [s]
    bag_shape: np.ndarray  # (nb, nr) displacement at each bag point per unit q
    bag_slope: np.ndarray  # (nb, nr) slope (local pitch angle) at each bag point per unit q
    bag_force: np.ndarray  # (nr, nb) generalised force per unit bag force
    bag_group: np.ndarray  # (nb,) holding group each bag lifts
    capacity: np.ndarray  # (nb,) bag capacity V_max [m^3]
    relief: np.ndarray  # (nb,) over-pressure relief setting (0: open bag) [Pa]
    top_offset: np.ndarray  # (nb,) height of a bag's top above the hull bottom [m]
    bag_drag: np.ndarray  # (nb,) 1/2 rho C_D,bag A [kg/m]
    weight_force: np.ndarray  # (nr,) generalised wet weight (point masses included) [N]
    pitch_row: np.ndarray  # (nr,) hull pitch angle per unit q [rad]
    heave_row: np.ndarray  # (nr,) heave of the centre of mass per unit q [m]
    corr_strip: np.ndarray  # (nb, ns) static correction of the heights per unit line load
    corr_bag: np.ndarray  # (nb, nb) ... per unit bag force
    corr_weight: np.ndarray  # (nb,) ... of the wet weight [m]
    slope_strip: np.ndarray  # (nb, ns) static correction of the slopes per unit line load
    slope_bag: np.ndarray  # (nb, nb) ... per unit bag force
    slope_weight: np.ndarray  # (nb,) ... of the wet weight [rad]
    RT: float  # R T of the gas [J/mol]
    p_atm: float  # [Pa]
    rho_g: float  # seawater density times gravity [N/m^3]
    water_depth: float  # [m]
    purge_max: float  # Q_out,max [m^3/s]
    liftoff_clearance: float  # the whole structure is clear of the seabed above this [m]


@dataclass(frozen=True)
class Plant:
    """A plant and what the results need to label it.

    kind : "coupled" or "paper"
    names, external, x_point, spans : the bags (names, parachute or not, point [m], span or
        None [m])
    neutral_volume : (nb,) gas volumes that hold the structure neutral on the seabed [m^3]
    strip_x : (ns,) strip positions [m]; strip_element : (ns,) the element each lies in
    hull, modes, plan : the structure (wet modes, all of them) and the lift plan
    mass_line : added plus entrained mass per length [kg/m]
    wet_weight : W' [N]
    hold_stern_bow : (stern_ratio, bow_ratio) of the holding shape
    """

    kind: str
    names: tuple[str, ...]
    external: np.ndarray
    x_point: np.ndarray
    spans: tuple
    neutral_volume: np.ndarray
    strip_x: np.ndarray
    strip_element: np.ndarray
    arrays: PlantArrays
    hull: Hull
    modes: Modes
    plan: LiftPlan
    mass_line: float
    wet_weight: float
    hold_stern_bow: tuple[float, float]
    gravity: float
    seawater_density: float
    steel_density: float

    @property
    def nb(self) -> int:
        return len(self.names)

    @property
    def nr(self) -> int:
        return self.arrays.nr

    def initial_moles(self) -> np.ndarray:
        """Gas of every bag at the start [mol]: its neutral volume at the seabed's pressure."""
        a = self.arrays
        p = gas.ambient_pressure(0.0, a.water_depth, a.p_atm, a.rho_g)
        return gas.moles_of(self.neutral_volume, p, a.RT)


#: above this many elements the strips no longer follow the elements: a fixed load grid
FINE_MESH_ELEMENTS = 50
#: segments of the fixed load grid of fine meshes (two Gauss points each)
LOAD_SEGMENTS = 100


def strip_points(hull: Hull) -> tuple[np.ndarray, np.ndarray]:
    """Strip positions [m] and quadrature weights [m] along ``hull``: four Gauss-Legendre
    points per element up to :data:`FINE_MESH_ELEMENTS` elements; beyond, two per segment of
    an even grid of :data:`LOAD_SEGMENTS` segments, whatever the mesh (the distributed loads
    are smooth on that scale, and the cost of a step stops growing with the mesh)."""
    if hull.n_elements <= FINE_MESH_ELEMENTS:
        n, p = hull.n_elements, 4
    else:
        n, p = LOAD_SEGMENTS, 2
    gp, gw = np.polynomial.legendre.leggauss(p)
    gp, gw = 0.5 * (gp + 1.0), 0.5 * gw
    l = hull.length / n
    e = np.arange(n)
    return ((e[:, None] + gp[None, :]) * l).ravel(), np.tile(gw * l, n)


def slope_at(modes: Modes, x) -> np.ndarray:
    """Mode slopes dw/dx at x [m] by the Hermite shape functions, shape (len(x), n_modes)."""
    x = np.atleast_1d(np.asarray(x, dtype=float))
    hull = modes.hull
    l = hull.element_length
    e = np.clip((x / l).astype(int), 0, hull.n_elements - 1)
    xi = x / l - e
    dN = np.stack([(-6 * xi + 6 * xi**2) / l, 1 - 4 * xi + 3 * xi**2, (6 * xi - 6 * xi**2) / l,
                   -2 * xi + 3 * xi**2], axis=-1)
    dofs = 2 * e[:, None] + np.arange(4)[None, :]
    return np.einsum("pk,pkm->pm", dN, modes.phi[dofs])


def bag_force_shapes(modes: Modes, plan: LiftPlan) -> np.ndarray:
    """(nb, n_modes): generalised force per unit bag force; an internal bag's force is spread
    uniformly over its span (the mode shape averaged over it)."""
    out = modes.shape_at(np.array([b.x for b in plan.bags]))
    for i, b in enumerate(plan.bags):
        if b.span is not None:
            a, c = b.span
            xm = a + (np.arange(400) + 0.5) * (c - a) / 400
            out[i] = modes.shape_at(xm).mean(axis=0)
    return out


def gas_constants(scenario) -> dict:
    """The gas and environment constants of a scenario, SI (bar to Pa)."""
    env, g = scenario.environment, scenario.gas
    return dict(RT=gas.molar_energy(env.sea_temperature_K), p_atm=env.atmospheric_pressure_Pa,
                rho_g=env.seawater_density_kg_m3 * env.gravity_m_s2,
                water_depth=env.water_depth_m, purge_max=g.purge_rate_max_m3_s)


def static_correction(shape_p: np.ndarray, om2_e: np.ndarray, strip_gen: np.ndarray,
                      bag_gen: np.ndarray, weight_gen: np.ndarray):
    """The eliminated modes' static (mdc) response at the bag points: per unit strip line
    load (nb, ns), per unit bag force (nb, nb) and of the weight (nb,), for bag-point shapes
    ``shape_p`` (nb, ne) of modes with omega^2 ``om2_e`` (ne,), their generalised forces per
    unit strip load ``strip_gen`` (ne, ns), per unit bag force ``bag_gen`` (ne, nb) and of the
    weight ``weight_gen`` (ne,)."""
    scaled = shape_p / om2_e[None, :]
    return scaled @ strip_gen, scaled @ bag_gen, scaled @ weight_gen


def wet_beam(scenario, hull: Hull):
    """The hull as it moves in water: (its beam with the added mass a33 = C_a rho pi B^2 / 4
    and the entrained water spread over the length added to the structural mass, that extra
    mass per length [kg/m]). The coupled plant integrates this beam's modes (the wet modes);
    the modal stage reports their frequencies beside the dry ones."""
    env, hy = scenario.environment, scenario.hydro
    mass_line = hydro.moving_water_per_length(hull.breadth, env.seawater_density_kg_m3,
                                              hy.added_mass_coefficient,
                                              hy.entrained_water_t * C.TONNE, hull.length)
    return assemble(hull, extra_mass_per_length=mass_line), mass_line


def coupled_plant(scenario, hull: Hull | None = None, plan: LiftPlan | None = None) -> Plant:
    """The coupled plant of ``scenario``: the wet hull, its bags and its holding groups (one,
    or one per stage of a staged lift: :func:`holding_groups`)."""
    env, hy = scenario.environment, scenario.hydro
    hull = hull or hull_from_scenario(scenario)
    if plan is None:
        plan = plan_lift(scenario, hull)
    rho, g = env.seawater_density_kg_m3, env.gravity_m_s2
    beam, mass_line = wet_beam(scenario, hull)
    # the retained modes plus 10 more for the static correction of the eliminated ones (their
    # share falls as 1 / omega^2); all of them on the tanker's 11 elements
    n_flex = retained_flexible(scenario, hull, plan)
    n_modes = min(beam.n_dof, max(MODES_FOR_CORRECTION, 2 + n_flex + 10))
    modes = compute_modes(beam, n_modes=n_modes)
    nr = min(2 + n_flex, modes.n_modes)
    xs, ws = strip_points(hull)
    psi_s = modes.shape_at(xs)  # (ns, m)
    bags = plan.bags
    nb = len(bags)
    external = np.array([b.kind == "external" for b in bags])
    x_point = np.array([b.x for b in bags], dtype=float)
    psi_p, dpsi_p = modes.shape_at(x_point), slope_at(modes, x_point)
    psi_b = bag_force_shapes(modes, plan)
    capacity = np.array([b.capacity for b in bags])
    rho_s = env.steel_density_kg_m3
    el = hull.element_of(xs)
    strip_gen = (psi_s * ws[:, None]).T  # (m, ns)
    wet_line = hull.wet_weight_per_length(g, rho, rho_s)[el]  # at the strips [N/m]
    weight_gen = -(strip_gen @ wet_line
                   + modes.displacement.T @ hull.point_wet_weights(g, rho, rho_s))
    sb = scenario.seabed
    stern, bow = (sb.stern_ratio, sb.bow_ratio) if sb.holding_shape == "linear" else (1.0, 1.0)
    shape = seabed.holding_shape(xs, hull.length, stern, bow)
    H0 = (scenario.lift.breakout_factor - 1.0) * plan.wet_weight
    strip_group, bag_group, ng = holding_groups(scenario, [b.name for b in bags], x_point,
                                                external, xs)
    W_g, frac = stretch_shares(strip_group, ng, xs, ws * wet_line, ws * shape, hull,
                               hull.point_wet_weights(g, rho, rho_s), plan.wet_weight)
    hold_s = shape / frac[strip_group]  # per unit H of the strip's own group
    ns = xs.size
    cs, cb, cw = static_correction(psi_p[:, nr:], modes.omega[nr:] ** 2, strip_gen[nr:],
                                   psi_b[:, nr:].T, weight_gen[nr:])
    ss, sbg, sw = static_correction(dpsi_p[:, nr:], modes.omega[nr:] ** 2, strip_gen[nr:],
                                    psi_b[:, nr:].T, weight_gen[nr:])
    top = hull.depth + np.where(external, hydro.sphere_diameter(capacity), 0.0)
    pitch_row = np.zeros(nr)
    pitch_row[1] = float(slope_at(modes, [0.5 * hull.length])[0, 1])
    heave_row = np.zeros(nr)
    heave_row[0] = float(psi_s[0, 0])
    relief = np.where(external, 0.0, scenario.gas.relief_pressure_bar * C.BAR)
    arrays = PlantArrays(
        nr=nr, nb=nb, ns=ns, ng=ng,
        omega2=modes.omega[:nr] ** 2, damping=2.0 * scenario.hull.modal_damping * modes.omega[:nr],
        strip_shape=np.ascontiguousarray(psi_s[:, :nr]),
        strip_force=np.ascontiguousarray(strip_gen[:nr]), strip_weight=ws,
        strip_drag=np.full(ns, hydro.drag_coefficient(rho, hy.drag_coefficient, hull.breadth)),
        strip_k=np.full(ns, sb.contact_stiffness_N_m2), strip_c=np.full(ns, sb.contact_damping_Ns_m2),
        strip_group=strip_group, strip_hold=hold_s,
        hold_force=-np.stack([strip_gen[:nr] @ (hold_s * (strip_group == k)) for k in range(ng)],
                             axis=1),
        H0=H0 * frac, group_weight=W_g,
        breakout_time=sb.breakout_time_s, release_time=sb.release_time_s,
        bag_shape=np.ascontiguousarray(psi_p[:, :nr]), bag_slope=np.ascontiguousarray(dpsi_p[:, :nr]),
        bag_force=np.ascontiguousarray(psi_b[:, :nr].T), bag_group=bag_group,
        capacity=capacity, relief=relief, top_offset=top,
        bag_drag=np.where(external, hydro.drag_coefficient(
            rho, hy.bag_drag_coefficient, 1.0) * hydro.sphere_frontal_area(capacity), 0.0),
        weight_force=weight_gen[:nr].copy(), pitch_row=pitch_row, heave_row=heave_row,
        corr_strip=cs, corr_bag=cb, corr_weight=cw, slope_strip=ss, slope_bag=sbg, slope_weight=sw,
        liftoff_clearance=LIFTOFF_CLEARANCE, **gas_constants(scenario))
    return Plant(kind="coupled", names=tuple(b.name for b in bags), external=external,
                 x_point=x_point, spans=tuple(b.span for b in bags),
                 neutral_volume=neutral_volumes(external, capacity, W_g, rho * g, bag_group),
                 strip_x=xs, strip_element=el, arrays=arrays, hull=hull, modes=modes, plan=plan,
                 mass_line=mass_line, wet_weight=plan.wet_weight, hold_stern_bow=(stern, bow),
                 gravity=g, seawater_density=rho, steel_density=rho_s)


#: the range of ``simulation.retained_flexible_modes: auto``
AUTO_FLEXIBLE_MODES = (3, 60)


def retained_flexible(scenario, hull: Hull, plan: LiftPlan) -> int:
    """Flexible modes the coupled plant integrates: ``simulation.retained_flexible_modes``, or
    for ``auto`` as many as the lift points need: one half-wave per interval between
    neighbouring external lift points, ceil(L / s) with s their mean spacing, within
    :data:`AUTO_FLEXIBLE_MODES`.
    The lifts change from one lift point to the next (in a staged lift, one stage is up while
    the next still lies on the seabed), so the deflected shape has features as short as the
    spacing s; modes with shorter half-waves, far above that band of frequencies, respond
    quasi-statically and the static correction carries them (on the staged pipeline the peak
    moment is 8.9, 2.1, 0.327 and 0.321 MN m with 10, 20, 40 and 60 flexible modes)."""
    n = scenario.simulation.retained_flexible_modes
    if n != "auto":
        return int(n)
    x = np.unique([b.x for b in plan.bags if b.kind == "external"])
    spacing = float(np.ptp(x) / (x.size - 1)) if x.size > 1 else hull.length
    lo, hi = AUTO_FLEXIBLE_MODES
    return int(np.clip(math.ceil(hull.length / max(spacing, 1e-9) - 1e-9), lo, hi))


#: modes computed for the static correction at least (2 rigid + 22 flexible)
MODES_FOR_CORRECTION = 24
#: the whole structure is clear of the seabed once every strip is this high [m]
LIFTOFF_CLEARANCE = 0.05


def neutral_volumes(external: np.ndarray, capacity: np.ndarray, wet_weight, rho_g: float,
                    bag_group: np.ndarray | None = None) -> np.ndarray:
    """Gas volumes at the start (SPEC §5) [m^3]: the internal (closed) bags full, the external
    bags sharing the rest of the wet weight W' [N] equally so the hull rests neutral; with
    holding groups (``bag_group``, ``wet_weight`` per group), within each group."""
    groups = np.zeros(external.size, dtype=np.int64) if bag_group is None else bag_group
    W = np.atleast_1d(np.asarray(wet_weight, dtype=float))
    V = np.where(external, 0.0, capacity)
    for g in range(W.size):
        ext = external & (groups == g)
        if ext.any():
            V = np.where(ext, (W[g] / rho_g - V[groups == g].sum()) / ext.sum(), V)
    return V


def stretch_shares(strip_group, ng: int, xs, strip_weight, strip_hold, hull: Hull,
                   point_weights, wet_weight: float):
    """(wet weight W_g [N], share of the suction [-]) of each of the ``ng`` holding stretches:
    ``strip_weight`` [N] and ``strip_hold`` [-] the strips' wet weight and holding shape times
    their quadrature weights, ``point_weights`` [N] at the hull's nodes (to the stretch of the
    nearest strip); W_g scaled to the plan's ``wet_weight`` exactly. One stretch: everything."""
    if ng == 1:
        return np.array([wet_weight]), np.ones(1)
    node_group = strip_group[np.clip(np.searchsorted(xs, hull.x_nodes), 0, xs.size - 1)]
    W_g = np.bincount(strip_group, strip_weight, ng) + np.bincount(node_group, point_weights, ng)
    frac = np.bincount(strip_group, strip_hold, ng)
    return W_g * (wet_weight / W_g.sum()), frac / frac.sum()


def holding_groups(scenario, names, x_point, external, xs):
    """(group of each strip (ns,), group of each bag (nb,), number of groups) of the seabed's
    hold. One group unless the lift is staged (``control.sequence``): then each stage's
    group of bags has its own stretch of the structure (the strips nearest to its bags) with
    its share of the suction and of the weight, and lets go on its own (SPEC §9.1): a
    pipeline peels off stage by stage. An internal bag belongs to the stretch its point is in."""
    if scenario.control.sequence is None:
        return np.zeros(xs.size, dtype=np.int64), np.zeros(len(names), dtype=np.int64), 1
    groups = stage_groups(scenario, names, x_point, external)
    of_bag = np.zeros(len(names), dtype=np.int64)
    for k, members in enumerate(groups):
        of_bag[members] = k
    ext = np.flatnonzero(external)
    strip_group = of_bag[ext][np.abs(xs[:, None] - x_point[ext][None, :]).argmin(1)]
    for i in np.flatnonzero(~external):
        of_bag[i] = strip_group[np.abs(xs - x_point[i]).argmin()]
    return strip_group.astype(np.int64), of_bag, len(groups)


def check_neutral(plant: Plant) -> None:
    """InputError when the bags cannot hold the structure neutral at the start (SPEC §5):
    the internal bags full and the external bags sharing the rest of W' must fit."""
    V = plant.neutral_volume
    ext = plant.external
    to_t = plant.seawater_density / C.TONNE  # m^3 of displaced water -> tonnes of lift
    cap = plant.arrays.capacity
    if not ext.any() or np.any(V < -1e-9):
        internal_t = float(cap[~ext].sum()) * to_t
        raise InputError(
            "lift", f"{internal_t:.0f} t of internal bags for "
                    f"{plant.wet_weight / plant.gravity / C.TONNE:.0f} t wet weight",
            "the internal bags alone must lift less than the wet weight and there must be an "
            "external bag to control; change internal_bags or bag_lift_t")
    over = V > cap * (1 + 1e-9)
    if over.any():
        k = int(np.flatnonzero(over)[0])
        raise InputError(
            f"lift.bags.{plant.names[k]}", f"{V[k] * to_t:.0f} t needed at the start",
            f"each external bag must hold its share of the wet weight, but it lifts at most "
            f"{cap[k] * to_t:.0f} t; raise bag_lift_t or add bags")
