"""Hydrodynamics of the hull and bags: strip-theory drag and added mass (SPEC §6).

- Added mass per unit length a_33 = C_a rho pi B^2 / 4, plus water entrained in flooded
  compartments spread uniformly along the hull. It enters the simulation's mass matrix (wet
  modes).
- Hull drag per unit length f_D = -1/2 rho C_D B |v| v on the local vertical velocity v
  relative to the water (a vertical current c makes v = w' - c).
- Bag drag -1/2 rho C_D,bag A |v| v at an external bag's point. The frontal area A is that of
  a sphere holding the bag's capacity (a parachute bag opens to roughly that shape); the
  internal bags sit inside the hull and add no drag. The bags' own mass and added mass are
  neglected against the hull's.
"""

from __future__ import annotations

import numpy as np


def added_mass_per_length(breadth: float, rho: float, ca: float = 1.0) -> float:
    """a_33 = C_a rho pi B^2 / 4 [kg/m] for breadth B [m], water density rho [kg/m^3]."""
    return ca * rho * np.pi * breadth**2 / 4.0


def drag_load(v, coeff):
    """Quadratic drag -coeff |v| v, with ``coeff`` = 1/2 rho C_D B [kg/m^2] (line load, v in
    m/s -> N/m) or 1/2 rho C_D A [kg/m] (point force -> N)."""
    v = np.asarray(v, dtype=float)
    return -coeff * np.abs(v) * v


def sphere_frontal_area(volume) -> np.ndarray:
    """Frontal area [m^2] of a sphere of ``volume`` [m^3]."""
    d = (6.0 * np.asarray(volume, dtype=float) / np.pi) ** (1.0 / 3.0)
    return np.pi * d**2 / 4.0


def sphere_diameter(volume) -> np.ndarray:
    """Diameter [m] of a sphere of ``volume`` [m^3]."""
    return (6.0 * np.asarray(volume, dtype=float) / np.pi) ** (1.0 / 3.0)
