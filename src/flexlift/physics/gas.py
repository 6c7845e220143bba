"""Lift-bag gas: an ideal gas, isothermal at sea temperature (docs/theory/gas.md#boyle).

A bag's state is its amount of gas n [mol]. At its point, ``height`` above the seabed [m] in
water ``water_depth`` deep, the ambient pressure is p = p_atm + rho g (depth - height) [Pa]
(clipped at the surface). The gas occupies V = n R T / p [m^3], at most the bag's capacity
V_max = lift / (rho g). Open (parachute) bags spill gas beyond V_max at once; closed
(cylindrical) bags hold it under over-pressure up to their relief setting, then vent.

Flows are volumes per second at the bag's local pressure [m^3/s]. Every law is compiled and
takes floats or NumPy arrays (element by element, broadcasting); ``RT`` is R T [J/mol] and
``rho_g`` is rho g [N/m^3] (seawater density times gravity).
"""

from __future__ import annotations

import numpy as np

from flexlift import constants as C
from flexlift._jit import inline_jit, jit


def molar_energy(temperature: float = C.T_SEA) -> float:
    """R T [J/mol] of the gas at ``temperature`` [K]."""
    return C.R_GAS * temperature


@inline_jit
def ambient_pressure(height, water_depth, p_atm, rho_g):
    """Pressure at ``height`` [m] above a seabed ``water_depth`` [m] deep [Pa]: p_atm [Pa] plus
    the water column rho_g (depth - height), no column above the surface."""
    return p_atm + rho_g * np.maximum(water_depth - height, 0.0)


@inline_jit
def gas_volume(n, pressure, RT, capacity):
    """Volume [m^3] of ``n`` [mol] of gas at ambient ``pressure`` [Pa] (Boyle), at most the
    bag's ``capacity`` [m^3]: gas beyond it is spilled (open bag) or compressed (closed)."""
    return np.minimum(n * RT / pressure, capacity)


@inline_jit
def moles_of(volume, pressure, RT):
    """Amount of gas [mol] that occupies ``volume`` [m^3] at ``pressure`` [Pa]."""
    return volume * pressure / RT


@jit
def moles_capacity(pressure, capacity, relief, RT):
    """Most gas a bag holds [mol]: its ``capacity`` [m^3] at the ambient ``pressure`` [Pa]
    plus its ``relief`` over-pressure [Pa] (0 for an open bag)."""
    return (pressure + relief) * capacity / RT


@inline_jit
def vented_moles(n, pressure, capacity, relief, RT):
    """Gas an open bag spills or a closed bag's relief valve vents at once [mol]: what ``n``
    [mol] holds beyond :func:`moles_capacity` (0 when within it)."""
    return np.maximum(n - (pressure + relief) * capacity / RT, 0.0)


@inline_jit
def purge_flow(opening, volume, capacity, purge_max):
    """Purge outflow at local pressure [m^3/s] of a valve ``opening`` in [0, 1]: orifice flow
    driven by the gas column, u_v Q_out,max sqrt(V / V_max) (``purge_max`` Q_out,max
    [m^3/s], ``volume`` and ``capacity`` [m^3])."""
    frac = np.minimum(np.maximum(volume / capacity, 0.0), 1.0)
    return np.minimum(np.maximum(opening, 0.0), 1.0) * purge_max * np.sqrt(frac)


@inline_jit
def moles_rate(pressure, fill, purge, RT):
    """Rate of change of a bag's gas [mol/s] from the fill and purge flows [m^3/s] at the
    local ``pressure`` [Pa]: p (Q_in - Q_out) / (R T)."""
    return pressure * (fill - purge) / RT


@inline_jit
def buoyancy(volume, rho_g):
    """Lift of a gas ``volume`` [m^3]: the weight of the water it displaces, rho g V [N]."""
    return rho_g * volume


@inline_jit
def free_air(volume, pressure, p_atm):
    """A gas ``volume`` [m^3] at ``pressure`` [Pa] as free air at the surface [m^3]."""
    return volume * pressure / p_atm


@jit
def expansion_rate(volume, pressure, rho_g, speed):
    """Growth of a bag's gas volume [m^3/s] as it rises at ``speed`` [m/s] (Boyle at constant
    n): dV/dt = V rho g v / p, for ``volume`` [m^3] at ``pressure`` [Pa]."""
    return volume * rho_g * speed / pressure
