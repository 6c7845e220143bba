"""Seabed contact and suction breakout (SPEC §6).

Contact: a penalty spring-damper per unit length, q_c = max(0, -k w - c w') where the hull
bottom is below its resting height (w < 0): a hull that sinks back lands again. While the
hull is held by suction the same spring also works in tension (the soil holds the hull
down; the hull does not move but for millimetres of spring travel).

Breakout: the holding force H [N] is a state, initially H_0 = (breakout_factor - 1) W',
distributed along the hull in a shape (linear from ``stern_ratio`` to ``bow_ratio`` times the
mean, or uniform). With the net uplift U = sum of bag lift - W':

- held, while U <= H: dH/dt = -(H_0 / T_b) min(U / H_0, 1) when U > 0 (else 0);
- separated, once U > H: dH/dt = -H / tau_r, the remaining suction acting as a downward
  line load H shape(x) / L that releases over tau_r;
- breakout complete when H < 0.1 % of H_0.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: breakout is complete when the holding force falls below this fraction of H_0
COMPLETE_FRACTION = 1e-3


@dataclass(frozen=True)
class SeabedModel:
    """Seabed constants, SI.

    H0 : initial holding force [N]
    breakout_time : T_b, a full pull (U >= H_0) breaks out in this time [s]
    release_time : tau_r, suction release after separation [s]
    stiffness : contact penalty spring per unit length [N/m per m]
    damping : contact penalty damper per unit length [N s/m per m]
    stern_ratio, bow_ratio : holding force per length at the stern / bow over the mean [-]
    """

    H0: float
    breakout_time: float = 400.0
    release_time: float = 30.0
    stiffness: float = 5.0e6
    damping: float = 2.0e6
    stern_ratio: float = 0.5
    bow_ratio: float = 1.5

    def shape(self, x, length: float):
        """Holding force per unit length per unit H at x [m] on a hull of ``length`` [m]
        [1/m]; integrates to 1 over the hull."""
        xi = np.asarray(x, dtype=float) / length
        return (self.stern_ratio + (self.bow_ratio - self.stern_ratio) * xi) / length

    def held_rate(self, U, H=None):
        """dH/dt while held under the net uplift U [N] -> [N/s] (vectorised)."""
        U = np.asarray(U, dtype=float)
        return np.where(U > 0, -(self.H0 / self.breakout_time) * np.minimum(U / self.H0, 1.0), 0.0)

    def released_rate(self, H):
        """dH/dt after separation [N/s]."""
        return -np.asarray(H, dtype=float) / self.release_time

    def separation_time(self, U: float) -> float:
        """Time to separation under a constant net uplift U [N] (analytic, SPEC §6) [s]:
        T_b (H_0 / U - 1) for 0 < U < H_0, 0 for U >= H_0, inf for U <= 0."""
        if U <= 0:
            return float("inf")
        if U >= self.H0:
            return 0.0
        return self.breakout_time * (self.H0 / U - 1.0)

    def complete(self, H) -> bool:
        return bool(np.all(np.asarray(H) < COMPLETE_FRACTION * self.H0))


def contact_load(w, wdot, k: float, c: float, bilateral: bool):
    """Contact line load [N/m] and its active mask at strips of displacement ``w`` [m] (up
    positive, 0 = resting) and velocity ``wdot`` [m/s]. One-sided (no tension) unless
    ``bilateral`` (held by suction)."""
    if bilateral:
        return -k * w - c * wdot, np.ones(np.shape(w), dtype=bool)
    q = -k * w - c * wdot
    active = (w < 0.0) & (q > 0.0)
    return np.where(active, q, 0.0), active


def seabed_from_scenario(scenario, wet_weight: float) -> SeabedModel:
    """The :class:`SeabedModel` of a scenario; ``wet_weight`` W' [N]."""
    s = scenario.seabed
    stern, bow = (s.stern_ratio, s.bow_ratio) if s.holding_shape == "linear" else (1.0, 1.0)
    return SeabedModel(
        H0=(scenario.lift.breakout_factor - 1.0) * wet_weight,
        breakout_time=s.breakout_time_s,
        release_time=s.release_time_s,
        stiffness=s.contact_stiffness_N_m2,
        damping=s.contact_damping_Ns_m2,
        stern_ratio=stern,
        bow_ratio=bow,
    )
