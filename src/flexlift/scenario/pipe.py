"""The scenario's ``pipe`` section: a pipeline described by its cross-section (docs/theory/statics.md#pipe-section).

Given instead of the ship's ``hull`` numbers: :func:`derive` fills the ``hull`` section (mass,
EI and section modulus per element, the coated diameter as breadth), the explicit bags of
``lift.bags`` from the lift points, and the breakout factor from the suction per unit length,
before the scenario is validated. The section laws are in :mod:`flexlift.physics.pipe`.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from flexlift import constants as C
from flexlift.scenario.types import (
    MAX_ELEMENTS,
    MAX_ITEMS,
    MAX_LENGTH_M,
    MAX_MASS_T,
    Name,
    Real,
    real,
    whole,
)


class _Section(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)


Density = real(1.0, 20_000)  # [kg/m^3]: positive; gas-filled ~1 .. lead 11340
Contents = Literal["empty", "flooded"] | Density


def _wall_inside(owner: str, D, t) -> None:
    if D is not None and t is not None and not t < D / 2:
        raise ValueError(f"{owner}wall_thickness_m {t} m must be less than the radius "
                         f"outside_diameter_m / 2 = {D / 2} m")


class PipeSegment(_Section):
    """A stretch ``[from_m, to_m]`` with a different section: any section key overrides the
    pipe's (e.g. a heavier riser end)."""

    from_m: real(0, MAX_LENGTH_M)
    to_m: real(0, MAX_LENGTH_M)
    outside_diameter_m: real(0.01, 5) | None = None
    wall_thickness_m: real(0.0005, 1) | None = None
    steel_density_kg_m3: Density | None = None
    youngs_modulus_Pa: real(1e9, 1e12) | None = None
    smys_MPa: real(50, 2000) | None = None
    coating_thickness_m: real(0, 1) | None = None
    coating_density_kg_m3: Density | None = None
    contents: Contents | None = None

    @model_validator(mode="after")
    def _check(self) -> PipeSegment:
        if not self.from_m < self.to_m:
            raise ValueError(f"segment [from_m, to_m] = [{self.from_m}, {self.to_m}] must be "
                             "increasing")
        return self


class PipePointMass(_Section):
    """A valve, tee or PLET: a lumped mass at ``x_m`` (moved to the nearest node)."""

    x_m: Real  # [m] from the start of the line; its range 0 .. length_m is the pipe's check
    mass_t: real(0.001, MAX_MASS_T)


class LiftPoints(_Section):
    """Where the bags hold the pipe: every ``spacing_m`` (the first and last half a spacing
    from the ends) or at ``positions_m``; ``count`` bags at each point. Each point's bags are
    sized from the wet weight of the length it carries (half-way to its neighbours and the ends)
    times the breakout factor."""

    spacing_m: real(0.1, MAX_LENGTH_M) | None = None
    positions_m: Annotated[list[real(0, MAX_LENGTH_M)], Field(min_length=1,
                                                               max_length=MAX_ITEMS)] | None = None
    count: whole(1, 100) = 1  # bags per lift point (a cluster)
    margin: real(1, 3) = 1.0  # bag lift / what it carries (1: just enough)

    @model_validator(mode="after")
    def _check(self) -> LiftPoints:
        if (self.spacing_m is None) == (self.positions_m is None):
            raise ValueError("give exactly one of spacing_m or positions_m")
        return self


class Pipe(_Section):
    """A pipeline from its cross-section. Defaults: a 20-inch (508 mm x 15.9 mm) API 5L X65
    line with 60 mm of concrete weight coat, empty, 1 km on 1,000 elements."""

    length_m: real(1, MAX_LENGTH_M) = 1000.0
    elements: whole(1, MAX_ELEMENTS) = 1000
    outside_diameter_m: real(0.01, 5) = 0.508  # 20 inch (API 5L)
    wall_thickness_m: real(0.0005, 1) = 0.0159  # 0.625 inch, a standard 20-inch wall (API 5L)
    steel_density_kg_m3: Density = C.RHO_STEEL
    youngs_modulus_Pa: real(1e9, 1e12) = 207e9  # carbon steel (DNV-ST-F101 uses 207 GPa)
    smys_MPa: real(50, 2000) = 448.0  # X65 (API 5L / ISO 3183: 448 MPa)
    coating_thickness_m: real(0, 1) = 0.060  # concrete weight coat, typically 40-150 mm
    coating_density_kg_m3: Density = 3044.0  # high-density concrete (190 pcf), common spec
    contents: Contents = "empty"
    allowable_stress_MPa: real(1, 2000) | None = None  # default 0.72 SMYS (docs/theory/statics.md#pipe-section)
    breakout_suction_kN_m: real(0, 1000) | None = None  # suction per length; default: lift.breakout_factor
    segments: Annotated[list[PipeSegment], Field(max_length=MAX_ITEMS)] = []
    point_masses: Annotated[list[PipePointMass], Field(max_length=MAX_ITEMS)] = []
    lift_points: LiftPoints | None = None
    bag_prefix: Name = "B"  # lift-point bags are named B01, B02, ... (clusters B01_1, ...)

    @model_validator(mode="after")
    def _check(self) -> Pipe:
        _wall_inside("", self.outside_diameter_m, self.wall_thickness_m)
        L = self.length_m
        for k, s in enumerate(self.segments):
            D = s.outside_diameter_m or self.outside_diameter_m
            t = s.wall_thickness_m or self.wall_thickness_m
            _wall_inside(f"segments[{k}] ", D, t)
            if s.to_m > L:
                raise ValueError(f"segments[{k}] to_m {s.to_m} m is off the line (length_m {L} m)")
        for k, p in enumerate(self.point_masses):
            if not 0 <= p.x_m <= L:
                raise ValueError(f"point_masses[{k}].x_m = {p.x_m:g} m is off the line; "
                                 f"allowed [0, {L:g}] m (0 .. length_m)")
        lp = self.lift_points
        if lp is not None and lp.positions_m is not None:
            off = [x for x in lp.positions_m if x > L]
            if off:
                raise ValueError(f"lift_points.positions_m {off[0]} m is off the line (0..{L} m)")
            if sorted(set(lp.positions_m)) != list(lp.positions_m):
                raise ValueError("lift_points.positions_m must be increasing")
        if lp is not None and lp.spacing_m is not None and lp.spacing_m > L:
            raise ValueError(f"lift_points.spacing_m {lp.spacing_m} m is longer than the line "
                             f"({L} m)")
        return self

    def lift_positions(self) -> list[float]:
        """The lift points along the line [m]."""
        lp = self.lift_points
        if lp is None:
            return []
        if lp.positions_m is not None:
            return [float(x) for x in lp.positions_m]
        n = max(1, int(math.floor(self.length_m / lp.spacing_m + 1e-9)))
        s = self.length_m / n
        return [(k + 0.5) * s for k in range(n)]


def _bags(pipe: Pipe, hull: dict, breakout: float, g: float, rho: float) -> list[dict]:
    """The explicit bags of the lift points, each sized from the wet weight it carries."""
    import numpy as np

    from flexlift.physics.pipe import element_sections

    xs = pipe.lift_positions()
    n, L = pipe.elements, pipe.length_m
    q = np.array([s.wet_weight(g, rho) for s in element_sections(pipe, rho)])
    xe = np.linspace(0.0, L, n + 1)
    edges = [0.0] + [(a + b) / 2 for a, b in zip(xs, xs[1:])] + [L]
    lp = pipe.lift_points
    points = [(min(int(p.x_m / L * n), n - 1), p.mass_t * C.TONNE * g
               * (1 - rho / pipe.steel_density_kg_m3)) for p in pipe.point_masses]
    bags = []
    width = len(str(len(xs)))
    for k, x in enumerate(xs):
        a, b = edges[k], edges[k + 1]
        overlap = np.clip(np.minimum(xe[1:], b) - np.maximum(xe[:-1], a), 0.0, None)
        carried = float(overlap @ q)
        carried += sum(w for e, w in points if a <= (e + 0.5) * L / n < b or (b == L and e == n - 1
                                                                          and a <= (e + .5) * L / n))
        lift_t = breakout * lp.margin * carried / (C.TONNE * g) / lp.count
        lift_t = max(0.01, math.ceil(lift_t * 10.0) / 10.0)  # up to 0.1 t
        node = int(min(max(round(x / L * n), 0), n)) + 1  # the bag hangs from the nearest node
        bag = {"name": f"{pipe.bag_prefix}{k + 1:0{width}d}", "kind": "external", "node": node,
               "lift_t": lift_t}
        if lp.count > 1:
            bag["count"] = lp.count
        bags.append(bag)
    return bags


def derive(data: dict) -> dict:
    """Fill ``hull`` (and ``lift.bags``, ``lift.breakout_factor``, ``seabed.holding_shape``)
    from ``data["pipe"]``; ``data`` is returned unchanged when the pipe does not validate (the
    scenario's own validation then reports its first error)."""
    if not isinstance(data, dict) or data.get("pipe") is None:
        return data
    try:
        pipe = Pipe.model_validate(data["pipe"])
    except ValidationError:
        return data
    from flexlift.physics.pipe import element_sections, hull_section

    env = data.get("environment") or {}
    if not isinstance(env, dict):
        return data
    g = env.get("gravity_m_s2", C.G)
    rho = env.get("seawater_density_kg_m3", C.RHO_SEAWATER)
    if not all(isinstance(v, int | float) and not isinstance(v, bool) for v in (g, rho)):
        return data
    out = dict(data)
    derived = hull_section(pipe, rho)
    hull = dict(data.get("hull") or {})
    for key, value in derived.items():
        if key in hull and hull[key] != value:
            raise ValueError(f"hull.{key} is derived from the pipe section ({_short(value)}); "
                             "remove it or change the pipe")
    hull.update(derived)
    out["hull"] = hull
    lift = dict(data.get("lift") or {})
    if pipe.breakout_suction_kN_m is not None:
        q = [s.wet_weight(g, rho) for s in element_sections(pipe, rho)]
        wet = sum(q) * pipe.length_m / pipe.elements
        factor = 1.0 + pipe.breakout_suction_kN_m * 1e3 * pipe.length_m / wet
        if "breakout_factor" in lift and lift["breakout_factor"] != factor:
            raise ValueError("lift.breakout_factor is derived from pipe.breakout_suction_kN_m "
                             f"({factor:.4g}); give one of them")
        lift["breakout_factor"] = factor
    if pipe.lift_points is not None:
        bags = _bags(pipe, hull, lift.get("breakout_factor", 1.3), g, rho)
        if lift.get("bags") is not None and _bag_keys(lift["bags"]) != _bag_keys(bags):
            raise ValueError("lift.bags and pipe.lift_points both place the bags; give one")
        lift["bags"] = bags
    out["lift"] = lift
    seabed = dict(data.get("seabed") or {})
    seabed.setdefault("holding_shape", "uniform")  # a uniform line: suction uniform too
    out["seabed"] = seabed
    return out


def underive(data: dict) -> dict:
    """``data`` (a dumped scenario) without what :func:`derive` filled in from its pipe, so
    that a changed pipe key derives them anew (``Scenario.with_changes``)."""
    if not isinstance(data, dict) or data.get("pipe") is None:
        return data
    from flexlift.physics.pipe import hull_section

    pipe = Pipe.model_validate(data["pipe"])
    rho = (data.get("environment") or {}).get("seawater_density_kg_m3", C.RHO_SEAWATER)
    out = dict(data)
    out["hull"] = {k: v for k, v in (data.get("hull") or {}).items()
                   if k not in hull_section(pipe, rho)}
    lift = dict(data.get("lift") or {})
    if pipe.breakout_suction_kN_m is not None:
        lift.pop("breakout_factor", None)
    if pipe.lift_points is not None:
        lift.pop("bags", None)
    out["lift"] = lift
    return out


def _bag_keys(bags) -> list:
    if not isinstance(bags, list) or not all(isinstance(b, dict) for b in bags):
        return [None]
    keys = ("name", "kind", "x_m", "lift_t", "node", "span_m")
    return [tuple(b.get(k) for k in keys) + (b.get("count", 1),) for b in bags]


def _short(value) -> str:
    if isinstance(value, list):
        return f"{len(value)} values"
    return f"{value:.6g}" if isinstance(value, float) else str(value)
