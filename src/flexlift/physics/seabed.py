"""The seabed: suction holding force and contact (docs/theory/seabed.md).

Holding force H [N], initially H_0 = (breakout_factor - 1) W'. With the net uplift U = sum
of bag lift - W' [N]:

- held, while U <= H: dH/dt = -(H_0 / T_b) min(U / H_0, 1) when U > 0, else 0
  (a full pull breaks out in T_b; a weaker one takes longer);
- separated, once U > H: the remaining suction releases, dH/dt = -H / tau_r, acting as a
  downward line load in its shape;
- breakout is complete when H < :data:`COMPLETE_FRACTION` H_0.

Contact: a penalty spring-damper per unit length under the hull, q = -k w - c w' [N/m]
(w the height of the hull bottom above its resting level [m], up positive), active only in
compression below the seabed, or in tension too while the hull is held by suction.
"""

from __future__ import annotations

import math

import numpy as np

from flexlift._jit import inline_jit

#: breakout is complete when the holding force falls below this fraction of H_0
COMPLETE_FRACTION = 1e-3


@inline_jit
def holding_rate(uplift, H0, breakout_time):
    """dH/dt while held [N/s] under the net ``uplift`` U [N]: -(H_0 / T_b)
    min(U / H_0, 1) for U > 0, else 0; ``H0`` [N], ``breakout_time`` T_b [s]."""
    pull = np.minimum(np.maximum(uplift, 0.0) / np.maximum(H0, 1e-300), 1.0)
    return -(H0 / breakout_time) * pull


@inline_jit
def released_holding(holding, dt, release_time):
    """Holding force [N] ``dt`` [s] after separation left it at ``holding`` H [N]: the exact
    decay H exp(-dt / tau_r) of dH/dt = -H / tau_r (``release_time`` tau_r [s])."""
    return holding * np.exp(-dt / release_time)


@inline_jit
def contact_load(w, wdot, stiffness, damping, bilateral):
    """Seabed line load [N/m] on a strip at height ``w`` [m] (0 = resting, up positive)
    moving at ``wdot`` [m/s]: -k w - c w' with ``stiffness`` k [N/m per m] and ``damping``
    c [N s/m per m]; one-sided (pushing up, below the seabed only) unless ``bilateral`` (the
    hull held down by suction)."""
    q = -stiffness * w - damping * wdot
    return q * np.logical_or(bilateral, (w < 0.0) & (q > 0.0))


@inline_jit
def in_contact(w, wdot, stiffness, damping):
    """True where a strip at ``w`` [m] moving at ``wdot`` [m/s] is pressed on the seabed (the
    one-sided :func:`contact_load` is active)."""
    return (w < 0.0) & (-stiffness * w - damping * wdot > 0.0)


def holding_shape(x, length: float, stern_ratio: float = 0.5, bow_ratio: float = 1.5):
    """Holding force per unit length per unit H [1/m] at ``x`` [m] on a hull of ``length``
    [m]: linear from ``stern_ratio`` to ``bow_ratio`` times the mean (1 / L), integrating to
    1 over the hull (the ratios sum to 2; uniform: both 1)."""
    xi = np.asarray(x, dtype=float) / length
    return (stern_ratio + (bow_ratio - stern_ratio) * xi) / length


def separation_time(uplift: float, H0: float, breakout_time: float) -> float:
    """Time to separation under a constant net ``uplift`` U [N] (docs/theory/seabed.md#separation-time, analytic) [s]:
    T_b (H_0 / U - 1) for 0 < U < H_0, 0 for U >= H_0, infinite for U <= 0."""
    if uplift <= 0:
        return math.inf
    if uplift >= H0:
        return 0.0
    return breakout_time * (H0 / uplift - 1.0)
