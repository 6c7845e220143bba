"""One sensor's tests in the fault detector: its CUSUM, its silence and its repeats
(docs/theory/fault-detection.md)."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from scipy.stats import binom, norm

from flexlift.estimate.detect_stats import (
    Cusum,
    consistent_with,
    cusum_threshold,
    repeat_probability,
    repeats_needed,
    silent_periods,
)
from flexlift.sensors.config import Sensor

#: readings kept per sensor for the value tests (10 min at 1 Hz)
WINDOW = 600


class Track:
    """The state of one sensor's tests.

    Parameters
    ----------
    sensor : Sensor
    budget_per_hour : float
        The false alarms per hour each of its three tests (CUSUM, silence, repeats) may give.
    nu : float
        The CUSUM's reference [-].
    resolution : float or None
        The sensor's resolution (SI); None: the float's own (``numpy.spacing`` at the value).
    """

    def __init__(self, sensor: Sensor, budget_per_hour: float, nu: float,
                 resolution: float | None):
        self.sensor = sensor
        self.per_sample = budget_per_hour / (3600.0 * sensor.rate_Hz)  # false alarms / sample
        self.h = cusum_threshold(1.0 / self.per_sample, nu)
        self.cusum = Cusum(self.h, nu)
        self.k_silent = silent_periods(sensor.dropout, self.per_sample)
        self.z_standing = float(norm.isf(self.per_sample))
        self.resolution = resolution
        self.flag = 0  # +1 / -1 while the CUSUM's upper / lower side is above h
        self.flag_time = math.nan  # the first reading of the current flag
        self.last_time: float | None = None
        self.last_value = math.nan
        self.repeats = 0
        self.stuck_p: float | None = None  # the repeats' chance once they prove it stuck
        self.silent_since: float | None = None
        self.silent_p = 1.0
        self.window: deque = deque(maxlen=WINDOW)  # (t, z, mean, std)
        self._persist_k: dict[int, int] = {}  # readings in the span -> those needed

    @property
    def faulty(self) -> bool:
        """Stuck or silent: its readings say nothing of the lift."""
        return self.stuck_p is not None or self.silent_since is not None

    def repeat(self, t: float, value: float) -> bool:
        """Count an exact repeat of the last reading; True when the repeats prove the
        sensor stuck (:func:`~flexlift.estimate.detect_stats.repeats_needed`)."""
        noise = self.sensor.noise
        if noise > 0.0 and value == self.last_value:
            self.repeats += 1
            q = self.resolution or float(np.spacing(abs(value)))
            m = repeats_needed(noise, q, self.per_sample)
            if self.repeats >= m and self.stuck_p is None:
                self.stuck_p = repeat_probability(noise, q) ** self.repeats
                return True
        else:
            self.repeats = 0
        return False

    def innovation(self, t: float, z: float, mean: float, std: float) -> bool:
        """Add the reading ``z`` predicted N(``mean``, ``std``); True when its flag changed."""
        self.window.append((t, z, mean, std))
        state = self.cusum.update((z - mean) / std, t)
        if state == self.flag:
            return False
        self.flag, self.flag_time = state, t
        return True

    def silence(self, now: float) -> bool:
        """Whether, at ``now`` [s], ``k_silent`` readings in a row are due and missing
        (each taken one period after the last, delivered ``latency_s`` later); sets
        ``silent_since`` (the first missing reading's time) the first time."""
        if self.last_time is None:
            return False
        s = self.sensor
        due = math.floor((now - s.latency_s - self.last_time) * s.rate_Hz + 1e-9)
        if due < self.k_silent:
            return False
        if self.silent_since is None:
            self.silent_since = self.last_time + s.period_s
            self.silent_p = s.dropout ** due
            return True
        return False

    def reads(self, value: float, alpha: float) -> bool:
        """Whether every reading since the current flag is that of ``value`` (its noise:
        the sensor's, or the predicted std when the sensor has none given)."""
        sq, n = 0.0, 0
        for t, z, _mean, std in self.window:
            if t >= self.flag_time:
                sigma = self.sensor.noise if self.sensor.noise > 0 else std
                sq += ((z - value) / sigma) ** 2
                n += 1
        return consistent_with(sq, n, alpha)

    def read_throughout(self, value: float, alpha: float, now: float, span_s: float) -> bool:
        """Whether the readings of the whole last ``span_s`` before ``now`` are of ``value``
        (as :meth:`reads`), the span covered: its first reading at least 80 % of the span
        before ``now``. A valve stuck shut reads shut all along; a controller's valve that the
        members open at other moments than the lift's reads open in between
        (docs/theory/fault-detection.md#persistence)."""
        rows = [(t, z, std) for t, z, _m, std in self.window if t > now - span_s + 1e-9]
        if not rows or now - rows[0][0] < 0.8 * span_s:
            return False
        sq = 0.0
        for _t, z, std in rows:
            sigma = self.sensor.noise if self.sensor.noise > 0 else std
            sq += ((z - value) / sigma) ** 2
        return consistent_with(sq, len(rows), alpha)

    def standing(self, now: float, span_s: float) -> bool:
        """Whether the current flag is still fed: the readings of the last ``span_s`` before
        ``now`` lie, on average, beyond the CUSUM's reference on the flag's side (a CUSUM
        stays above its threshold long after one outlier; a fault's deviation lasts): their
        mean beyond ``nu + z / sqrt(n)``, ``z`` the standard normal quantile of the sensor's
        false-alarm budget per sample, so that noise alone passes it no more often than the
        CUSUM's own threshold."""
        if self.flag == 0:
            return False
        e = [(z - m) / sd for t, z, m, sd in self.window if t > now - span_s + 1e-9]
        if not e:
            return False
        return self.flag * float(np.mean(e)) > self.cusum.nu + self.z_standing / math.sqrt(len(e))

    def persistent(self, now: float, span_s: float) -> bool:
        """Whether the current flag has lasted: of the ``n`` readings of the last ``span_s``
        before ``now``, at least ``k`` lie beyond the CUSUM's reference on the flag's side, the
        least ``k`` that noise alone (each beyond with probability ``1 - Phi(nu)``) reaches no
        more often than the sensor's false-alarm budget per sample (a binomial sign test).
        A fault that lasts passes it once its readings fill the span; a deviation of a few
        seconds in it (a controller's short fill the members did not give) does not, however
        large (docs/theory/fault-detection.md#persistence)."""
        if self.flag == 0:
            return False
        e = [(z - m) / sd for t, z, m, sd in self.window if t > now - span_s + 1e-9]
        n = len(e)
        if n not in self._persist_k:
            p = float(norm.sf(self.cusum.nu))
            self._persist_k[n] = int(binom.isf(self.per_sample, n, p)) + 1 if n else 1
        return sum(self.flag * x > self.cusum.nu for x in e) >= self._persist_k[n] > 0 and n > 0

    def moved(self, side: int, since: float) -> bool:
        """Whether the innovations since ``since`` [s] lean to ``side`` beyond noise: their
        mean times ``sqrt(n)`` past the same quantile as :meth:`standing`'s."""
        e = [(z - m) / sd for t, z, m, sd in self.window if t >= since]
        return bool(e) and side * sum(e) / math.sqrt(len(e)) > self.z_standing

    def since_flag(self) -> tuple[float, float, float]:
        """(first, last reading, last prediction) since the current flag, for a message."""
        rows = [(z, m) for t, z, m, _ in self.window if t >= self.flag_time]
        return rows[0][0], rows[-1][0], rows[-1][1]
