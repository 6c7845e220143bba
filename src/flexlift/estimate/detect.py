"""Fault detection and isolation from a lift's readings and their predictions
(docs/theory/fault-detection.md).

:class:`Detector` takes every reading with the estimator's predicted mean and standard
deviation of it (from any estimator: the detector does not care how they are made) and
raises :class:`~flexlift.estimate.detect_alarm.Alarm` s, each fault once per bag and kind:

- detection, per sensor (:mod:`flexlift.estimate.detect_track`): a two-sided CUSUM of the
  normalised innovations, its threshold from the wanted false alarms per hour; exact repeats
  of a noisy reading (stuck); readings missing longer than their dropouts explain (silent);
- isolation, per bag: the pattern of its sensors' flags and the values they read (a sling
  force of zero, a supply at atmospheric pressure, a purge shut) against each fault's
  signature (:data:`SIGNATURES` in the theory page), once the bag's flags have stood still
  for ``isolation_wait_s``.
"""

from __future__ import annotations

import math

from flexlift.estimate.detect_alarm import Alarm, make_alarm
from flexlift.estimate.detect_track import Track
from flexlift.sensors.config import HULL, Sensor
from flexlift.sensors.log import Reading

#: faults of the bag's hardware: a bag has one at a time (the first named explains the rest
#: of its readings, which no longer follow a model that does not know of it)
PHYSICAL = ("bag_rupture", "sling_break", "supply_failure", "dump_valve_stuck_closed",
            "fill_valve_stuck_open", "fill_valve_stuck_closed")
#: the tests per sensor sharing its part of the false-alarm budget
TESTS_PER_SENSOR = 3
#: a fill valve is named stuck open only once its flow has stood above the prediction for
#: most of this span [s] (:meth:`Track.persistent`), a dump valve stuck shut once it has read
#: shut all of it (:meth:`Track.read_throughout`): the lift's controller tops its bags up and
#: cycles its dump valves in bursts of a few seconds that members a little off give at other
#: moments; a stuck valve stays as it stuck (a quarter of the issue's 120 s for a stuck
#: valve; docs/theory/fault-detection.md#persistence)
PERSIST_S = 30.0


class Detector:
    """Detect and name faults from readings and their predictions.

    Parameters
    ----------
    sensors : list of Sensor
        The lift's sensors (:func:`flexlift.sensors.config.sensors_of`): their rates, noise
        (the stuck test), dropouts (the silence test) and latencies.
    bag_names : sequence of str
        The plant's bags.
    false_alarms_per_hour : float, optional
        The false alarms per hour of the whole detector when nothing is wrong and the
        predictions are right (N(mean, std)): split evenly over the sensors and their three
        tests (a union bound: the rate is at most this). Default 1e-3.
    nu : float, optional
        The CUSUM's reference [std]: half the smallest shift it is tuned to find quickly.
        Default 0.5.
    value_alpha : float, optional
        The chance of refusing a true value in the value tests (sling force 0, supply at
        atmospheric pressure, purge 0). Default 1e-3.
    atmospheric_pressure_Pa : float, optional
        A lost supply's pressure. Default 101325.
    resolution : dict, optional
        Quantity -> the sensors' resolution (SI) for the stuck test; default the float's.
    isolation_wait_s : float, optional
        How long a bag's flags must stand still before it is named; default two periods of
        the bag's slowest sensor.
    """

    def __init__(self, sensors: list[Sensor], bag_names, false_alarms_per_hour: float = 1e-3,
                 nu: float = 0.5, value_alpha: float = 1e-3,
                 atmospheric_pressure_Pa: float = 101_325.0,
                 resolution: dict[str, float] | None = None,
                 isolation_wait_s: float | None = None):
        if not sensors:
            raise ValueError("a detector needs sensors")
        if not 0.0 < false_alarms_per_hour:
            raise ValueError("false_alarms_per_hour must be positive")
        self.bag_names = list(bag_names)
        budget = false_alarms_per_hour / (TESTS_PER_SENSOR * len(sensors))
        resolution = resolution or {}
        self.tracks = {s.name: Track(s, budget, nu, resolution.get(s.quantity))
                       for s in sensors}
        self.value_alpha = value_alpha
        self.p_atm = atmospheric_pressure_Pa
        self._of_bag: dict[str, dict[str, Track]] = {}
        for tr in self.tracks.values():
            self._of_bag.setdefault(tr.sensor.bag, {})[tr.sensor.quantity] = tr
        slowest = {b: max(tr.sensor.period_s for tr in q.values())
                   for b, q in self._of_bag.items()}
        self._wait = {b: 2.0 * p if isolation_wait_s is None else isolation_wait_s
                      for b, p in slowest.items()}
        self._changed = {b: math.nan for b in self._of_bag}  # last flag change [s]
        self._raised: set[tuple[str, str]] = set()
        self.alarms: list[Alarm] = []
        self.unknown = 0  # readings of sensors the detector does not know
        self._t0: float | None = None

    # ---------------------------------------------------------------- the interface
    def update(self, reading: Reading, predicted_mean: float | None,
               predicted_std: float | None) -> list[Alarm]:
        """Take one reading and its prediction (None: none); the alarms it completes."""
        tr = self.tracks.get(reading.sensor)
        if tr is None:
            self.unknown += 1
            return []
        t, z = reading.time_s, reading.value
        self._start(t)
        bag = tr.sensor.bag
        if tr.repeat(t, z):
            self._changed[bag] = t
        tr.last_value = z
        tr.last_time = t if tr.last_time is None else max(tr.last_time, t)
        tr.silent_since = None
        if (not tr.faulty and predicted_mean is not None and predicted_std is not None
                and predicted_std > 0.0 and math.isfinite(predicted_mean)
                and tr.innovation(t, z, predicted_mean, predicted_std)):
            self._changed[bag] = t
        return self._isolate(bag, t)

    def tick(self, time_s: float) -> list[Alarm]:
        """The time is ``time_s`` [s, in the readings' time]: the silent sensors' alarms,
        and any bag whose flags have stood still long enough."""
        self._start(time_s)
        out = []
        for bag, tracks in self._of_bag.items():
            silent = [tr for tr in tracks.values() if tr.silence(time_s)]
            if silent:
                out += self._raise_silent(bag, tracks, silent, time_s)
            out += self._isolate(bag, time_s)
        return out

    # ---------------------------------------------------------------- bookkeeping
    def _start(self, t: float) -> None:
        """The first time seen (a sensor is watched for silence from its first reading on:
        one never heard from is :attr:`never_heard`, not a fault that began)."""
        if self._t0 is None:
            self._t0 = t

    @property
    def never_heard(self) -> list[str]:
        """The sensors without a reading so far (a bag without a purge controller has no
        purge reading)."""
        return [name for name, tr in self.tracks.items() if tr.last_time is None]

    def _raise(self, alarm: Alarm) -> list[Alarm]:
        key = (alarm.bag, alarm.kind)
        if key in self._raised:
            return []
        self._raised.add(key)
        self.alarms.append(alarm)
        return [alarm]

    def _raise_silent(self, bag, tracks, silent, t) -> list[Alarm]:
        every = all(tr.silent_since is not None for tr in tracks.values())
        since = min(tr.silent_since for tr in silent)
        sensor = None if every or len(silent) > 1 else silent[0].sensor.name
        names = ", ".join(tr.sensor.quantity for tr in silent)
        p = max(tr.silent_p for tr in silent)
        detail = f"no {names} reading for {t - since:.0f} s"
        return self._raise(make_alarm(t, "sensor_dropout", bag, sensor, [p], since, detail,
                                      evidence={"silent": [tr.sensor.name for tr in silent],
                                                "p": p}))

    # ---------------------------------------------------------------- isolation
    def _isolate(self, bag: str, t: float) -> list[Alarm]:
        changed = self._changed[bag]
        if not t >= changed + self._wait[bag]:
            return []
        tracks = self._of_bag[bag]
        if not any(tr.flag or tr.stuck_p is not None for tr in tracks.values()):
            self._changed[bag] = math.nan  # nothing to name until a flag rises
            return []
        out = self._stuck(bag, tracks, t)
        if bag == HULL:
            return out
        if not any((bag, k) in self._raised for k in PHYSICAL):
            alarm = self._physical(bag, tracks, t)
            if alarm is not None:
                out += self._raise(alarm)
        alarm = self._drift(bag, tracks, t)
        if alarm is not None:
            out += self._raise(alarm)
        return out

    def _stuck(self, bag, tracks, t) -> list[Alarm]:
        stuck = [tr for tr in tracks.values() if tr.stuck_p is not None]
        if not stuck:
            return []
        sensor = stuck[0].sensor.name if len(stuck) == 1 else None
        names = ", ".join(tr.sensor.quantity for tr in stuck)
        since = min(tr.last_time - (tr.repeats - 1) * tr.sensor.period_s for tr in stuck)
        detail = f"{names} repeat{'s' if len(stuck) == 1 else ''} exactly"
        p = max(tr.stuck_p for tr in stuck)
        return self._raise(make_alarm(t, "sensor_stuck", bag, sensor, [p], since, detail,
                                      evidence={"stuck": [tr.sensor.name for tr in stuck],
                                                "p": p}))

    def _flag(self, tracks, quantity, t: float) -> int:
        """The flag of the bag's ``quantity`` sensor at ``t``: 0 if it has none, is faulty,
        or its flag is no longer fed (:meth:`Track.standing` over the isolation wait)."""
        tr = tracks.get(quantity)
        if tr is None or tr.faulty or not tr.standing(t, self._wait[tr.sensor.bag]):
            return 0
        return tr.flag

    def _physical(self, bag, tracks, t) -> Alarm | None:
        """The bag's hardware fault its flags show, if any (the signatures' table of the
        theory page, most severe first)."""
        F, Q = self._flag(tracks, "sling_force", t), self._flag(tracks, "fill_flow", t)
        S, P = self._flag(tracks, "supply_pressure", t), self._flag(tracks, "purge", t)
        a = self.value_alpha
        if F < 0:
            force = tracks["sling_force"]
            first, last, pred = force.since_flag()
            if force.reads(0.0, a) and Q <= 0:
                return self._alarm(t, "sling_break", bag, [force],
                                   f"sling force {pred / 1e6:.2f} MN expected, reads "
                                   f"{last / 1e3:.0f} kN")
            used = [force] + ([tracks["fill_flow"]] if Q > 0 else [])
            filled = " while filled" if Q > 0 else ""
            return self._alarm(t, "bag_rupture", bag, used,
                               f"sling force fell to {last / 1e6:.2f} MN of "
                               f"{pred / 1e6:.2f} MN expected{filled}")
        if Q > 0 and tracks["fill_flow"].persistent(t, PERSIST_S):
            flow = tracks["fill_flow"]
            _, last, pred = flow.since_flag()
            return self._alarm(t, "fill_valve_stuck_open", bag, [flow],
                               f"fill flow {last:.2f} m3/s free air of {pred:.2f} expected, "
                               "the bag's load as expected")
        if S < 0 and tracks["supply_pressure"].reads(self.p_atm, a):
            supply = tracks["supply_pressure"]
            return self._alarm(t, "supply_failure", bag, [supply],
                               f"supply pressure at atmospheric, {supply.since_flag()[2] / 1e5:.1f}"
                               " bar expected", ("fill_valve_stuck_closed",))
        if P < 0 and tracks["purge"].reads(0.0, a) and tracks["purge"].read_throughout(
                0.0, a, t, PERSIST_S):
            purge = tracks["purge"]
            return self._alarm(t, "dump_valve_stuck_closed", bag, [purge],
                               f"purge shut, {purge.since_flag()[2]:.2f} open expected")
        return None

    def _drift(self, bag, tracks, t) -> Alarm | None:
        """A depth gauge whose innovation has moved while its bag's load cell and every other
        depth gauge agree with the predictions (none of them has moved the same way since
        the gauge's onset: :meth:`Track.moved`; theory page)."""
        D = self._flag(tracks, "depth", t)
        if D == 0 or self._flag(tracks, "sling_force", t) != 0:
            return None
        gauge = tracks["depth"]
        onset = gauge.cusum.onset(D)
        for other, q in self._of_bag.items():
            tr = q.get("depth")
            if other != bag and tr is not None and not tr.faulty and tr.moved(D, onset):
                return None  # the other gauge moved too: the hull moved, not the gauge
        _, last, pred = gauge.since_flag()
        return self._alarm(t, "sensor_drift", bag, [gauge],
                           f"reads {last:.2f} m, {pred:.2f} m expected", sensor=gauge.sensor.name)

    def _alarm(self, t, kind, bag, used, detail, alternatives=(), sensor=None) -> Alarm:
        p = [tr.cusum.p_value(tr.flag) for tr in used]
        onset = min(tr.cusum.onset(tr.flag) for tr in used)
        evidence = {tr.sensor.name: {"side": tr.flag, "cusum": max(tr.cusum.up, tr.cusum.down),
                                     "h": tr.h, "p": pv} for tr, pv in zip(used, p)}
        return make_alarm(t, kind, bag, sensor, p, onset, detail, tuple(alternatives), evidence)
