"""A lift bag at the surface (docs/theory/gas.md#surface): the gas above the waterline lifts
nothing.

A bag's gas gathers at the top of its body: in an upright bag (a parachute bag, mouth down) a
column from the crown down, in a lying cylinder (an enclosed bag) a segment from the top down.
Once the bag's top stands ``freeboard`` f [m] above the surface, the part of its gas within f
of the top is above the waterline: the water it displaces, and so its lift, is only the rest,
V_w = max(V - V_top(f), 0), with V_top(y) the body's volume within y of its top. A body is

- upright: a vertical cylinder of diameter D, its top ``cone`` [m] a cone (0: a flat top),
  V_top(y) = A y^3 / (3 c^2) for y <= c, A c / 3 + A (y - c) beyond (A = pi D^2 / 4);
- lying: a horizontal cylinder of diameter D and length L, V_top(y) = L times the circular
  segment of height y, R^2 acos((R - y) / R) - (R - y) sqrt(2 R y - y^2) (R = D / 2), the
  whole section beyond y = D.

Every law is compiled and takes floats (lengths [m], volumes [m^3]).
"""

from __future__ import annotations

import math

from flexlift._jit import jit


@jit
def volume_from_top(y, diameter, length, cone, upright):
    """Volume [m^3] of a bag's body within ``y`` [m] of its top (module docstring): upright
    (a vertical cylinder of ``diameter`` [m] with a ``cone`` [m] high conical top; its
    ``length`` is not a bound: a body holds its true capacity) or lying (a horizontal cylinder
    of ``diameter`` and ``length`` [m])."""
    if y <= 0.0:
        return 0.0
    r = 0.5 * diameter
    if upright:
        area = math.pi * r * r
        if cone > 0.0 and y <= cone:
            return area * y * y * y / (3.0 * cone * cone)
        c = max(cone, 0.0)
        return area * c / 3.0 + area * (y - c)
    if y >= diameter:
        return math.pi * r * r * length
    h = r - y
    return length * (r * r * math.acos(h / r) - h * math.sqrt(max(2.0 * r * y - y * y, 0.0)))


@jit
def waterline_volume(volume, freeboard, diameter, length, cone, upright):
    """The part [m^3] of a bag's gas ``volume`` [m^3] below the waterline when its top stands
    ``freeboard`` [m] above the surface (the whole of it at or below the surface): what it
    displaces, and so lifts (body as in :func:`volume_from_top`)."""
    if freeboard <= 0.0:
        return volume
    return max(volume - volume_from_top(freeboard, diameter, length, cone, upright), 0.0)
