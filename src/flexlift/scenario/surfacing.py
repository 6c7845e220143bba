"""The scenario's ``surfacing:`` section: the final lift of the hull out of the water and the
water trapped in it (docs/theory/trapped-water.md), read by ``flexlift surfacing``.

The hull's depth D is ``hull.depth_m`` (keel to the top of the space that holds water) and
its steel is the hull's mass; this section adds what the trapped water needs. The section
absent: the scenario has no final lift to compute (and the ascent never reads it).
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict

from flexlift.scenario.types import MAX_TIME_S, real


class Surfacing(BaseModel):
    """The final lift through the surface: the trapped water, its openings and the lift."""

    model_config = ConfigDict(extra="forbid", frozen=True, validate_default=True)

    trapped_volume_m3: real(0, 1.0e6)  # water the flooded hull holds: none .. a VLCC's holds
    opening_area_m2: real(0, 1.0e4)  # the openings it drains by, at the keel: none .. a whole bottom
    discharge_coefficient: real(0.01, 1) = 0.61  # C_d: 0.61 a sharp-edged orifice, ~1 a bell mouth
    lift_speed_m_s: real(0.001, 10)  # the steady lift speed: 6 cm/min .. far beyond any crane's
    start_depth_m: real(0, 1000) = 1.0  # the hull's top below the surface when the history starts
    clearance_m: real(0, 100) = 1.0  # the keel's height above the surface where the lift stops
    hold_s: real(1, MAX_TIME_S) = 3600.0  # how long the history goes on after the lift stops
