"""Lift-bag gas: ideal, isothermal gas in open (parachute) and closed (cylindrical) bags (SPEC §5).

Every bag's state is its amount of gas n [mol]. At the local ambient pressure
p = p_atm + rho g d (d the depth of the bag's point [m]) the gas occupies V = n R T / p [m^3],
bounded by the bag's capacity V_max = lift / (rho g):

- parachute (external, open-bottom) bags spill any gas beyond V_max at once;
- cylindrical (internal, closed) bags stay at V_max while the gas pressure n R T / V_max rises
  above ambient, up to the relief setting; the relief valve vents the rest at once.

Flows are volumes per second at the bag's local pressure: fill Q_in [m^3/s] and purge
Q_out = u_v Q_out,max sqrt(V / V_max) [m^3/s]. All functions are vectorised over bags.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexlift import constants as C


@dataclass(frozen=True)
class GasModel:
    """Constants of the gas model, SI.

    temperature : sea temperature, gas isothermal at it [K]
    p_atm : atmospheric pressure at the surface [Pa]
    rho : seawater density [kg/m^3]
    g : gravitational acceleration [m/s^2]
    water_depth : depth of the seabed below the surface [m]
    relief : over-pressure relief setting of the closed bags [Pa]
    fill_max : largest fill rate at local pressure [m^3/s]
    purge_max : purge rate at local pressure, valve fully open, bag full [m^3/s]
    """

    temperature: float = C.T_SEA
    p_atm: float = C.P_ATM
    rho: float = C.RHO_SEAWATER
    g: float = C.G
    water_depth: float = 350.0
    relief: float = 0.1 * C.BAR
    fill_max: float = 0.5
    purge_max: float = 2.0

    @property
    def RT(self) -> float:
        """Molar gas constant times temperature [J/mol]."""
        return C.R_GAS * self.temperature

    def pressure(self, height):
        """Ambient pressure at ``height`` above the seabed [m] -> [Pa] (clipped at the surface)."""
        depth = np.maximum(self.water_depth - np.asarray(height, dtype=float), 0.0)
        return self.p_atm + self.rho * self.g * depth

    def moles(self, volume, pressure):
        """Amount of gas occupying ``volume`` [m^3] at ``pressure`` [Pa] -> [mol]."""
        return np.asarray(volume) * np.asarray(pressure) / self.RT

    def volume(self, n, pressure, capacity):
        """Gas volume [m^3] of ``n`` [mol] at ambient ``pressure`` [Pa], bounded by
        ``capacity`` [m^3] (gas beyond it is spilled or held under over-pressure)."""
        return np.minimum(n * self.RT / pressure, capacity)

    def max_moles(self, pressure, capacity, closed):
        """Most gas a bag can hold [mol]: capacity at ambient pressure (open bags) or at
        ambient plus the relief setting (closed bags, ``closed`` a bool array)."""
        return (pressure + np.where(closed, self.relief, 0.0)) * capacity / self.RT

    def purge_flow(self, opening, volume, capacity):
        """Purge outflow at local pressure [m^3/s] for a valve ``opening`` in [0, 1]:
        orifice flow driven by the gas column, u_v Q_out,max sqrt(V / V_max)."""
        frac = np.clip(volume / capacity, 0.0, 1.0)
        return np.clip(opening, 0.0, 1.0) * self.purge_max * np.sqrt(frac)

    def dn_dt(self, pressure, fill, purge):
        """Rate of change of the amount of gas [mol/s] from fill and purge flows at local
        pressure [m^3/s]."""
        return pressure * (fill - purge) / self.RT

    def free_air(self, volume_at_local, pressure):
        """Volume at local ``pressure`` [Pa] expressed as free air at the surface [m^3]."""
        return np.asarray(volume_at_local) * np.asarray(pressure) / self.p_atm


def spill(model: GasModel, n, pressure, capacity, closed):
    """Apply instant spill (open bags) and relief venting (closed bags).

    Returns (n_kept [mol], n_vented [mol]), both arrays like ``n``.
    """
    n_max = model.max_moles(pressure, capacity, closed)
    kept = np.minimum(n, n_max)
    return kept, n - kept


def gas_model_from_scenario(scenario) -> GasModel:
    """The :class:`GasModel` of a scenario (bar converted to Pa)."""
    env, gas = scenario.environment, scenario.gas
    return GasModel(
        temperature=env.sea_temperature_K,
        p_atm=env.atmospheric_pressure_Pa,
        rho=env.seawater_density_kg_m3,
        g=env.gravity_m_s2,
        water_depth=env.water_depth_m,
        relief=gas.relief_pressure_bar * C.BAR,
        fill_max=gas.fill_rate_max_m3_s,
        purge_max=gas.purge_rate_max_m3_s,
    )
