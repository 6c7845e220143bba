"""What live knows of the lift: the latest reading of every sensor, in time order, the lift's
clock, and which sensors have gone silent.

Readings are ordered by their own time: one older than the latest of its sensor is *late*:
kept (logged, marked) but not taken as the sensor's present value. The lift's clock is the
latest reading time seen, run on between readings at the rate lift time has been passing per
second of this machine's clock (1 for a real lift; the rig's ``--speed`` for a faster rig:
estimated from the readings, or given). A sensor is *silent* once the clock is past its last
reading by twice its period (its declared period, or the interval seen between its readings)
and by :data:`SILENT_WALL_S` of this machine's clock.
"""

from __future__ import annotations

import math
from collections import deque

#: the speed of a bag is the least-squares slope of its heights over this much lift time [s]
SPEED_WINDOW_S = 2.0
#: silent: no reading for this many periods ...
SILENT_PERIODS = 2.0
#: ... and for at least this long on this machine's clock [s] (a rig at many times real time
#: delivers in bursts: its periods are milliseconds of wall time)
SILENT_WALL_S = 0.3
#: weight of a new interval in a sensor's learnt period, and of a new clock-rate sample
LEARN = 0.2
#: the clock's rate is re-estimated over at least this much wall time [s]
RATE_WINDOW_S = 0.5


class Board:
    """The latest readings of a lift whose bags are ``bags`` (names); ``periods``: sensor
    name (``<bag>/<quantity>``) -> declared period [s]; ``rate``: lift seconds per wall
    second when known (None: estimated)."""

    def __init__(self, bags, periods: dict | None = None, rate: float | None = None):
        self.bags = list(bags)
        self.declared = dict(periods or {})
        self.learnt: dict[str, float] = {}
        self.last: dict[str, tuple[float, float]] = {}  # sensor: (time, value)
        self.heights = {b: deque() for b in self.bags}
        self._speeds: dict[str, float | None] = {}  # speed(bag) until its next depth reading
        self.late = 0
        self.count = 0
        self._rate_known = rate
        self.rate = rate or 1.0
        self.t_max = -math.inf
        self._wall_at_max = None
        self._anchor = None  # (wall, lift time) of the last rate estimate
        self._samples = 0

    def add(self, reading, wall: float) -> bool:
        """Take ``reading`` received at ``wall`` [monotonic s]; whether it is late."""
        self.count += 1
        key = reading.sensor
        prev = self.last.get(key)
        if prev is not None and reading.time <= prev[0]:
            self.late += 1
            return True
        if prev is not None:
            gap = reading.time - prev[0]
            old = self.learnt.get(key)
            self.learnt[key] = gap if old is None else old + LEARN * (gap - old)
        self.last[key] = (reading.time, reading.value)
        if reading.quantity == "depth" and reading.source in self.heights:
            window = self.heights[reading.source]
            window.append((reading.time, reading.value))
            while window and window[0][0] < reading.time - SPEED_WINDOW_S:
                window.popleft()
            self._speeds.pop(reading.source, None)
        if reading.time > self.t_max:
            self._clock(reading.time, wall)
        return False

    def _clock(self, t: float, wall: float) -> None:
        self.t_max, self._wall_at_max = t, wall
        if self._rate_known is not None:
            return
        if self._anchor is None:
            self._anchor = (wall, t)
            return
        w0, t0 = self._anchor
        if wall - w0 >= RATE_WINDOW_S:
            sample = (t - t0) / (wall - w0)
            if sample > 0:
                self.rate = sample if self._samples == 0 else self.rate + LEARN * (sample - self.rate)
                self._samples += 1
            self._anchor = (wall, t)

    def now(self, wall: float) -> float:
        """The lift's clock at ``wall`` [s since filling began]; -inf before any reading."""
        if self._wall_at_max is None:
            return -math.inf
        return self.t_max + (wall - self._wall_at_max) * self.rate

    def period(self, sensor: str) -> float | None:
        """The sensor's period [s]: declared, else learnt, else None."""
        return self.declared.get(sensor, self.learnt.get(sensor))

    def silent(self, wall: float) -> list[str]:
        """The sensors heard from (or declared) whose last reading is older than
        SILENT_PERIODS periods on the lift's clock."""
        now = self.now(wall)
        out = []
        for sensor in sorted(set(self.last) | set(self.declared)):
            period = self.period(sensor)
            last = self.last.get(sensor, (0.0, None))[0]
            if period is not None and now - last > max(SILENT_PERIODS * period,
                                                       SILENT_WALL_S * self.rate):
                out.append(sensor)
        return out

    def value(self, source: str, quantity: str) -> float | None:
        """The latest value of a sensor (None: never heard)."""
        got = self.last.get(f"{source}/{quantity}")
        return None if got is None else got[1]

    def speed(self, bag: str) -> float | None:
        """The bag's upward speed [m/s]: minus the slope of its depth over the window (kept
        until the bag's next depth reading: live asks twice a period, for 73 bags)."""
        if bag not in self._speeds:
            self._speeds[bag] = self._slope(bag)
        return self._speeds[bag]

    def _slope(self, bag: str) -> float | None:
        window = self.heights[bag]
        if len(window) < 2:
            return None
        n = len(window)
        mt = sum(t for t, _ in window) / n
        md = sum(d for _, d in window) / n
        stt = sum((t - mt) ** 2 for t, _ in window)
        if stt <= 0:
            return None
        return -sum((t - mt) * (d - md) for t, d in window) / stt
