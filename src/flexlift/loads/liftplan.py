"""Hydrostatics, bag sizing and bag layout (docs/theory/factors.md#bag-count).

How much lift the wreck needs, how many bags of the catalogue size, how much each is modelled
to lift, and where they go: internal cylindrical bags end to end over the ballast-tank span;
external parachute bags balanced on the centre of gravity (``lift.layout: balanced``, the
default: :mod:`flexlift.loads.balance`), or at the nodes of a chosen flexible mode with the
tanks snapped to the element grid (``mode_nodes``, the paper's rule); or an explicit layout
from the scenario (``lift.bags``, clusters with ``count``).
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

from flexlift import constants as C
from flexlift.errors import InputError
from flexlift.loads import balance
from flexlift.physics.hydro import sphere_diameter
from flexlift.scenario.cost import estimate, refusal
from flexlift.structure.hull import Hull
from flexlift.structure.modes import Modes, compute_modes, mode_nodes

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Bag:
    """One lift bag on the hull.

    name : str — "bag_1", ... (externals aft to bow, then internals aft to bow)
    kind : "external" (parachute, point load) or "internal" (cylindrical, uniform load)
    x : float — point of action (external) or span centre (internal) [m from the aft end]
    span : (x0, x1) or None — extent of an internal bag's uniform load [m]
    node : int or None — 0-based node of an external bag when it sits on one
    lift : float — rated (full) lift force [N]
    capacity : float — true gas capacity, capacity_factor x lift / (rho_sw g) [m^3]
    """

    name: str
    kind: Literal["external", "internal"]
    x: float
    span: tuple[float, float] | None
    node: int | None
    lift: float
    capacity: float


@dataclass(frozen=True)
class LiftPlan:
    """The lift plan: weights [N], the bags, and any warnings (e.g. a shortfall)."""

    dry_weight: float  # W, structural weight in air [N]
    wet_weight: float  # W' = W (1 - rho_sw / rho_steel) [N]
    breakout_factor: float  # required lift / wet weight [-]
    required_lift: float  # breakout_factor * W' [N]
    catalogue_lift: float  # lift of one catalogue bag [N]
    bag_lift: float  # modelled lift per bag [N]
    bags: tuple[Bag, ...]
    gravity: float = C.G  # [m/s^2]
    warnings: tuple[str, ...] = ()
    layout: str = "explicit"  # "balanced", "mode_nodes" or "explicit" (lift.bags)
    seawater_density: float = C.RHO_SEAWATER  # [kg/m^3], for the wet weight along the hull
    steel_density: float = C.RHO_STEEL  # [kg/m^3]

    def holding_lifts(self) -> np.ndarray:
        """Each bag's lift while it holds the structure through the ascent [N] (docs/theory/gas.md#initial-state): the
        internal bags full, the external bags sharing the rest of the wet weight equally (their
        rated lift when that is not possible, e.g. no external bag)."""
        lifts = np.array([b.lift for b in self.bags])
        ext = np.array([b.kind == "external" for b in self.bags])
        rest = self.wet_weight - lifts[~ext].sum()
        if ext.any() and rest > 0:
            lifts = np.where(ext, rest / ext.sum(), lifts)
        return lifts

    @property
    def lift_centroid(self) -> float:
        """Where the bags' lift acts while they hold the structure [m from the aft end]."""
        lifts = self.holding_lifts()
        return float(lifts @ np.array([b.x for b in self.bags]) / lifts.sum())

    def lift_points(self) -> list[tuple[float, list[str]]]:
        """The lift points (x [m], bag names) of the external bags, clusters together."""
        points: dict[float, list[str]] = {}
        for b in self.external:
            points.setdefault(round(b.x, 9), []).append(b.name)
        return sorted(points.items())

    @property
    def bag_count(self) -> int:
        return len(self.bags)

    @property
    def total_lift(self) -> float:
        """Sum of the bags' rated lifts [N]."""
        return float(sum(b.lift for b in self.bags))

    @property
    def shortfall(self) -> float:
        """Required lift the bags cannot carry, 0 when they suffice [N]."""
        return max(0.0, self.required_lift - self.total_lift)

    @property
    def external(self) -> tuple[Bag, ...]:
        return tuple(b for b in self.bags if b.kind == "external")

    @property
    def internal(self) -> tuple[Bag, ...]:
        return tuple(b for b in self.bags if b.kind == "internal")

    def bag(self, name: str) -> Bag:
        for b in self.bags:
            if b.name == name:
                return b
        raise InputError("bag", name, f"known bags are {', '.join(b.name for b in self.bags)}")




def bag_count(required_lift_t: float, catalogue_lift_t: float) -> tuple[int, float]:
    """The bag-count rule of docs/theory/factors.md#bag-count: n = ceil(required / catalogue), and the modelled lift
    per bag = required / n rounded up to the tonne. Inputs and output lift in tonnes."""
    if required_lift_t <= 0 or catalogue_lift_t <= 0:
        raise InputError("lift", (required_lift_t, catalogue_lift_t), "lifts must be positive [t]")
    # guard exact multiples against round-off (3616.9999999 / 565 must not become 7.0000001)
    ratio = required_lift_t / catalogue_lift_t
    n = max(1, math.ceil(ratio - 1e-9))
    per = required_lift_t / n
    return n, float(math.ceil(per - 1e-9))


def _snap(x: float, hull: Hull) -> float:
    return float(hull.x_nodes[hull.nearest_node(x)])


def plan_lift(scenario, hull: Hull, modes: Modes | None = None) -> LiftPlan:
    """Size and lay out the bags of ``scenario`` on ``hull``.

    The bag-count rule and the layouts: ``docs/theory/factors.md#bag-count``.

    Parameters
    ----------
    scenario : Scenario
        The lift.
    hull : Hull
        Its structure (:func:`~flexlift.structure.hull.hull_from_scenario`).
    modes : Modes, optional
        The dry modes that place the external bags of the paper's layout (computed here when
        needed and not given).

    Returns
    -------
    LiftPlan
        The bags (``plan.bags``, ``plan.bag(name)``; lifts in N, positions in m) and the
        weights they carry.

    Examples
    --------
    >>> from flexlift import load_scenario
    >>> from flexlift.structure.hull import hull_from_scenario
    >>> from flexlift.loads.liftplan import plan_lift
    >>> scenario = load_scenario("tanker")
    >>> plan = plan_lift(scenario, hull_from_scenario(scenario))
    >>> len(plan.bags), plan.bag("bag_2").node, round(plan.bag("bag_2").lift / 9.81e3)  # t
    (7, 4, 517)
    """
    env = scenario.environment
    lift = scenario.lift
    g, rho = env.gravity_m_s2, env.seawater_density_kg_m3
    dry = hull.total_mass * g
    wet = hull.total_wet_weight(g, rho, env.steel_density_kg_m3)
    if not wet > 0:
        raise InputError("hull", f"wet weight {wet / (C.TONNE * g):.0f} t",
                         "the structure floats in seawater: nothing to lift; check its masses, "
                         "densities and contents")
    # the user's weight contingency (none: none) scales the lift to provide, not the physics
    required = lift.breakout_factor * wet * (lift.weight_contingency or 1.0)
    cat = lift.catalogue_bag.lift_t * C.TONNE * g
    n, per_t = bag_count(required / (C.TONNE * g), lift.catalogue_bag.lift_t)
    _refuse_too_many(scenario, n, required / (C.TONNE * g))
    if lift.bag_lift_t is not None:
        per_t = lift.bag_lift_t
    per = per_t * C.TONNE * g

    factor = lift.catalogue_bag.capacity_factor  # true gas capacity over the rated one

    def make(name, kind, x, span, node, lift_force, own_factor=None):
        f = factor if own_factor is None else own_factor  # a listed bag's own factor
        return Bag(name, kind, float(x), span, node, float(lift_force),
                   f * lift_force / (rho * g))

    bags, layout = _laid_out(scenario, hull, modes, n, per, g, make)
    plan = LiftPlan(dry_weight=dry, wet_weight=wet, breakout_factor=lift.breakout_factor,
                    required_lift=required, catalogue_lift=cat, bag_lift=per, bags=tuple(bags),
                    gravity=g, layout=layout, seawater_density=rho,
                    steel_density=env.steel_density_kg_m3)
    warnings = []
    if plan.shortfall > 0:
        short_t = plan.shortfall / (C.TONNE * g)
        warnings.append(
            f"lift shortfall: the bags carry {plan.total_lift / (C.TONNE * g):.0f} t of the "
            f"{required / (C.TONNE * g):.0f} t required ({short_t:.0f} t short); add a bag or "
            "raise bag_lift_t")
        log.warning(warnings[-1])
    return replace(plan, warnings=tuple(warnings))


def _refuse_too_many(scenario, n: int, required_t: float) -> None:
    """InputError when the automatic layout's ``n`` bags are beyond the cost model's limits
    (the schema's check estimated the count; here it is exact)."""
    lift = scenario.lift
    too_large = refusal(estimate(scenario, bags=n)) if lift.bags is None else None
    if too_large is not None:
        raise InputError("lift.catalogue_bag.lift_t", lift.catalogue_bag.lift_t,
                         f"the plan would need {n:,} bags of it for {required_t:,.0f} t: "
                         f"{too_large}; choose a larger catalogue bag")


def _laid_out(scenario, hull: Hull, modes, n: int, per: float, g: float, make):
    """(the bags, the layout's name): the scenario's own list, or ``n`` bags of ``per`` [N]
    laid out by its rule (internal bags in the tanks, external bags by layout)."""
    lift = scenario.lift
    if lift.bags is not None:
        return _explicit_bags(lift.bags, hull, per, g, make), "explicit"
    n_int = min(lift.internal_bags, n)
    snap = lift.layout == "mode_nodes"  # the paper rounds the tanks to the element grid
    internal = _tank_layout(scenario, hull, n_int, n - n_int, per, make, snap)
    if lift.layout == "mode_nodes":
        external = _mode_layout(lift, modes, hull, n - n_int, per, make)
    else:
        external = _balanced_layout(scenario, hull, n - n_int, per, internal, make)
    return external + internal, lift.layout


def _mode_layout(lift, modes: Modes | None, hull: Hull, n_ext: int, per: float, make) -> list[Bag]:
    """The paper's rule: ``n_ext`` external bags at the nodes of ``lift.layout_flexible_mode``."""
    if not n_ext:
        return []
    if modes is None:
        modes = compute_modes(hull)
    k_mode = lift.layout_flexible_mode
    n_flex = modes.n_modes - modes.n_rigid
    if k_mode > n_flex:
        raise InputError("lift.layout_flexible_mode", k_mode,
                         f"the model has flexible modes 1..{n_flex}; choose one of them or list "
                         "lift.bags")
    nodes = mode_nodes(modes, modes.flexible_index(k_mode))
    if len(set(nodes)) != len(nodes):
        raise InputError("lift.layout_flexible_mode", k_mode,
                         f"the nodes of flexible mode {k_mode} fall on the same beam node "
                         f"({[k + 1 for k in nodes]}); use more hull.elements or list lift.bags")
    if len(nodes) != n_ext:
        raise InputError("lift.layout_flexible_mode", k_mode,
                         f"flexible mode {k_mode} has {len(nodes)} nodes but the plan needs "
                         f"{n_ext} external bags; use mode {n_ext - 1} or list lift.bags")
    return [make(f"bag_{k + 1}", "external", hull.x_nodes[node], None, node, per)
            for k, node in enumerate(nodes)]


def _balanced_layout(scenario, hull: Hull, n_ext: int, per: float, internal: list[Bag],
                     make) -> list[Bag]:
    """``n_ext`` external bags balancing the hull (:mod:`flexlift.loads.balance`) in the state
    they hold it through the ascent: the submerged weight less the internal bags' lift, shared
    equally (the breakout pull on top is shaped like the suction by the controllers)."""
    if not n_ext:
        return []
    env = scenario.environment
    g, rho, rho_s = env.gravity_m_s2, env.seawater_density_kg_m3, env.steel_density_kg_m3
    spans = [b.span for b in internal]
    lifts = [b.lift for b in internal]
    x, q, points = balance.design_load(
        hull, hull.wet_weight_per_length(g, rho, rho_s),
        hull.point_wet_weights(g, rho, rho_s), spans, lifts, 1.0)
    start = balance.equal_share_positions(x, q, points, n_ext)
    load = np.trapezoid(q, x) + sum(F for _, F in points)
    moment = np.trapezoid(q * x, x) + sum(F * xp for xp, F in points)
    share = load / n_ext  # what each external bag holds through the ascent [N]
    pos = balance.refine(x, q, points, start, share, moment, hull.length)
    diameter = float(sphere_diameter(per / (rho * g)))
    bags, k = [], 0
    for xp, count in balance.clusters(pos, diameter):
        for _ in range(count):
            k += 1
            bags.append(make(f"bag_{k}", "external", xp, None, None, per))
    return bags


def _tank_layout(scenario, hull: Hull, n_int: int, n_ext: int, per: float, make,
                 snap: bool = True) -> list[Bag]:
    """``n_int`` internal bags end to end over the ballast-tank span (its ends snapped to the
    nearest nodes when ``snap``, as the paper does)."""
    if not n_int:
        return []
    edges = tank_edges(scenario, hull, n_int, snap)
    return [make(f"bag_{n_ext + k + 1}", "internal", 0.5 * (edges[k] + edges[k + 1]),
                 (float(edges[k]), float(edges[k + 1])), None, per) for k in range(n_int)]


def tank_edges(scenario, hull: Hull, n_int: int, snap: bool = True) -> np.ndarray:
    """The ends of ``n_int`` internal bags laid end to end over the ballast-tank span
    (``hull.ballast_tank_frames`` x ``hull.frame_spacing_m``) [m], (n_int + 1,); the span's
    ends snapped to the nearest nodes when ``snap``. A span off the hull is one line."""
    fs = scenario.hull.frame_spacing_m
    f0, f1 = scenario.hull.ballast_tank_frames
    x0, x1 = (_snap(f0 * fs, hull), _snap(f1 * fs, hull)) if snap else (f0 * fs, f1 * fs)
    if not 0 <= f0 * fs < f1 * fs <= hull.length or x1 <= x0:
        raise InputError("hull.ballast_tank_frames", [f0, f1],
                         f"the tank span must lie on the hull, 0..{hull.length / fs:.0f} frames")
    return np.linspace(x0, x1, n_int + 1)


def _explicit_bags(specs, hull: Hull, default_lift: float, g: float, make) -> list[Bag]:
    """Bags listed in the scenario; default_lift [N], g [m/s^2]."""
    L = hull.length
    bags: list[Bag] = []
    for s in specs:
        lift_force = default_lift if s.lift_t is None else s.lift_t * C.TONNE * g
        if s.kind == "external":
            if s.node is not None:
                if s.node > hull.n_nodes:
                    raise InputError(
                        f"lift.bags.{s.name}.node", s.node, f"nodes are 1..{hull.n_nodes}"
                    )
                node = s.node - 1
                x = float(hull.x_nodes[node])
            else:
                x = float(s.x_m)
                if not 0 <= x <= L:
                    raise InputError(
                        f"lift.bags.{s.name}.x_m", x, f"must lie on the hull, 0..{L} m"
                    )
                near = hull.nearest_node(x)
                node = near if abs(hull.x_nodes[near] - x) < 1e-9 * L else None
            names = [s.name] if s.count == 1 else [f"{s.name}_{j + 1}" for j in range(s.count)]
            bags += [make(nm, "external", x, None, node, lift_force, s.capacity_factor)
                     for nm in names]
        else:
            a, b = (float(v) for v in s.span_m)
            if not (0 <= a < b <= L):
                raise InputError(
                    f"lift.bags.{s.name}.span_m", [a, b], f"must lie on the hull, within 0..{L} m"
                )
            if s.count != 1:
                raise InputError(f"lift.bags.{s.name}.count", s.count,
                                 "clusters are of external bags; an internal bag fills its span")
            bags.append(make(s.name, "internal", 0.5 * (a + b), (a, b), None, lift_force,
                             s.capacity_factor))
    names = [b.name for b in bags]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise InputError("lift.bags", dup[0], "bag names must be unique, also within clusters "
                         "(a cluster 'x' of 2 is x_1, x_2)")
    spans = sorted((b.span, b.name) for b in bags if b.span is not None)
    for (s1, n1), (s2, n2) in zip(spans, spans[1:]):
        if s2[0] < s1[1] - 1e-9:
            raise InputError(
                "lift.bags",
                f"{n1} {list(s1)} and {n2} {list(s2)}",
                "internal bags must not overlap; shorten or move one",
            )
    return bags
