"""Hydrodynamics of the hull and its bags: quadratic drag and added mass (docs/theory/hydrodynamics.md).

- Drag: -1/2 rho C_D B |v| v per unit length of hull (strip theory on the breadth B), and
  -1/2 rho C_D,bag A |v| v at an external bag's point (A the frontal area of a sphere of the
  bag's capacity: a parachute bag opens to roughly that shape; internal bags are inside the
  hull and add none). v is the velocity relative to the water (a vertical current c makes it
  w' - c).
- Submerged weight: the structure's weight less the buoyancy of its own steel,
  m g (1 - rho_w / rho_s) (docs/theory/hydrodynamics.md#submerged-weight: the whole displacement is treated as steel).
- Added mass per unit length a_33 = C_a rho pi B^2 / 4, plus water entrained in flooded
  compartments; it enters the simulation's mass matrix. The bags' own mass and added mass
  are neglected against the hull's.
"""

from __future__ import annotations

import math

import numpy as np

from flexlift._jit import inline_jit, jit


@inline_jit
def drag(v, coeff):
    """Quadratic drag -coeff |v| v: a line load [N/m] for ``coeff`` = 1/2 rho C_D B [kg/m^2],
    a force [N] for ``coeff`` = 1/2 rho C_D A [kg/m]; ``v`` relative velocity [m/s]."""
    return -coeff * np.abs(v) * v


@jit
def submerged_weight(mass, g, rho_water, rho_structure):
    """Weight in water of a steel ``mass`` [kg] (or mass per length [kg/m]): its weight less the
    buoyancy of the steel's own volume, m g (1 - rho_w / rho_s) [N] (or [N/m]), downward
    positive; ``g`` [m/s^2], densities [kg/m^3]."""
    return mass * g * (1.0 - rho_water / rho_structure)


def drag_coefficient(rho: float, cd: float, width_or_area: float) -> float:
    """The ``coeff`` of :func:`drag`: 1/2 rho C_D B for a breadth B [m] (strip, kg/m^2) or
    1/2 rho C_D A for an area A [m^2] (point, kg/m); ``rho`` [kg/m^3], ``cd`` [-]."""
    return 0.5 * rho * cd * width_or_area


def added_mass_per_length(breadth: float, rho: float, ca: float = 1.0) -> float:
    """a_33 = C_a rho pi B^2 / 4 [kg/m] for breadth B [m] and water density rho [kg/m^3]."""
    return ca * rho * math.pi * breadth**2 / 4.0


def moving_water_per_length(breadth: float, rho: float, ca: float, entrained: float,
                            length: float) -> float:
    """The water that accelerates with the hull, per length [kg/m]: the added mass
    :func:`added_mass_per_length` (breadth B [m], rho [kg/m^3], C_a [-]) plus the
    ``entrained`` water of flooded compartments [kg] spread over the ``length`` [m]. With the
    structure's own mass it is the mass the ascent integrates and the statics relieve."""
    return added_mass_per_length(breadth, rho, ca) + entrained / length


def sphere_diameter(volume):
    """Diameter [m] of a sphere of ``volume`` [m^3]."""
    return (6.0 * np.asarray(volume, dtype=float) / math.pi) ** (1.0 / 3.0)


def sphere_frontal_area(volume):
    """Frontal area [m^2] of a sphere of ``volume`` [m^3]."""
    return math.pi * sphere_diameter(volume) ** 2 / 4.0
