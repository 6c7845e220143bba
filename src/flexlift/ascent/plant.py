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

:class:`Plant` holds what the compiled loop reads, one record per part
(:mod:`flexlift.ascent.records`: modal, strips, bags, seabed; each built by its own function
below), and the names and the structure for the results. Units: SI throughout (N,
m, s, mol, Pa).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexlift import constants as C
from flexlift.ascent.records import (
    BAG_ENCLOSED,
    BAG_KINDS,
    BAG_OPEN_PARACHUTE,
    BAG_PAPER,
    TIP_FRACTION,
    Bags,
    Modal,
    PlantRecords,
    Seabed,
    Strips,
)
from flexlift.control.sequence import stage_groups
from flexlift.errors import InputError
from flexlift.loads.liftplan import LiftPlan, plan_lift
from flexlift.physics import gas, hydro, seabed
from flexlift.scenario.valves import external_valve
from flexlift.structure.beam import assemble
from flexlift.structure.hull import Hull, hull_from_scenario
from flexlift.structure.modes import Modes, compute_modes


@dataclass(frozen=True)
class Plant:
    """A plant and what the results need to label it.

    kind : "coupled" or "paper"
    names, external, x_point, spans : the bags (names, parachute or not, point [m], span or
        None [m])
    neutral_volume : (nb,) gas volumes that hold the structure neutral on the seabed [m^3]
    strip_x : (ns,) strip positions [m]; strip_element : (ns,) the element each lies in
    modal, strips, bags, seabed : the records the compiled loop reads
        (:mod:`flexlift.ascent.records`)
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
    modal: Modal
    strips: Strips
    bags: Bags
    seabed: Seabed
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
        return self.modal.nr

    @property
    def records(self) -> PlantRecords:
        """The records the compiled loop reads."""
        return PlantRecords(modal=self.modal, strips=self.strips, bags=self.bags,
                            seabed=self.seabed)

    def initial_moles(self) -> np.ndarray:
        """Gas of every bag at the start [mol]: its neutral volume at the seabed's pressure."""
        a = self.bags
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
    """The gas laws' constants of a scenario, SI: R T [J/mol], the atmospheric pressure [Pa],
    the water's weight density [N/m^3] and depth [m]."""
    env = scenario.environment
    return dict(RT=gas.molar_energy(env.sea_temperature_K), p_atm=env.atmospheric_pressure_Pa,
                rho_g=env.seawater_density_kg_m3 * env.gravity_m_s2,
                water_depth=env.water_depth_m)


def static_correction(shape_p: np.ndarray, om2_e: np.ndarray, weight_gen: np.ndarray):
    """The eliminated modes' static (mdc) response at the bag points, factored: the shapes
    scaled by the modes' flexibilities, ``shape_p diag(1/omega^2)`` (nb, ne), and the response
    to the weight (nb,), for bag-point shapes ``shape_p`` (nb, ne) of modes with omega^2
    ``om2_e`` (ne,) and their generalised force of the weight ``weight_gen`` (ne,). The response
    to loads with generalised forces f (ne,) is ``scaled @ f``: the loop forms f from the line
    loads and bag forces and never the dense (nb, ns) and (nb, nb) products."""
    scaled = shape_p / om2_e[None, :]
    return np.ascontiguousarray(scaled), scaled @ weight_gen


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


@dataclass(frozen=True)
class Layout:
    """What the records of the coupled plant share: the strips and bag points on the modes.

    xs, ws : (ns,) strip positions and quadrature weights [m]; el : (ns,) their elements
    psi_s : (ns, m) mode shapes at the strips; strip_gen : (m, ns) generalised force per unit
        strip line load [m]
    wet_line : (ns,) wet weight per length at the strips [N/m]; weight_gen : (m,) the
        generalised wet weight (point masses included) [N]
    external, x_point, capacity : (nb,) the bags: parachute or not, point [m], capacity [m^3]
    psi_p, dpsi_p : (nb, m) mode shapes and slopes at the bag points; psi_b : (nb, m)
        generalised force per unit bag force
    """

    xs: np.ndarray
    ws: np.ndarray
    el: np.ndarray
    psi_s: np.ndarray
    strip_gen: np.ndarray
    wet_line: np.ndarray
    weight_gen: np.ndarray
    external: np.ndarray
    x_point: np.ndarray
    capacity: np.ndarray
    psi_p: np.ndarray
    dpsi_p: np.ndarray
    psi_b: np.ndarray


@dataclass(frozen=True)
class Holding:
    """The seabed's hold of the coupled plant: strip_group (ns,), bag_group (nb,), ng groups,
    their wet weights W_g [N] and shares of the suction frac [-], the holding shape at the
    strips [-], the strips' holding line load per unit H of their group [1/m] and the shape's
    (stern, bow) ratios."""

    strip_group: np.ndarray
    bag_group: np.ndarray
    ng: int
    W_g: np.ndarray
    frac: np.ndarray
    shape: np.ndarray
    strip_hold: np.ndarray
    stern_bow: tuple[float, float]


@dataclass(frozen=True)
class Geometry:
    """What the coupled plant of a hull and a lift plan is built on, whatever the gas and the
    seabed's hold and breakout time (:func:`plant_geometry`): the hull, the extra moving mass
    per length of the wet beam [kg/m], its modes (all computed) and the ``nr`` retained, the
    strips and bag points on them, the holding groups, and the modal and strip records."""

    hull: Hull
    mass_line: float | np.ndarray
    modes: Modes
    nr: int
    lay: Layout
    hold: Holding
    modal: Modal
    strips: Strips


#: what :func:`plant_geometry` reads of a lift plan (a sweep's worker reuses a geometry for a
#: plan the same in these; a test holds the function to them)
GEOMETRY_READS = ("bags", "wet_weight")


def plant_geometry(scenario, hull: Hull, plan: LiftPlan) -> Geometry:
    """The :class:`Geometry` of ``scenario``'s coupled plant on ``hull`` and ``plan`` (of
    which it reads :data:`GEOMETRY_READS` only)."""
    beam, mass_line = wet_beam(scenario, hull)
    # the retained modes plus 10 more for the static correction of the eliminated ones (their
    # share falls as 1 / omega^2); all of them on the tanker's 11 elements
    n_flex = retained_flexible(scenario, hull, plan)
    n_modes = min(beam.n_dof, max(MODES_FOR_CORRECTION, 2 + n_flex + 10))
    modes = compute_modes(beam, n_modes=n_modes)
    nr = min(2 + n_flex, modes.n_modes)
    lay = layout(scenario, hull, plan, modes)
    hold = holding(scenario, hull, plan, lay)
    return Geometry(hull=hull, mass_line=mass_line, modes=modes, nr=nr, lay=lay, hold=hold,
                    modal=modal_record(scenario, hull, modes, nr, lay),
                    strips=strip_record(scenario, hull, nr, lay, hold))


def coupled_plant(scenario, hull: Hull | None = None, plan: LiftPlan | None = None,
                  geometry: Geometry | None = None) -> Plant:
    """The coupled plant of ``scenario``: the wet hull, its bags and its holding groups (one,
    or one per stage of a staged lift: :func:`holding_groups`). ``geometry``: its
    :func:`plant_geometry` on ``plan`` when already built (a sweep's worker keeps it for the
    cases that change only the gas, the seabed's hold or the loads); it holds the hull."""
    env = scenario.environment
    hull = geometry.hull if geometry is not None else hull or hull_from_scenario(scenario)
    if plan is None:
        plan = plan_lift(scenario, hull)
    rho, g = env.seawater_density_kg_m3, env.gravity_m_s2
    geo = geometry or plant_geometry(scenario, hull, plan)
    modes, nr, lay, hold = geo.modes, geo.nr, geo.lay, geo.hold
    bags = plan.bags
    return Plant(kind="coupled", names=tuple(b.name for b in bags), external=lay.external,
                 x_point=lay.x_point, spans=tuple(b.span for b in bags),
                 neutral_volume=neutral_volumes(lay.external, lay.capacity, hold.W_g, rho * g,
                                                hold.bag_group),
                 strip_x=lay.xs, strip_element=lay.el, modal=geo.modal, strips=geo.strips,
                 bags=bag_record(scenario, hull, modes, nr, lay, hold),
                 seabed=seabed_record(scenario, plan, nr, lay, hold), hull=hull, modes=modes,
                 plan=plan,
                 mass_line=geo.mass_line, wet_weight=plan.wet_weight,
                 hold_stern_bow=hold.stern_bow,
                 gravity=g, seawater_density=rho, steel_density=env.steel_density_kg_m3)


def layout(scenario, hull: Hull, plan: LiftPlan, modes: Modes) -> Layout:
    """The strips and bag points of ``hull`` and ``plan`` on ``modes`` (all of them)."""
    env = scenario.environment
    rho, g, rho_s = env.seawater_density_kg_m3, env.gravity_m_s2, env.steel_density_kg_m3
    xs, ws = strip_points(hull)
    psi_s = modes.shape_at(xs)  # (ns, m)
    bags = plan.bags
    external = np.array([b.kind == "external" for b in bags])
    x_point = np.array([b.x for b in bags], dtype=float)
    el = hull.element_of(xs)
    strip_gen = (psi_s * ws[:, None]).T  # (m, ns)
    wet_line = hull.wet_weight_per_length(g, rho, rho_s)[el]  # at the strips [N/m]
    weight_gen = -(strip_gen @ wet_line
                   + modes.displacement.T @ hull.point_wet_weights(g, rho, rho_s))
    return Layout(xs=xs, ws=ws, el=el, psi_s=psi_s, strip_gen=strip_gen, wet_line=wet_line,
                  weight_gen=weight_gen, external=external, x_point=x_point,
                  capacity=np.array([b.capacity for b in bags]), psi_p=modes.shape_at(x_point),
                  dpsi_p=slope_at(modes, x_point), psi_b=bag_force_shapes(modes, plan))


def holding(scenario, hull: Hull, plan: LiftPlan, lay: Layout) -> Holding:
    """The holding groups of the seabed's suction, their weights and shares."""
    env, sb = scenario.environment, scenario.seabed
    rho, g = env.seawater_density_kg_m3, env.gravity_m_s2
    stern, bow = (sb.stern_ratio, sb.bow_ratio) if sb.holding_shape == "linear" else (1.0, 1.0)
    shape = seabed.holding_shape(lay.xs, hull.length, stern, bow)
    strip_group, bag_group, ng = holding_groups(scenario, [b.name for b in plan.bags],
                                                lay.x_point, lay.external, lay.xs)
    W_g, frac = stretch_shares(strip_group, ng, lay.xs, lay.ws * lay.wet_line, lay.ws * shape,
                               hull, hull.point_wet_weights(g, rho, env.steel_density_kg_m3),
                               plan.wet_weight)
    hold_s = shape / frac[strip_group]  # per unit H of the strip's own group
    return Holding(strip_group=strip_group, bag_group=bag_group, ng=ng, W_g=W_g, frac=frac,
                   shape=shape, strip_hold=hold_s, stern_bow=(stern, bow))


def modal_record(scenario, hull: Hull, modes: Modes, nr: int, lay: Layout) -> Modal:
    """The ``nr`` retained modes' mechanics, weight and the hull's heave and pitch rows."""
    pitch_row = np.zeros(nr)
    pitch_row[1] = float(slope_at(modes, [0.5 * hull.length])[0, 1])
    heave_row = np.zeros(nr)
    heave_row[0] = float(lay.psi_s[0, 0])
    return Modal(nr=nr, omega2=modes.omega[:nr] ** 2,
                 damping=2.0 * scenario.hull.modal_damping * modes.omega[:nr],
                 weight_force=lay.weight_gen[:nr].copy(), pitch_row=pitch_row,
                 heave_row=heave_row)


def strip_record(scenario, hull: Hull, nr: int, lay: Layout, hold: Holding) -> Strips:
    """The strips: their motion and generalised force, drag, seabed contact and hold."""
    rho, hy, sb = scenario.environment.seawater_density_kg_m3, scenario.hydro, scenario.seabed
    ns = lay.xs.size
    return Strips(
        ns=ns, shape=np.ascontiguousarray(lay.psi_s[:, :nr]),
        shape_t=np.ascontiguousarray(lay.psi_s[:, :nr].T),
        force=np.ascontiguousarray(lay.strip_gen[:nr]), weight=lay.ws,
        drag=np.full(ns, hydro.drag_coefficient(rho, hy.drag_coefficient, hull.breadth)),
        contact_k=np.full(ns, sb.contact_stiffness_N_m2),
        contact_c=np.full(ns, sb.contact_damping_Ns_m2), group=hold.strip_group,
        hold=hold.strip_hold)


def bag_record(scenario, hull: Hull, modes: Modes, nr: int, lay: Layout,
               hold: Holding) -> Bags:
    """The bags: their points on the retained modes, their gas and its laws' constants, drag
    and the static correction of the eliminated modes at their points. The external bags
    purge through the catalogue bag's dump valve (:func:`flexlift.scenario.valves.external_valve`:
    the user's ``gas.purge_rate_max_m3_s`` first), the internal ones through
    ``gas.purge_rate_max_m3_s``."""
    rho, hy = scenario.environment.seawater_density_kg_m3, scenario.hydro
    external, capacity, psi_p, dpsi_p, psi_b = (lay.external, lay.capacity, lay.psi_p,
                                                lay.dpsi_p, lay.psi_b)
    nb = external.size
    om2_e, strip_e, bag_e, weight_e = (modes.omega[nr:] ** 2, lay.strip_gen[nr:],
                                       psi_b[:, nr:].T, lay.weight_gen[nr:])
    cs, cw = static_correction(psi_p[:, nr:], om2_e, weight_e)
    ss, sw = static_correction(dpsi_p[:, nr:], om2_e, weight_e)
    return Bags(
        nb=nb, shape=np.ascontiguousarray(psi_p[:, :nr]),
        slope=np.ascontiguousarray(dpsi_p[:, :nr]), force=np.ascontiguousarray(psi_b[:, :nr].T),
        group=hold.bag_group, capacity=capacity, **bag_bodies(scenario, hull, external, capacity),
        drag=np.where(external, hydro.drag_coefficient(
            rho, hy.bag_drag_coefficient, 1.0) * hydro.sphere_frontal_area(capacity), 0.0),
        purge_max=np.where(external, external_valve(scenario).m3_s,
                           scenario.gas.purge_rate_max_m3_s),
        supply_free_air=(scenario.gas.supply_free_air_m3_min or 0.0) / 60.0,
        **gas_constants(scenario),
        corr_shape=cs, corr_weight=cw, slope_shape=ss, slope_weight=sw,
        gen_strip=np.ascontiguousarray(strip_e), gen_bag=np.ascontiguousarray(bag_e),
        count=np.ones(nb))


def bag_bodies(scenario, hull: Hull, external: np.ndarray, capacity: np.ndarray) -> dict:
    """Each bag's type and body (:class:`~flexlift.ascent.records.Bags`: ``relief``, ``kind``,
    ``body_diameter``, ``body_length``, ``cone_top``, ``tip_freeboard``, ``top_offset``).

    The external bags are of the catalogue bag's type (``lift.catalogue_bag.type``), the
    internal ones (in the tanks) the paper's closed cylinders. The paper's type keeps the
    paper's bags as before: external bags spill beyond their capacity, internal ones relieve at
    ``gas.relief_pressure_bar``, a bag's top is a sphere of its capacity above the hull's depth.
    A salvor's bag (docs/theory/gas.md#bag-types): open parachute bags spill from the mouth,
    closed parachute and enclosed bags relieve at their catalogue setting (else
    ``gas.relief_pressure_bar``); its body is the catalogue's diameter and length (an upright
    bag's length is its height), lengthened to hold its true capacity (``capacity_factor`` > 1),
    its top ``rigging.sling_length_m`` and its height above the hull's depth; an open bag tips
    once its top stands :data:`~flexlift.ascent.records.TIP_FRACTION` of its height above the
    surface."""
    bag, gas_relief = scenario.lift.catalogue_bag, scenario.gas.relief_pressure_bar * C.BAR
    kind_ext = BAG_KINDS[bag.type]
    nb = external.size
    kind = np.where(external, kind_ext, BAG_PAPER).astype(np.int64)
    out = dict(relief=np.where(external, 0.0, gas_relief), kind=kind,
               body_diameter=np.zeros(nb), body_length=np.zeros(nb), cone_top=np.zeros(nb),
               tip_freeboard=np.full(nb, np.inf),
               top_offset=hull.depth + np.where(external, hydro.sphere_diameter(capacity), 0.0))
    if kind_ext == BAG_PAPER:
        return out
    D = bag.diameter_m
    area = 0.25 * math.pi * D * D
    cone = (bag.cone_top_m or 0.0) if kind_ext != BAG_ENCLOSED else 0.0
    length = np.maximum(bag.length_m, capacity / area + 2.0 * cone / 3.0)
    height = length if kind_ext != BAG_ENCLOSED else np.full(nb, D)
    relief = 0.0 if kind_ext == BAG_OPEN_PARACHUTE else (
        bag.relief_bar * C.BAR if bag.relief_bar is not None else gas_relief)
    tip = TIP_FRACTION * height if kind_ext == BAG_OPEN_PARACHUTE else np.full(nb, np.inf)
    ext = external
    out.update(relief=np.where(ext, relief, out["relief"]),
               body_diameter=np.where(ext, D, 0.0), body_length=np.where(ext, length, 0.0),
               cone_top=np.where(ext, cone, 0.0), tip_freeboard=np.where(ext, tip, np.inf),
               top_offset=np.where(ext, hull.depth + scenario.lift.rigging.sling_length_m
                                   + height, out["top_offset"]))
    return out


def seabed_record(scenario, plan: LiftPlan, nr: int, lay: Layout, hold: Holding) -> Seabed:
    """The holding groups: their generalised force, initial hold and wet weight."""
    sb = scenario.seabed
    H0 = (scenario.lift.breakout_factor - 1.0) * plan.wet_weight
    if sb.breakout_law == "soil":  # docs/theory/breakout-soil.md#force
        H0 = seabed.soil_breakout_force(scenario.hull.length_m, scenario.hull.breadth_m,
                                        sb.embedment_m, sb.shear_strength_kPa * 1e3)
    hold_s, sg = hold.strip_hold, hold.strip_group
    return Seabed(
        ng=hold.ng,
        hold_force=-np.stack([lay.strip_gen[:nr] @ (hold_s * (sg == k)) for k in range(hold.ng)],
                             axis=1),
        H0=H0 * hold.frac, group_weight=hold.W_g, breakout_time=sb.breakout_time_s,
        release_time=sb.release_time_s, liftoff_clearance=LIFTOFF_CLEARANCE,
        law=seabed.LAWS[sb.breakout_law],
        consolidation_time=sb.drainage_length_m ** 2 / sb.consolidation_coefficient_m2_s)


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
    """Gas volumes at the start (docs/theory/gas.md#initial-state) [m^3]: the internal (closed) bags full, the external
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
    its share of the suction and of the weight, and lets go on its own (docs/theory/seabed.md#stages): a
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
    """InputError when the bags cannot hold the structure neutral at the start (docs/theory/gas.md#initial-state):
    the internal bags full and the external bags sharing the rest of W' must fit."""
    V = plant.neutral_volume
    ext = plant.external
    to_t = plant.seawater_density / C.TONNE  # m^3 of displaced water -> tonnes of lift
    cap = plant.bags.capacity
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
