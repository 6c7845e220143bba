"""The seabed: suction holding force and contact (docs/theory/seabed.md).

Holding force H [N], initially H_0 = (breakout_factor - 1) W' (the timer law) or the soil's
immediate breakout force (the soil law, :func:`soil_breakout_force`). With the net uplift
U = sum of bag lift - W' [N]:

- held, while U <= H, by the seabed's law (``Seabed.law``, :func:`holding_rate`):

  - timer (:data:`LAW_TIMER`, the default): dH/dt = -(H_0 / T_b) min(U / H_0, 1) when
    U > 0, else 0 (a full pull breaks out in T_b; a weaker one takes longer);
  - soil (:data:`LAW_SOIL`, docs/theory/breakout-soil.md): the suction relieved by the
    consolidation of the soil under the pull, H = H_0 (1 - U_c(T_v)), Terzaghi's degree of
    consolidation U_c at the time factor T_v = t / T_c of the pull's duration t, with
    T_c = d^2 / c_v (``consolidation_time``: drainage length d, coefficient c_v); as a rate,
    dH/dt = -(H_0 / T_c) dU_c/dT_v at the degree U_c = 1 - H / H_0, when U > 0, else 0;

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

#: the held laws of ``Seabed.law``: the timer (docs/theory/seabed.md#suction-held) and the
#: soil's consolidation (docs/theory/breakout-soil.md)
LAW_TIMER = 0
LAW_SOIL = 1
#: the scenario's names of the laws (``seabed.breakout_law``)
LAWS = {"timer": LAW_TIMER, "soil": LAW_SOIL}

#: Terzaghi's degree of consolidation: U_c = sqrt(4 T_v / pi) below this degree, the first
#: term of the series, 1 - (8 / pi^2) exp(-pi^2 T_v / 4), above it (both within 1 % there)
EARLY_DEGREE = 0.6
#: below this degree the early rate 2 / (pi U_c), infinite at U_c = 0, is held at its value here
#: (the start of sqrt(T_v) regularised: it delays a degree by less than 1e-4 T_c)
MIN_DEGREE = 0.01
#: N_c of a deeply embedded rectangle in Skempton's (1951) bearing capacity, the cap on
#: 5 (1 + 0.2 D / B)(1 + 0.2 B / L) (docs/theory/breakout-soil.md#force)
NC_MAX = 7.5


@inline_jit
def relief_rate(degree):
    """dU_c/dT_v [-] of Terzaghi's degree of consolidation at the ``degree`` U_c [-] it has
    reached: 2 / (pi U_c) below :data:`EARLY_DEGREE` (U_c = sqrt(4 T_v / pi), held at its
    :data:`MIN_DEGREE` value below that), (pi^2 / 4)(1 - U_c) above."""
    if degree < EARLY_DEGREE:
        return 2.0 / (math.pi * max(degree, MIN_DEGREE))
    return 0.25 * math.pi * math.pi * max(1.0 - degree, 0.0)


@inline_jit
def holding_rate(uplift, holding, H0, seabed):
    """dH/dt while held [N/s] under the net ``uplift`` U [N], the ``holding`` force H [N]
    left of the initial ``H0`` [N], by the law of the ``seabed`` record
    (:class:`~flexlift.ascent.records.Seabed`: ``law``, ``breakout_time``,
    ``consolidation_time``): timer -(H_0 / T_b) min(U / H_0, 1), soil -(H_0 / T_c)
    dU_c/dT_v at U_c = 1 - H / H_0 (:func:`relief_rate`); 0 for U <= 0."""
    if uplift <= 0.0 or H0 <= 0.0:
        return 0.0
    if seabed.law == LAW_SOIL:
        return -(H0 / seabed.consolidation_time) * relief_rate(1.0 - holding / H0)
    return -(H0 / seabed.breakout_time) * min(uplift / H0, 1.0)


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


def consolidation_degree_time(degree: float) -> float:
    """Terzaghi's time factor T_v [-] at which the degree of consolidation reaches ``degree``
    U_c [-] (the two branches of :func:`relief_rate`): pi U_c^2 / 4 below
    :data:`EARLY_DEGREE`, -(4 / pi^2) ln((pi^2 / 8)(1 - U_c)) above; infinite at 1."""
    if degree >= 1.0:
        return math.inf
    if degree < EARLY_DEGREE:
        return 0.25 * math.pi * max(degree, 0.0) ** 2
    return -(4.0 / math.pi**2) * math.log((math.pi**2 / 8.0) * (1.0 - degree))


def soil_separation_time(uplift: float, H0: float, consolidation_time: float) -> float:
    """Time to separation [s] under a constant net ``uplift`` U [N] by the soil law
    (docs/theory/breakout-soil.md#separation-time): T_c T_v(1 - U / H_0) for
    0 < U < H_0, 0 for U >= H_0, infinite for U <= 0; ``consolidation_time`` T_c [s]."""
    if uplift <= 0:
        return math.inf
    if uplift >= H0:
        return 0.0
    return consolidation_time * consolidation_degree_time(1.0 - uplift / H0)


def soil_breakout_force(length: float, breadth: float, embedment: float,
                        shear_strength: float) -> float:
    """The soil's immediate breakout force [N] on a rectangle ``length`` x ``breadth`` [m]
    embedded ``embedment`` D [m] in clay of undrained ``shear_strength`` s_u [Pa]
    (docs/theory/breakout-soil.md#force): A s_u N_c, A = L B, with Skempton's
    N_c = 5 (1 + 0.2 D / B)(1 + 0.2 B / L) capped at :data:`NC_MAX`."""
    B, L = min(breadth, length), max(breadth, length)
    nc = min(5.0 * (1.0 + 0.2 * embedment / B) * (1.0 + 0.2 * B / L), NC_MAX)
    return length * breadth * shear_strength * nc


def separation_time(uplift: float, H0: float, breakout_time: float) -> float:
    """Time to separation under a constant net ``uplift`` U [N] (docs/theory/seabed.md#separation-time, analytic) [s]:
    T_b (H_0 / U - 1) for 0 < U < H_0, 0 for U >= H_0, infinite for U <= 0."""
    if uplift <= 0:
        return math.inf
    if uplift >= H0:
        return 0.0
    return breakout_time * (H0 / uplift - 1.0)
