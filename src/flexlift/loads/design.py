"""The static design cases of the lift plan, each closed physically (docs/theory/strength.md#design-cases).

A free structure in water is in equilibrium only when its loads have no resultant and no
moment. A lift plan's loads are not exactly so (bags rounded up to the tonne, a lift centroid
a little off the load's, the breakout pull a fraction of the suction), and a shear-moment
diagram of an open load case ends at the free bow with the imbalance times its lever: an
artefact that can exceed the real moments. Each design case here is closed as the structure
itself closes it:

1. **Scale.** The external bags' lifts are scaled by one factor ``s`` so that the bags carry
   the total downward load exactly (``s`` is reported: 1 where the plan already balances, the
   bags' excess or shortfall otherwise). The internal bags are full in every case and cannot
   give more, so they are not scaled; a plan without external bags (or whose internal bags
   alone outweigh the load) scales every bag.
2. **Inertia relief.** The remaining moment (and any force left by round-off) accelerates the
   structure as a rigid body: heave a_0 of the centre of the moving mass and pitch alpha about
   it, with the mass that accelerates in water (structure and point masses, plus the added
   mass and the entrained water spread over the length, as the ascent integrates them). The
   inertia loads -m(x) (a_0 + alpha (x - x_G)) close the force and the moment exactly; no
   fictitious trim load is added.

The three cases (names as in the JSON summary):

- ``holding``: the wet weight W' against the bags' holding lifts (the internal bags full, the
  external bags sharing the rest), the state the bags hold the structure in through the ascent;
- ``breakout``: W' plus the suction H_0 in the scenario's holding shape (the tanker's 0.5 at
  the stern to 1.5 at the bow, as the ascent applies it) against the holding lifts plus the
  breakout pull shaped like the suction; scaled to carry W' + H_0 at once (the 1.3 rule's
  load: the external bags then stand near their full lift, in the pull's shape; a planned
  pull of a fraction of H_0 breaks the suction over time instead, the factor says how much);
- ``full_lift``: every bag at its full capacity against the same W' + H_0 in its shape: the
  envelope of what the plan can apply (the bags are sized to it, so the factor is near 1).

The paper's still-water table (the bags at full lift against 1.3 W' distributed like the
mass, not closed: its closing values measure the imbalance) is :func:`paper_case`.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from flexlift.loads.strength import (
    LineLoad,
    LoadCase,
    PointLoad,
    Strength,
    lift_load_case,
    strength,
)
from flexlift.structure.hull import Hull

#: the design cases in the order they are reported
CASES = ("holding", "breakout", "full_lift")
TITLES = {
    "holding": "holding: W' against the holding lifts",
    "breakout": "breakout: W' + H0 (its shape) against holding lifts + the shaped pull",
    "full_lift": "full-lift envelope: every bag at full capacity against W' + H0",
}


@dataclass(frozen=True)
class Closure:
    """How a load case was closed.

    scale : factor on the bags' lifts that carries the total load [-]
    heave_acceleration : upward acceleration of the centre of the moving mass [m/s^2]
    pitch_acceleration : bow-up angular acceleration about that centre [rad/s^2]
    centre : x of the centre of the moving mass [m]
    moving_mass : the mass that accelerates in water [kg]
    """

    scale: float
    heave_acceleration: float
    pitch_acceleration: float
    centre: float
    moving_mass: float


@dataclass(frozen=True)
class DesignCase:
    """A closed design case: its ``name`` (:data:`CASES`), the closed load case (inertia loads
    included), its shear force and bending moment, and the closure."""

    name: str
    case: LoadCase
    strength: Strength
    closure: Closure
    lifts: dict  # bag name -> lift after scaling [N]

    @property
    def title(self) -> str:
        return TITLES.get(self.name, self.name)


def close(case: LoadCase, lifts: set[str], hull: Hull, mass_per_length) -> tuple[LoadCase, Closure]:
    """``case`` closed physically (module docstring): the loads named in ``lifts`` scaled to
    carry the rest, then inertia relief of the rigid body with ``mass_per_length`` (n_el,)
    [kg/m] per element (structure plus the water that moves with it) and ``hull``'s point
    masses [kg] at the nodes. Returns the closed case (inertia loads named ``inertia*``) and
    the :class:`Closure`."""
    up = sum(p.force for p in case.point_loads if p.name in lifts) + sum(
        d.resultant for d in case.line_loads if d.name in lifts)
    rest = case.total_force - up
    s = -rest / up if up > 0 and rest < 0 else 1.0
    points = [replace(p, force=p.force * s) if p.name in lifts else p for p in case.point_loads]
    line = [LineLoad(d.name, d.x0, d.x1, d.q0 * s, None if d.q1 is None else d.q1 * s)
            if d.name in lifts else d for d in case.line_loads]
    scaled = LoadCase(case.length, tuple(line), tuple(points))
    m_e = np.broadcast_to(np.asarray(mass_per_length, dtype=float), (hull.n_elements,))
    l, xn = hull.element_length, hull.x_nodes
    xc = 0.5 * (xn[:-1] + xn[1:])
    pm = hull.point_masses
    mass = float(m_e.sum() * l + pm.sum())
    xg = float((m_e * l) @ xc + pm @ xn) / mass
    inertia_g = float((m_e * l) @ ((xc - xg) ** 2 + l * l / 12.0) + pm @ (xn - xg) ** 2)
    F = scaled.total_force
    M_g = scaled.moment_about_aft - F * xg  # about the centre; upward forces forward: bow-up
    a0 = F / mass
    alpha = M_g / inertia_g  # [rad/s^2], bow-up positive

    def acc(x):  # upward rigid-body acceleration at x [m/s^2]
        return a0 + alpha * (np.asarray(x, dtype=float) - xg)

    if np.allclose(m_e, m_e[0], rtol=1e-12, atol=0.0):
        inertia = [LineLoad("inertia", 0.0, hull.length, float(-m_e[0] * acc(0.0)),
                            float(-m_e[0] * acc(hull.length)))]
    else:
        inertia = [LineLoad(f"inertia_e{e + 1}", float(xn[e]), float(xn[e + 1]),
                            float(-m * acc(xn[e])), float(-m * acc(xn[e + 1])))
                   for e, m in enumerate(m_e)]
    ipoints = [PointLoad(f"inertia_n{j + 1}", float(xn[j]), float(-m * acc(xn[j])))
               for j, m in enumerate(pm) if m > 0]
    closed = LoadCase(case.length, tuple(line) + tuple(inertia), tuple(points) + tuple(ipoints))
    return closed, Closure(scale=float(s), heave_acceleration=float(a0),
                           pitch_acceleration=float(alpha), centre=xg, moving_mass=mass)


def suction_load(length: float, H0: float, stern_bow: tuple[float, float]) -> LineLoad:
    """The suction H_0 [N] as a downward line load in its holding shape: linear from
    ``stern_bow[0]`` to ``stern_bow[1]`` times the mean H_0 / L (the ratios sum to 2)."""
    stern, bow = stern_bow
    return LineLoad("suction", 0.0, length, -H0 * stern / length, -H0 * bow / length)


def design_cases(plan, hull: Hull, mass_per_length, H0: float, stern_bow: tuple[float, float],
                 pulls: dict, per_element: int = 50, holding: dict | None = None
                 ) -> tuple[DesignCase, ...]:
    """The three design cases of :data:`CASES`, each closed by :func:`close`.

    plan : the :class:`~flexlift.loads.liftplan.LiftPlan`; hull : the beam it was laid on
    mass_per_length : (n_el,) or scalar — the mass that accelerates in water per element:
        structure plus added mass plus entrained water [kg/m] (point masses from ``hull``)
    H0 : the suction [N]; stern_bow : its holding shape's (stern, bow) ratios [-]
    pulls : the breakout pull of each external bag by name [N], shaped like the suction
    per_element : sample intervals per element for V and M
    holding : each bag's holding lift by name [N], as the ascent holds it (a staged lift
        shares the weight within each stage's stretch); default the plan's
        :meth:`~flexlift.loads.liftplan.LiftPlan.holding_lifts`
    """
    ext = {b.name for b in plan.bags if b.kind == "external"}
    internal = sum(b.lift for b in plan.bags if b.kind == "internal")
    if holding is None:
        holding = dict(zip([b.name for b in plan.bags], plan.holding_lifts().tolist()))
    pulled = {k: v + float(pulls.get(k, 0.0)) for k, v in holding.items()}
    full = {b.name: b.lift for b in plan.bags}
    suction = (suction_load(hull.length, H0, stern_bow),) if H0 > 0 else ()
    out = []
    for name, lifts, extra in (("holding", holding, ()), ("breakout", pulled, suction),
                               ("full_lift", full, suction)):
        base = lift_load_case(plan, hull, lifts, weight_factor=1.0)
        base = LoadCase(base.length, base.line_loads + extra, base.point_loads)
        # the external bags carry what the full internal bags leave (all bags when none is)
        scaled = ext if ext and -base.total_force + sum(lifts.values()) > internal else set(lifts)
        closed, closure = close(base, scaled, hull, mass_per_length)
        out.append(DesignCase(name, closed, strength(closed, hull, per_element), closure,
                              {k: v * (closure.scale if k in scaled else 1.0)
                               for k, v in lifts.items()}))
    return tuple(out)


def paper_case(plan, hull: Hull, per_element: int = 50) -> tuple[LoadCase, Strength]:
    """The paper's still-water case (docs/theory/strength.md#shear-moment): every bag at full lift against the breakout
    factor times W' distributed like the mass, integrated from the aft end and not closed;
    its values at the bow are its closing errors (the tanker: 0.021 MN, 0.84 MN m)."""
    case = lift_load_case(plan, hull)
    return case, strength(case, hull, per_element)
