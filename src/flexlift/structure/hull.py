"""The structure's description in SI: length, per-element stiffness and mass, point masses.

:class:`Hull` is plain immutable data. Build it from a scenario with :func:`hull_from_scenario`
or directly (``Hull.uniform(...)``); change the mesh with :meth:`Hull.refined`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from flexlift import constants as C
from flexlift.errors import InputError
from flexlift.physics.hydro import submerged_weight


@dataclass(frozen=True)
class Hull:
    """A free-free beam of ``n`` equal elements.

    length : float — beam length L, aft end at x = 0 [m]
    EI : ndarray (n,) — bending stiffness of each element [N m^2]
    mass_per_length : ndarray (n,) — structural mass per unit length of each element [kg/m]
    point_masses : ndarray (n+1,) — lumped mass at each node [kg]
    breadth : float — breadth B, for drag and added mass [m]
    depth : float — depth D [m]
    density : ndarray (n,) or None — each element's mean density, mass / displaced volume
        [kg/m^3], for its wet weight; None: the whole mass is steel (the environment's steel
        density). A pipe's comes from its section (:mod:`flexlift.physics.pipe`).
    """

    length: float
    EI: np.ndarray
    mass_per_length: np.ndarray
    point_masses: np.ndarray = field(default=None)  # type: ignore[assignment]
    breadth: float = 12.0
    depth: float = 5.4
    density: np.ndarray | None = None

    def __post_init__(self):
        EI = np.atleast_1d(np.asarray(self.EI, dtype=float))
        m = np.atleast_1d(np.asarray(self.mass_per_length, dtype=float))
        if not np.isfinite(self.length) or self.length <= 0:
            raise InputError("hull.length_m", self.length, "must be a positive length [m]")
        if EI.size != m.size:
            raise InputError(
                "hull", f"{EI.size} EI values, {m.size} masses", "need one of each per element"
            )
        if EI.size < 1:
            raise InputError("hull.elements", EI.size, "need at least one element")
        if not np.all(np.isfinite(EI)) or np.any(EI <= 0):
            raise InputError("hull.bending_stiffness_Nm2", EI.min(), "must be positive [N m^2]")
        if not np.all(np.isfinite(m)) or np.any(m <= 0):
            raise InputError("hull.mass_per_length_kg_m", m.min(), "must be positive [kg/m]")
        pm = self.point_masses
        pm = np.zeros(EI.size + 1) if pm is None else np.asarray(pm, dtype=float)
        if pm.shape != (EI.size + 1,) or np.any(pm < 0):
            raise InputError("hull.point_masses", pm.tolist(), "one non-negative mass per node [kg]")
        object.__setattr__(self, "EI", EI)
        object.__setattr__(self, "mass_per_length", m)
        object.__setattr__(self, "point_masses", pm)
        if self.density is not None:
            rho = np.broadcast_to(np.asarray(self.density, dtype=float), EI.shape).copy()
            if not np.all(np.isfinite(rho)) or np.any(rho <= 0):
                raise InputError("hull density", rho.min(), "must be positive [kg/m^3]")
            object.__setattr__(self, "density", rho)

    # ------------------------------------------------------------------ constructors
    @classmethod
    def uniform(
        cls, length: float, EI: float, mass_per_length: float, elements: int, **kw
    ) -> Hull:
        """A uniform beam: ``elements`` equal elements of constant EI [N m^2] and mass [kg/m]."""
        if int(elements) < 1:
            raise InputError("hull.elements", elements, "need at least one element")
        n = int(elements)
        return cls(length, np.full(n, float(EI)), np.full(n, float(mass_per_length)), **kw)

    # ------------------------------------------------------------------ geometry
    @property
    def n_elements(self) -> int:
        return self.EI.size

    @property
    def n_nodes(self) -> int:
        return self.EI.size + 1

    @property
    def element_length(self) -> float:
        """Length of each (equal) element [m]."""
        return self.length / self.n_elements

    @property
    def x_nodes(self) -> np.ndarray:
        """Node positions from the aft end [m]."""
        return np.linspace(0.0, self.length, self.n_nodes)

    @property
    def total_mass(self) -> float:
        """Structural mass including point masses [kg]."""
        return float(np.sum(self.mass_per_length) * self.element_length + self.point_masses.sum())

    def element_of(self, x) -> np.ndarray:
        """0-based element holding each position ``x`` [m] (the last for x = L)."""
        e = np.floor(np.asarray(x, dtype=float) / self.element_length).astype(int)
        return np.clip(e, 0, self.n_elements - 1)

    def nearest_node(self, x: float) -> int:
        """0-based index of the node nearest to position ``x`` [m]."""
        return int(np.clip(np.rint(x / self.element_length), 0, self.n_elements))

    # ------------------------------------------------------------------ wet weight
    def wet_weight_per_length(self, g: float, rho_water: float, rho_steel: float) -> np.ndarray:
        """Submerged weight of each element per length [N/m], downward positive: the hull's
        mass less the buoyancy of its own volume (steel unless ``density`` says otherwise)."""
        rho = rho_steel if self.density is None else self.density
        return submerged_weight(self.mass_per_length, g, rho_water, rho)

    def point_wet_weights(self, g: float, rho_water: float, rho_steel: float) -> np.ndarray:
        """Submerged weight of the point masses [N] (treated as steel)."""
        return submerged_weight(self.point_masses, g, rho_water, rho_steel)

    def total_wet_weight(self, g: float, rho_water: float, rho_steel: float) -> float:
        """W' of the whole structure with its point masses [N]."""
        q = self.wet_weight_per_length(g, rho_water, rho_steel)
        return float(np.sum(q) * self.element_length
                     + np.sum(self.point_wet_weights(g, rho_water, rho_steel)))

    # ------------------------------------------------------------------ derived copies
    def refined(self, elements: int) -> Hull:
        """The same beam on ``elements`` equal elements (properties sampled at element centres;
        point masses moved to the nearest new node)."""
        if int(elements) < 1:
            raise InputError("elements", elements, "need at least one element")
        n = int(elements)
        xc = (np.arange(n) + 0.5) * self.length / n
        idx = np.minimum((xc / self.element_length).astype(int), self.n_elements - 1)
        pm = np.zeros(n + 1)
        for x, mass in zip(self.x_nodes, self.point_masses):
            if mass:
                pm[int(np.clip(np.rint(x / (self.length / n)), 0, n))] += mass
        rho = None if self.density is None else self.density[idx]
        return replace(self, EI=self.EI[idx], mass_per_length=self.mass_per_length[idx],
                       point_masses=pm, density=rho)

    def mirrored(self) -> Hull:
        """The beam turned end for end (bow becomes stern)."""
        return replace(
            self,
            EI=self.EI[::-1].copy(),
            mass_per_length=self.mass_per_length[::-1].copy(),
            point_masses=self.point_masses[::-1].copy(),
            density=None if self.density is None else self.density[::-1].copy(),
        )


def hull_from_scenario(scenario, elements: int | None = None) -> Hull:
    """The SI :class:`Hull` of a :class:`~flexlift.scenario.Scenario` (optionally re-meshed)."""
    h = scenario.hull
    n = h.elements
    if h.displacement_t is not None:
        m = np.full(n, h.displacement_t * C.TONNE / h.length_m)
    else:
        m = np.broadcast_to(np.asarray(h.mass_per_length_kg_m, dtype=float), (n,)).copy()
    EI = np.broadcast_to(np.asarray(h.bending_stiffness_Nm2, dtype=float), (n,)).copy()
    pm = np.zeros(n + 1)
    for p in h.point_masses:
        pm[p.node_on(h.length_m, n) - 1] += p.mass_t * C.TONNE
    rho = None
    if getattr(scenario, "pipe", None) is not None:
        from flexlift.physics.pipe import element_density

        rho = element_density(scenario.pipe, scenario.environment.seawater_density_kg_m3)
    elif h.submerged_weight_t is not None:
        rho = _density_for(h.submerged_weight_t * C.TONNE, m, pm, h.length_m / n,
                           scenario.environment)
    hull = Hull(h.length_m, EI, m, pm, breadth=h.breadth_m, depth=h.depth_m, density=rho)
    if elements is not None and int(elements) != n:
        hull = hull.refined(int(elements))
    return hull


def _density_for(submerged_mass: float, m: np.ndarray, pm: np.ndarray, dx: float, env) -> float:
    """The one mean density of the distributed mass [kg/m^3] that gives the submerged weight
    ``submerged_mass`` g [kg] given directly (the point masses stay steel): from
    M_d (1 - rho_w / rho) = W'/g - (point masses' own submerged mass)."""
    rho_w, rho_s = env.seawater_density_kg_m3, env.steel_density_kg_m3
    distributed = float(np.sum(m) * dx)
    wet_distributed = submerged_mass - float(np.sum(pm)) * (1.0 - rho_w / rho_s)
    if not 0.0 < wet_distributed < distributed:
        raise InputError("hull.submerged_weight_t", submerged_mass / C.TONNE,
                         "more than the point masses' own submerged weight and less than the "
                         "distributed mass [t]")
    return rho_w / (1.0 - wet_distributed / distributed)
