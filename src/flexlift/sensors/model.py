"""The sensor model: true values into readings (docs/reference/sensor-log.md#model).

Each sensor samples at ``k / rate_Hz`` (k = 0, 1, ...), the true value interpolated linearly
between the loop's recorded rows (exact at a row); adds Gaussian noise of its standard
deviation; loses the reading with probability ``dropout``; delivers it ``latency_s`` after it
was taken (the log's lines are in the order of delivery: readings of different sensors may be
out of time order; each reading keeps the time it was taken). Every sensor draws from its
own two streams of a seeded generator (``sensors.seed``), one draw of noise and one of
dropout per sample, so the readings do not depend on how the run is cut into chunks.

The scenario's sensor faults act on the readings of the faulted bag's sensors as they act
on its controller's (:mod:`flexlift.ascent.faults`): ``sensor_drift`` shifts its depth by
``-rate_m_s (t - t0)`` (the height reads high), ``sensor_stuck`` holds every one of its
sensors at its last reading, ``sensor_dropout`` silences them for ``duration_s``.
"""

from __future__ import annotations

import heapq
import math

import numpy as np

from flexlift.sensors.config import HULL, Sensor
from flexlift.sensors.log import Reading


class SensorModel:
    """Readings of ``sensors`` from true values given row by row.

    Parameters
    ----------
    sensors : list of Sensor
    seed : int
        ``sensors.seed``.
    """

    def __init__(self, sensors: list[Sensor], seed: int):
        self.sensors = sensors
        streams = np.random.SeedSequence(seed).spawn(2 * len(sensors))  # noise, dropout
        self._rng = [(np.random.default_rng(streams[2 * k]),
                      np.random.default_rng(streams[2 * k + 1])) for k in range(len(sensors))]
        self._next = np.zeros(len(sensors), dtype=np.int64)  # the next sample's k
        self._held = [math.nan] * len(sensors)  # last reading (a stuck sensor's value)
        self._queue: list[tuple[float, int, Reading]] = []  # (arrival, order, reading)
        self._order = 0
        self._prev: tuple[float, np.ndarray] | None = None  # the last row seen

    def add_rows(self, t: np.ndarray, values: np.ndarray, faults=None) -> None:
        """Take the rows at times ``t`` (rows,) [s] with true ``values`` (rows, sensors);
        ``faults`` (optional) maps a sensor's index to its fault state during these rows
        (``("drift", rate, t0)``, ``("stuck",)`` or ``("silent", until)``)."""
        if t.size == 0:
            return
        if self._prev is not None:
            t = np.concatenate([[self._prev[0]], t])
            values = np.vstack([self._prev[1][None, :], values])
        faults = faults or {}
        for k, s in enumerate(self.sensors):
            kk = int(self._next[k])
            last = int(math.floor(t[-1] * s.rate_Hz + 1e-9))
            if last < kk:
                continue
            times = np.arange(kk, last + 1) / s.rate_Hz
            times = times[times >= t[0] - 1e-12]
            true = np.interp(times, t, values[:, k])
            self._samples(k, s, times, true, faults.get(k))
            self._next[k] = last + 1
        self._prev = (float(t[-1]), values[-1].copy())

    def _samples(self, k: int, s: Sensor, times, true, fault) -> None:
        noisy, losing = self._rng[k]
        noise = noisy.standard_normal(times.size) * s.noise
        lost = losing.random(times.size) < s.dropout
        for t, v, e, gone in zip(times.tolist(), true.tolist(), noise.tolist(), lost.tolist()):
            if math.isnan(v) or gone:
                continue
            value = v + e
            if fault is not None:
                if fault[0] == "silent" and t < fault[1]:
                    continue
                if fault[0] == "stuck" and not math.isnan(self._held[k]):
                    value = self._held[k]
                if fault[0] == "drift" and s.quantity == "depth":
                    value -= fault[1] * max(t - fault[2], 0.0)
            self._held[k] = value
            heapq.heappush(self._queue, (t + s.latency_s, self._order, Reading(t, s.name, value)))
            self._order += 1

    def delivered(self, until: float = math.inf) -> list[Reading]:
        """The readings delivered by ``until`` [s] and not yet taken, in the order of
        delivery."""
        out = []
        while self._queue and self._queue[0][0] <= until:
            out.append(heapq.heappop(self._queue)[2])
        return out


def sensor_faults(sensors: list[Sensor], names, column, switches, t: float) -> dict:
    """The fault state of each sensor whose bag's sensors are faulted, from the loop's
    switches (:class:`flexlift.ascent.state.Switches`, per loop bag; ``column`` the loop bag
    of each of the plant's bags) during rows from time ``t`` [s] on. A dropout is silent
    until its ``frozen_until`` also when the loop has already cleared ``frozen`` (it does at
    that time, which may be before the chunk's end)."""
    index = {name: k for k, name in enumerate(names)}
    out = {}
    for k, s in enumerate(sensors):
        if s.bag == HULL:
            continue
        j = int(column[index[s.bag]])
        until = float(switches.frozen_until[j])
        if switches.frozen[j] and math.isinf(until):
            out[k] = ("stuck",)
        elif math.isfinite(until) and until > t:
            out[k] = ("silent", until)
        elif switches.drift[j] != 0.0:
            out[k] = ("drift", float(switches.drift[j]), float(switches.drift_t0[j]))
    return out
