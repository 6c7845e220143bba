"""A pipeline's beam properties from its cross-section (docs/theory/statics.md#pipe-section), all in one place.

A section is a steel tube of outside diameter D and wall thickness t, optionally coated (a
concrete weight coat of thickness t_c) and filled (empty, flooded with seawater, or a
contents density). Per unit length:

- second moment of area I = pi/64 (D^4 - D_i^4), D_i = D - 2 t; EI with the steel's E;
- section modulus Z = I / (D/2), so the bending stress is sigma = M (D/2) / I = M / Z;
- masses: steel rho_s pi/4 (D^2 - D_i^2), coating rho_c pi/4 (D_c^2 - D^2) with
  D_c = D + 2 t_c, contents rho_i pi/4 D_i^2 (all of it moves with the pipe);
- displaced volume V = pi/4 D_c^2 (the coated outline);
- wet weight q = (m - rho_sw V) g [N/m]; equivalently m g (1 - rho_sw / rho_eq) with the
  section's mean density rho_eq = m / V, which is how the hull's wet-weight law
  (:func:`flexlift.physics.hydro.submerged_weight`) takes it.

A scenario's ``pipe`` section (base section, segments, point masses) becomes per-element
arrays with :func:`element_sections`; :func:`hull_section` gives the numbers the ``hull``
section of the scenario is filled with.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexlift.physics.hydro import submerged_weight

#: the fields a segment may override (the section's own keys)
SECTION_KEYS = ("outside_diameter_m", "wall_thickness_m", "steel_density_kg_m3",
                "youngs_modulus_Pa", "smys_MPa", "coating_thickness_m",
                "coating_density_kg_m3", "contents")


@dataclass(frozen=True)
class Section:
    """One pipe cross-section in SI (densities kg/m^3, lengths m, E Pa, SMYS Pa).

    ``contents_density`` 0 means empty (gas at atmospheric pressure, its mass neglected)."""

    D: float
    t: float
    rho_steel: float
    E: float
    smys: float
    t_coat: float = 0.0
    rho_coat: float = 3044.0
    contents_density: float = 0.0

    @property
    def D_inner(self) -> float:
        return self.D - 2.0 * self.t

    @property
    def D_coated(self) -> float:
        return self.D + 2.0 * self.t_coat

    @property
    def I(self) -> float:  # noqa: E743 - the engineer's name
        """Second moment of area of the steel [m^4]."""
        return math.pi / 64.0 * (self.D**4 - self.D_inner**4)

    @property
    def EI(self) -> float:
        return self.E * self.I

    @property
    def Z(self) -> float:
        """Section modulus I / (D/2) [m^3]."""
        return self.I / (self.D / 2.0)

    @property
    def steel_mass(self) -> float:
        return self.rho_steel * math.pi / 4.0 * (self.D**2 - self.D_inner**2)

    @property
    def coating_mass(self) -> float:
        return self.rho_coat * math.pi / 4.0 * (self.D_coated**2 - self.D**2)

    @property
    def contents_mass(self) -> float:
        return self.contents_density * math.pi / 4.0 * self.D_inner**2

    @property
    def mass(self) -> float:
        """Mass per length moving with the pipe: steel, coating and contents [kg/m]."""
        return self.steel_mass + self.coating_mass + self.contents_mass

    @property
    def displaced_volume(self) -> float:
        """pi/4 D_c^2 [m^3/m]."""
        return math.pi / 4.0 * self.D_coated**2

    @property
    def mean_density(self) -> float:
        """m / V [kg/m^3]: the density the wet-weight law takes."""
        return self.mass / self.displaced_volume

    def wet_weight(self, g: float, rho_water: float) -> float:
        """q = (m - rho_sw V) g [N/m], downward positive."""
        return float(submerged_weight(self.mass, g, rho_water, self.mean_density))

    def stress(self, moment):
        """Bending stress sigma = M (D/2) / I [Pa] for a moment M [N m]."""
        return np.asarray(moment, dtype=float) * (self.D / 2.0) / self.I


def contents_density(contents, rho_water: float) -> float:
    """The contents key as a density [kg/m^3]: ``"empty"`` 0, ``"flooded"`` seawater, else the
    number given."""
    if contents == "empty":
        return 0.0
    if contents == "flooded":
        return float(rho_water)
    return float(contents)


def section_of(spec, rho_water: float) -> Section:
    """The SI :class:`Section` of a scenario section (``pipe`` or a merged segment)."""
    return Section(
        D=spec["outside_diameter_m"], t=spec["wall_thickness_m"],
        rho_steel=spec["steel_density_kg_m3"], E=spec["youngs_modulus_Pa"],
        smys=spec["smys_MPa"] * 1e6, t_coat=spec["coating_thickness_m"],
        rho_coat=spec["coating_density_kg_m3"],
        contents_density=contents_density(spec["contents"], rho_water))


def sections_along(pipe, rho_water: float) -> tuple[list[Section], list[tuple[float, float]]]:
    """The distinct sections of a scenario ``pipe`` and the span [m] each covers: the base
    section everywhere, each segment (in order; later ones win) over its ``[from_m, to_m]``."""
    base = {k: getattr(pipe, k) for k in SECTION_KEYS}
    out = [(section_of(base, rho_water), (0.0, pipe.length_m))]
    for seg in pipe.segments:
        merged = dict(base)
        merged.update({k: getattr(seg, k) for k in SECTION_KEYS if getattr(seg, k) is not None})
        out.append((section_of(merged, rho_water), (seg.from_m, seg.to_m)))
    return [s for s, _ in out], [span for _, span in out]


def element_sections(pipe, rho_water: float, elements: int | None = None) -> list[Section]:
    """The section of each of ``elements`` (default ``pipe.elements``) equal elements, taken at
    the element's centre."""
    n = int(elements or pipe.elements)
    secs, spans = sections_along(pipe, rho_water)
    xc = (np.arange(n) + 0.5) * pipe.length_m / n
    idx = np.zeros(n, dtype=int)
    for k, (a, b) in enumerate(spans[1:], start=1):
        idx[(xc >= a) & (xc <= b)] = k
    return [secs[i] for i in idx]


def _one_or_list(values: list[float]):
    return values[0] if len(set(values)) == 1 else values


def hull_section(pipe, rho_water: float) -> dict:
    """The ``hull`` keys a ``pipe`` defines (mass, EI, Z per element or one value; the coated
    diameter as breadth and depth; point masses on the nearest node)."""
    el = element_sections(pipe, rho_water)
    n, L = pipe.elements, pipe.length_m
    points: dict[int, float] = {}
    for p in pipe.point_masses:
        node = int(np.clip(round(p.x_m / L * n), 0, n)) + 1
        points[node] = points.get(node, 0.0) + p.mass_t
    Dc = max(s.D_coated for s in el)
    smys = min(s.smys for s in el)
    allow = pipe.allowable_stress_MPa or ALLOWABLE_FRACTION * smys / 1e6
    return {
        "length_m": L, "length_between_perpendiculars_m": None, "elements": n,
        "breadth_m": Dc, "depth_m": Dc, "displacement_t": None,
        "mass_per_length_kg_m": _one_or_list([s.mass for s in el]),
        "bending_stiffness_Nm2": _one_or_list([s.EI for s in el]),
        "section_modulus_m3": _one_or_list([s.Z for s in el]),
        "point_masses": [{"node": k, "mass_t": m} for k, m in sorted(points.items())],
        "allowable_stress_MPa": allow,
    }


#: default allowable bending stress as a fraction of SMYS (see the README's Pipelines section)
ALLOWABLE_FRACTION = 0.72


def element_density(pipe, rho_water: float, elements: int | None = None) -> np.ndarray:
    """Mean density m / V of each element [kg/m^3] (for the wet weight)."""
    return np.array([s.mean_density for s in element_sections(pipe, rho_water, elements)])
