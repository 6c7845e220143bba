"""The true value of every sensor, from the compiled loop's own records
(docs/reference/sensor-log.md#truth).

One function, :func:`true_values`, reads the rows the loop recorded (:class:`flexlift.ascent.
state.Record`: per bag the variables of :data:`flexlift.ascent.result.BAG_VARS`, per row the
hull's of :data:`~flexlift.ascent.result.HULL_VARS`) and the plant's bag record (its water
depth, pressures); the pressures come from the plant's own law
(:func:`flexlift.physics.gas.ambient_pressure`), the free air from
:func:`flexlift.physics.gas.free_air`. Nothing of the plant is computed twice.
"""

from __future__ import annotations

import numpy as np

from flexlift.ascent.result import BAG_VARS, HULL_VARS
from flexlift.physics.gas import ambient_pressure, free_air
from flexlift.sensors.config import HULL, Sensor

_BAG = {name: j for j, name in enumerate(BAG_VARS)}
_HULL = {name: j for j, name in enumerate(HULL_VARS)}
#: the supply's drive over the bag's pressure at its fill hose while it works [Pa]: the
#: sensor's assumption (the plant models the fill as a commanded flow, not a pressure)
SUPPLY_DRIVE_PA = 1.0e5


def true_values(sensors: list[Sensor], names, column, bags, recorder, r0: int, r1: int,
                supply) -> np.ndarray:
    """The true value of every sensor at the recorded rows ``r0 .. r1 - 1``.

    Parameters
    ----------
    sensors : list of Sensor
    names : sequence of str
        The plant's bag names.
    column : (nb,) int array
        The record's column of each of the plant's bags (the loop bag it is a member of,
        :attr:`flexlift.ascent.clusters.Clusters.of_bag`; the identity once a run ends).
    bags : flexlift.ascent.records.Bags
        The plant's (or the loop's) bag record: ``water_depth`` [m], ``p_atm`` [Pa],
        ``rho_g`` [N/m^3].
    recorder : flexlift.ascent.state.Record
    r0, r1 : int
        The rows.
    supply : (nl,) array
        ``switches.supply`` of the loop bags during those rows (1 working, 0 lost).

    Returns
    -------
    (rows, sensors) array
        SI values, in the order of ``sensors``: ``depth`` [m] from the gauge's pressure
        ``(p - p_atm) / (rho g)``, ``pitch`` [rad], ``sling_force`` [N], ``fill_flow``
        [m^3/s free air], ``purge`` [-], ``supply_pressure`` [Pa] (the bag's pressure plus
        :data:`SUPPLY_DRIVE_PA` while its supply works, atmospheric once lost).
    """
    index = {name: k for k, name in enumerate(names)}
    rows = recorder.bag[r0:r1]
    hull = recorder.hull[r0:r1]
    out = np.empty((r1 - r0, len(sensors)))
    for k, s in enumerate(sensors):
        if s.bag == HULL:
            if s.quantity == "pitch":
                out[:, k] = hull[:, _HULL["pitch"]]
            else:  # depth of the hull's centre of mass
                p = ambient_pressure(hull[:, _HULL["heave"]], bags.water_depth, bags.p_atm,
                                     bags.rho_g)
                out[:, k] = (p - bags.p_atm) / bags.rho_g
            continue
        j = int(column[index[s.bag]])
        row = rows[:, :, j]
        p = ambient_pressure(row[:, _BAG["height"]], bags.water_depth, bags.p_atm, bags.rho_g)
        if s.quantity == "depth":
            out[:, k] = (p - bags.p_atm) / bags.rho_g
        elif s.quantity == "pitch":
            out[:, k] = row[:, _BAG["pitch_angle"]]
        elif s.quantity == "sling_force":
            out[:, k] = row[:, _BAG["sling_force"]]
        elif s.quantity == "fill_flow":
            out[:, k] = free_air(row[:, _BAG["fill_rate"]], p, bags.p_atm)
        elif s.quantity == "purge":
            out[:, k] = row[:, _BAG["purge_opening"]]
        else:  # supply_pressure
            out[:, k] = bags.p_atm if supply[j] == 0 else p + SUPPLY_DRIVE_PA
    return out
