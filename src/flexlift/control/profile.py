"""The planned ascent that respects the purge valves (docs/theory/gas.md#purge-capacity).

A bag of gas volume V at pressure p rising at speed v expands at V rho g v / p (Boyle); the
purge can take off at most Q_out,max sqrt(V / V_max) of it. Where the planned speed would need
more, it cannot be held by purging and the ascent runs away, so the plan slows below

    v_max(z) = eta Q_out,max sqrt(V / V_max) p(z) / (rho g V)

(``control.purge_margin`` eta < 1) for the tightest external bag, V its neutral (working)
volume. The fastest profile under that limit, the planned speed and the acceleration limit
(up and down) is a forward-backward pass over the height; it is sampled in time for the
compiled controller. When the limit never binds (the tanker from 350 m to 50 m depth) the plain
trapezoid of :mod:`flexlift.control.reference` is used unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexlift._jit import jit
from flexlift.physics.gas import ambient_pressure, expansion_rate, purge_flow

#: height samples of the forward-backward pass and time samples of the table
HEIGHTS, TIMES = 4001, 4001


@dataclass(frozen=True)
class Profile:
    """A planned ascent from the seabed (0) to ``target`` [m]: ``z``, ``v`` [m, m/s] evenly
    over [0, ``duration``] [s]; ``limit_from`` [m] is the height above which the valves'
    limit binds (None: it never does)."""

    duration: float
    z: np.ndarray
    v: np.ndarray
    limit_from: float | None


def speed_limit(z, volume, capacity, purge_max, eta, water_depth, p_atm, rho_g):
    """v_max(z) [m/s] of a bag with gas volume ``volume`` [m^3] (of ``capacity``) at heights
    ``z`` [m]: the speed at which its expansion takes ``eta`` of the purge capacity."""
    p = ambient_pressure(np.asarray(z, dtype=float), water_depth, p_atm, rho_g)
    q = eta * purge_flow(1.0, volume, capacity, purge_max)
    return q / expansion_rate(volume, p, rho_g, 1.0)


@jit
def _passes(v, step):
    """The forward (accelerating from rest) and backward (decelerating to rest) passes over
    the speed caps ``v`` [m/s] (an array, changed in place), ``step`` = 2 a dz [m^2/s^2],
    compiled: each speed sqrt(v_prev^2 + step) with the square the correctly rounded product
    (libm's pow, which the interpreted passes used, is one unit in the last place off in
    about 3 of 10,000 squares) and the correctly rounded sqrt."""
    n = v.size
    _pass(v, step, 0, n, 1)  # accelerating from rest
    _pass(v, step, n - 1, -1, -1)  # decelerating to rest at the target
    return v


@jit
def _pass(v, step, first, stop, by):
    """One pass of :func:`_passes` from rest at ``v[first]`` over ``range(first, stop, by)``:
    each speed capped at sqrt(v_previous^2 + step)."""
    v[first] = prev = 0.0
    for i in range(first + by, stop, by):
        s = math.sqrt(prev * prev + step)
        if s < v[i]:
            v[i] = s
        prev = v[i]


def valve_profile(target, speed, accel, volume, capacity, purge_max, eta, water_depth, p_atm,
                  rho_g) -> Profile | None:
    """The fastest ascent to ``target`` [m] within ``speed`` [m/s], ``accel`` [m/s^2] and
    the tightest bag's :func:`speed_limit` (``volume`` [m^3], ``capacity``, ``purge_max``:
    arrays over the bags, ``purge_max`` each bag's dump valve); None when the limit never
    binds."""
    z = np.linspace(0.0, target, HEIGHTS)
    V = np.atleast_1d(volume)
    q = np.broadcast_to(np.asarray(purge_max, dtype=float), V.shape)
    lim = np.min([speed_limit(z, v, c, qi, eta, water_depth, p_atm, rho_g)
                  for v, c, qi in zip(V, np.atleast_1d(capacity), q)], axis=0)
    if np.all(lim >= speed):
        return None
    cap = np.minimum(lim, speed)
    dz = z[1] - z[0]
    v = _passes(np.array(cap, dtype=float), float(2.0 * accel * dz))
    tau = np.concatenate([[0.0], np.cumsum(2.0 * dz / np.maximum(v[1:] + v[:-1], 1e-12))])
    t = np.linspace(0.0, tau[-1], TIMES)
    binding = z[lim < speed]
    return Profile(float(tau[-1]), np.interp(t, tau, z), np.interp(t, tau, v),
                   float(binding.min()) if binding.size else None)
