"""A hull's trapped water on the final lift through the sea surface (docs/theory/trapped-water.md).

A hull lifted out of the water at a steady speed (by a crane, or held at the surface by bags
and craned out) carries the water that flooded it. While the hull is submerged that water
weighs nothing; as the hull rises through the surface the water inside stands above the sea
outside and weighs its full weight until it drains out through the hull's openings. The lift
force is

    F = m g (1 - f rho_w / rho_s) + rho_w g A max(h_in - h_e, 0)

- ``m g (1 - f rho_w / rho_s)``: the steel's weight less the buoyancy of the fraction ``f`` of
  it still below the waterline (:func:`flexlift.physics.hydro.submerged_weight`, the one law
  of the wet weight, with the displaced water scaled by ``f``): W' when the hull is
  submerged, its weight in air m g once it is out. The steel is taken spread evenly over the
  hull's depth D (f = h_e / D);
- ``rho_w g A (h_in - h_e)``: the water inside, of plan area A = V_t / D (the trapped volume
  V_t as a prism over the depth), standing at ``h_in`` above the keel while the sea outside
  stands at ``h_e`` = the waterline above the keel, clipped to [0, D];
- the drainage, Torricelli's orifice law through openings of area a at the keel with
  discharge coefficient C_d: A dh_in/dt = -C_d a sign(dh) sqrt(2 g |dh|), dh = h_in - h_e (a
  submerged opening is driven by the difference of the levels, an opening above the sea by
  the head over it: h_e = 0 then, the same formula). Water flows back in while dh < 0, so a
  submerged hull stays full.

The level's equation is integrated with :func:`scipy.integrate.solve_ivp`, piece by piece
between the kinks of the lift (the top reaching the surface, the keel leaving it, the crane
stopping). Surface tension, drag and the hull's inertia at crane speeds are neglected (the
page says by how much). This is a law of the final lift only: the ascent loop's hull stays
submerged and does not call it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

from flexlift import constants as C
from flexlift.errors import InputError
from flexlift.physics.hydro import submerged_weight


@dataclass(frozen=True)
class Surfacing:
    """The hull's water-holding space, its openings and the lift out of the water (SI).

    hull_depth_m : float — D, keel to the top of the space that holds water [m]
    trapped_volume_m3 : float — V_t, the water that space holds when flooded [m^3]
    opening_area_m2 : float — a, the openings' total area at the keel [m^2] (0: none drain)
    discharge_coefficient : float — C_d of the openings [-] (0.61: a sharp-edged orifice)
    lift_speed_m_s : float — the steady lift speed [m/s]
    start_depth_m : float — the hull's top below the surface when the history starts [m]
    clearance_m : float — the keel's height above the surface where the lift stops [m]
    hold_s : float — how long the history goes on after the lift stops [s]
    """

    hull_depth_m: float
    trapped_volume_m3: float
    opening_area_m2: float
    lift_speed_m_s: float
    discharge_coefficient: float = 0.61
    start_depth_m: float = 1.0
    clearance_m: float = 1.0
    hold_s: float = 3600.0

    def __post_init__(self):
        positive = ("hull_depth_m", "lift_speed_m_s", "hold_s")
        for name in positive:
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise InputError(f"surfacing.{name}", v, "must be a positive number")
        for name in ("trapped_volume_m3", "opening_area_m2", "start_depth_m", "clearance_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise InputError(f"surfacing.{name}", v, "must be zero or more")
        cd = self.discharge_coefficient
        if not (math.isfinite(cd) and 0 < cd <= 1):
            raise InputError("surfacing.discharge_coefficient", cd, "must be in (0, 1]")

    @property
    def plan_area_m2(self) -> float:
        """A = V_t / D, the water-holding space's plan area [m^2]."""
        return self.trapped_volume_m3 / self.hull_depth_m

    def keel_height(self, t):
        """The keel's height above the sea surface [m] at time ``t`` [s] (negative below)."""
        t_stop = self.kinks()[-1]
        return -(self.hull_depth_m + self.start_depth_m) + self.lift_speed_m_s * np.minimum(t, t_stop)

    def kinks(self) -> tuple[float, float, float]:
        """Times [s]: the top reaching the surface, the keel leaving it, the lift stopping."""
        v, d0, D = self.lift_speed_m_s, self.start_depth_m, self.hull_depth_m
        return d0 / v, (d0 + D) / v, (d0 + D + self.clearance_m) / v


def waterline_above_keel(keel_height, hull_depth):
    """h_e [m]: the sea's level above the keel, clipped to the hull's depth [0, D], for a keel
    ``keel_height`` [m] above the surface (negative below) and depth ``hull_depth`` [m]."""
    return np.clip(-np.asarray(keel_height, dtype=float), 0.0, hull_depth)


def drain_rate(level_in, waterline, opening_area, discharge_coefficient, plan_area, g=C.G):
    """dh_in/dt [m/s] by Torricelli's law: -(C_d a / A) sign(dh) sqrt(2 g |dh|) for the inside
    level ``level_in`` and the waterline ``waterline`` above the keel [m], openings of area
    ``opening_area`` [m^2] and coefficient ``discharge_coefficient`` [-], plan area
    ``plan_area`` [m^2] (> 0), ``g`` [m/s^2]."""
    dh = max(float(level_in), 0.0) - float(waterline)
    k = discharge_coefficient * opening_area / plan_area
    return -k * math.copysign(math.sqrt(2.0 * g * abs(dh)), dh)


def lift_force(mass, level_in, waterline, hull_depth, plan_area, g=C.G, rho_water=C.RHO_SEAWATER,
               rho_steel=C.RHO_STEEL):
    """The lift force [N]: the steel's ``mass`` [kg] less the buoyancy of the fraction of it
    below the ``waterline`` [m above the keel] of a hull ``hull_depth`` [m] deep, plus the
    water of plan area ``plan_area`` [m^2] standing inside at ``level_in`` [m] above the sea
    (module docstring); works on arrays."""
    f = np.asarray(waterline, dtype=float) / hull_depth
    steel = submerged_weight(mass, g, rho_water * f, rho_steel)
    held = np.maximum(np.asarray(level_in, dtype=float) - waterline, 0.0)
    return steel + rho_water * g * plan_area * held


@dataclass(frozen=True)
class History:
    """A lift force history [SI]: ``time`` [s], ``keel_height`` [m above the surface],
    ``level_in`` and ``waterline`` [m above the keel], ``force`` [N], and the steel's weight
    in water and in air [N] it starts and ends at."""

    time: np.ndarray
    keel_height: np.ndarray
    level_in: np.ndarray
    waterline: np.ndarray
    force: np.ndarray
    weight_in_water: float
    weight_in_air: float

    @property
    def peak(self) -> float:
        """The largest lift force [N]."""
        return float(self.force.max())

    @property
    def peak_time(self) -> float:
        """When the largest force occurs [s]."""
        return float(self.time[int(np.argmax(self.force))])

    def summary(self) -> dict:
        """The history's numbers in MN and s (for a report or ``--json``)."""
        return {"weight_in_water_MN": self.weight_in_water / 1e6,
                "weight_in_air_MN": self.weight_in_air / 1e6,
                "peak_MN": self.peak / 1e6, "peak_time_s": self.peak_time,
                "peak_over_weight_in_water": self.peak / self.weight_in_water,
                "final_MN": float(self.force[-1]) / 1e6,
                "drained_time_s": self.drained_time(),
                "duration_s": float(self.time[-1])}

    def drained_time(self, fraction: float = 0.01) -> float:
        """The first time [s] after the peak when the held water's weight is below
        ``fraction`` of the peak's excess over the weight in air (nan: never in the history)."""
        excess = self.force - self.weight_in_air
        after = self.time >= self.peak_time
        below = after & (excess <= fraction * excess.max())
        return float(self.time[np.argmax(below)]) if below.any() else math.nan


def force_history(mass: float, surfacing: Surfacing, g: float = C.G,
                  rho_water: float = C.RHO_SEAWATER, rho_steel: float = C.RHO_STEEL,
                  step_s: float = 1.0) -> History:
    """The lift force history of a hull of steel ``mass`` [kg] raised through the surface as
    ``surfacing`` says, sampled every ``step_s`` [s]; ``g`` [m/s^2], densities [kg/m^3]."""
    if not (math.isfinite(mass) and mass > 0):
        raise InputError("mass", mass, "must be a positive mass [kg]")
    s, D = surfacing, surfacing.hull_depth_m
    A = s.plan_area_m2
    ends = sorted({0.0, *s.kinks(), s.kinks()[-1] + s.hold_s})
    times, levels = [np.array([0.0])], [np.array([D])]
    for t0, t1 in zip(ends[:-1], ends[1:]):
        if t1 <= t0:
            continue
        t_eval = np.unique(np.r_[np.arange(math.ceil(t0 / step_s) * step_s, t1, step_s), t1])
        t_eval = t_eval[t_eval > t0]
        if A == 0.0 or s.opening_area_m2 == 0.0:
            times.append(t_eval), levels.append(np.full(t_eval.size, D))
            continue

        def rate(t, y):
            h_e = float(waterline_above_keel(s.keel_height(t), D))
            return [drain_rate(y[0], h_e, s.opening_area_m2, s.discharge_coefficient, A, g)]

        sol = solve_ivp(rate, (t0, t1), [levels[-1][-1]], t_eval=t_eval, rtol=1e-9, atol=1e-9,
                        max_step=max((t1 - t0) / 50.0, 1e-3))
        if not sol.success:  # pragma: no cover - the right-hand side is bounded and smooth
            raise RuntimeError(f"trapped water: the level's integration failed ({sol.message})")
        times.append(sol.t), levels.append(np.maximum(sol.y[0], 0.0))
    t, h_in = np.concatenate(times), np.concatenate(levels)
    z = s.keel_height(t)
    h_e = waterline_above_keel(z, D)
    return History(t, z, h_in, h_e, lift_force(mass, h_in, h_e, D, A, g, rho_water, rho_steel),
                   float(submerged_weight(mass, g, rho_water, rho_steel)), mass * g)


def mass_for_weight_in_water(weight_in_water: float, g: float = C.G,
                             rho_water: float = C.RHO_SEAWATER,
                             rho_steel: float = C.RHO_STEEL) -> float:
    """The steel mass [kg] whose weight in water is ``weight_in_water`` [N]: W' over the
    wet weight of one kilogram (:func:`~flexlift.physics.hydro.submerged_weight`)."""
    return weight_in_water / float(submerged_weight(1.0, g, rho_water, rho_steel))


def trapped_volume_for_peak(mass: float, peak: float, surfacing: Surfacing, g: float = C.G,
                            rho_water: float = C.RHO_SEAWATER,
                            rho_steel: float = C.RHO_STEEL) -> float:
    """The trapped volume V_t [m^3] that makes the history's largest force ``peak`` [N] for a
    hull of steel ``mass`` [kg] lifted as ``surfacing`` says (its own V_t ignored): the
    inverse of :func:`force_history`, by Brent's method. It is a fit: the peak it matches is
    then no evidence for the law (docs/theory/trapped-water.md#circularity)."""
    from dataclasses import replace

    from scipy.optimize import brentq

    def excess(volume):
        s = replace(surfacing, trapped_volume_m3=volume)
        return force_history(mass, s, g, rho_water, rho_steel).peak - peak

    if excess(0.0) >= 0.0:
        raise InputError("peak", peak, f"must exceed the weight in air {mass * g:.6g} N")
    hi = (peak - mass * g) / (rho_water * g)  # undrained: the least volume that reaches it
    while excess(hi) < 0.0:
        hi *= 2.0
        if hi > 1e9:
            raise InputError("peak", peak, "is not reached by any trapped volume: the "
                             "openings drain faster than the hull leaves the water")
    return float(brentq(excess, 0.0, hi, xtol=1e-6))


def scenario_history(scenario, step_s: float = 1.0) -> History:
    """The force history of a scenario's final lift (its ``surfacing:`` section, the hull's
    depth ``hull.depth_m``): the steel of the scenario's hull at the density that gives its
    wet weight W' (steel unless ``hull.submerged_weight_t`` says otherwise), so the history
    starts at exactly the W' of every other stage."""
    from flexlift.structure.hull import hull_from_scenario

    section = scenario.surfacing
    if section is None:
        raise InputError("surfacing", None, "the scenario needs a surfacing: section (the "
                         "trapped water and the lift out of the water) for this")
    env = scenario.environment
    g, rho_w = env.gravity_m_s2, env.seawater_density_kg_m3
    hull = hull_from_scenario(scenario)
    mass = hull.total_mass
    wet = hull.total_wet_weight(g, rho_w, env.steel_density_kg_m3)
    rho = mass * g * rho_w / (mass * g - wet)  # the mean density: mass over displaced volume
    lift = Surfacing(hull_depth_m=scenario.hull.depth_m, **section.model_dump())
    return force_history(mass, lift, g, rho_w, rho, step_s)
