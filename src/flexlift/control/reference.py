"""The planned ascent (docs/theory/control.md#reference): a trapezoidal velocity profile from the separation height to
the target, accelerating gently to the ascent speed, cruising, decelerating to a stop."""

from __future__ import annotations

import math

from flexlift._jit import inline_jit


@inline_jit
def trapezoid(tau, distance, speed, accel):
    """(position [m], velocity [m/s]) at ``tau`` [s] after the start of a move of
    ``distance`` [m] (signed) at most ``speed`` [m/s], accelerating and decelerating at
    ``accel`` [m/s^2]; before the start (tau < 0) it is at 0 and at rest."""
    D = abs(distance)
    sgn = 1.0 if distance >= 0.0 else -1.0
    if D == 0.0:
        return 0.0, 0.0
    vp = min(speed, math.sqrt(D * accel))  # peak speed (a triangle for short moves)
    ta = vp / accel  # time to accelerate
    tc = (D - vp * ta) / vp  # time cruising
    tau = max(tau, 0.0)
    if tau < ta:
        return sgn * 0.5 * accel * tau * tau, sgn * accel * tau
    if tau < ta + tc:
        return sgn * vp * (tau - 0.5 * ta), sgn * vp
    r = max(2.0 * ta + tc - tau, 0.0)
    return sgn * (D - 0.5 * accel * r * r), sgn * accel * r
