"""The detector's statistical tests, each with its false-alarm rate (docs/theory/fault-detection.md).

- :class:`Cusum`: the two-sided CUSUM of normalised innovations ``e = (z - mean) / std``
  (N(0, 1) when nothing is wrong); its threshold from the wanted average run length by
  Siegmund's approximation (:func:`cusum_arl`, :func:`cusum_threshold`).
- :func:`silent_periods`: how many lost readings in a row a sensor may miss by chance.
- :func:`repeats_needed`: how many exact repeats of a noisy reading are proof that it is stuck.
- :func:`consistent_with`: whether readings since an onset are those of a known value (a
  chi-square acceptance test).
"""

from __future__ import annotations

import math

from scipy.stats import chi2

#: Siegmund's correction of the threshold for the overshoot of a Gaussian random walk [-]
#: (``2 * 0.583``: the mean overshoot of a standard Gaussian walk over a barrier)
OVERSHOOT = 1.166


def cusum_arl(h: float, nu: float) -> float:
    """In-control average run length [samples] of a ONE-sided CUSUM ``S = max(0, S + e - nu)``
    of N(0, 1) samples with threshold ``h``, by Siegmund's approximation
    ``ARL = (exp(2 nu b) - 2 nu b - 1) / (2 nu^2)``, ``b = h + 1.166``."""
    b = h + OVERSHOOT
    x = 2.0 * nu * b
    return (math.expm1(x) - x) / (2.0 * nu * nu)


def cusum_threshold(arl: float, nu: float) -> float:
    """The threshold ``h`` [-] whose TWO-sided CUSUM (upper and lower, each with reference
    ``nu``) has the in-control average run length ``arl`` [samples]: each side's run length
    is ``2 arl`` (``1/ARL = 1/ARL+ + 1/ARL-``), solved from :func:`cusum_arl` by bisection."""
    if arl <= 1.0:
        raise ValueError("the average run length must exceed one sample")
    lo, hi = 0.0, 1.0
    while cusum_arl(hi, nu) < 2.0 * arl:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if cusum_arl(mid, nu) < 2.0 * arl:
            lo = mid
        else:
            hi = mid
    return 0.5 * (lo + hi)


def excursion_p(s: float, nu: float) -> float:
    """The probability that one excursion of a one-sided CUSUM of N(0, 1) samples reaches
    ``s`` when nothing is wrong: ``exp(-2 nu (s + 1.166))`` (Wald's bound with Siegmund's
    overshoot); the p-value of an observed statistic, for an alarm's confidence."""
    return min(1.0, math.exp(-2.0 * nu * (s + OVERSHOOT)))


class Cusum:
    """Two-sided CUSUM of normalised innovations.

    ``up = max(0, up + e - nu)``, ``down = max(0, down - e - nu)``; a side is flagged while it
    is above ``h``. ``onset_*`` is the time of the last sample at which that side was zero
    (the change's maximum-likelihood time for a step); ``peak_*`` its largest value since.

    Parameters
    ----------
    h : float
        Threshold [-] (:func:`cusum_threshold`).
    nu : float
        Reference value [-]: half the smallest shift, in standard deviations, to be found
        quickly.
    """

    def __init__(self, h: float, nu: float):
        self.h, self.nu = h, nu
        self.up = self.down = 0.0
        self.onset_up = self.onset_down = -math.inf
        self.n = 0

    def update(self, e: float, t: float) -> int:
        """Add the innovation ``e`` taken at ``t`` [s]; returns +1 (upper side above ``h``),
        -1 (lower side), 0 (neither; the larger if both)."""
        self.n += 1
        if self.up == 0.0:
            self.onset_up = t
        if self.down == 0.0:
            self.onset_down = t
        self.up = max(0.0, self.up + e - self.nu)
        self.down = max(0.0, self.down - e - self.nu)
        return self.state

    @property
    def state(self) -> int:
        if self.up > self.h or self.down > self.h:
            return 1 if self.up >= self.down else -1
        return 0

    def onset(self, side: int) -> float:
        """The estimated change time [s] of ``side`` (+1 up, -1 down)."""
        return self.onset_up if side > 0 else self.onset_down

    def p_value(self, side: int) -> float:
        """:func:`excursion_p` of ``side``'s current statistic."""
        return excursion_p(self.up if side > 0 else self.down, self.nu)

    def reset(self) -> None:
        self.up = self.down = 0.0


def silent_periods(dropout: float, budget_per_sample: float) -> int:
    """The least ``k >= 2`` lost readings in a row whose chance, ``dropout^k`` per sample, is
    at most ``budget_per_sample`` (a sensor that loses each reading independently with
    probability ``dropout``); 2 for a sensor that never loses one (one late reading is no
    alarm)."""
    if dropout <= 0.0:
        return 2
    return max(2, math.ceil(math.log(budget_per_sample) / math.log(dropout) - 1e-12))


def repeat_probability(noise: float, resolution: float) -> float:
    """The chance that a reading with Gaussian noise ``noise`` (std) resolved to
    ``resolution`` (same unit) equals the one before exactly: the difference of two
    readings is N(0, 2 noise^2), whose density at 0 is ``1 / (2 sqrt(pi) noise)``, times
    the width of one step of resolution."""
    return min(1.0, resolution / (2.0 * math.sqrt(math.pi) * noise))


def repeats_needed(noise: float, resolution: float, budget_per_sample: float) -> int:
    """The least ``m >= 1`` exact repeats in a row whose chance
    (:func:`repeat_probability` ``^ m``) is at most ``budget_per_sample``."""
    p = repeat_probability(noise, resolution)
    if p >= 1.0:
        return 1_000_000_000  # a sensor coarser than its noise repeats by itself: no test
    return max(1, math.ceil(math.log(budget_per_sample) / math.log(p) - 1e-12))


def consistent_with(sum_sq: float, n: int, alpha: float) -> bool:
    """Whether ``n`` readings whose squared normalised residuals to a value sum to
    ``sum_sq`` are those of that value: ``sum_sq`` at most the chi-square(n) quantile at
    ``1 - alpha`` (``alpha``: the chance of refusing a true value)."""
    return n > 0 and sum_sq <= float(chi2.ppf(1.0 - alpha, n))
