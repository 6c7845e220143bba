"""The estimator and the fault detector over a stream of readings, window by window
(docs/theory/estimation.md#filter): what ``flexlift replay`` runs over a log and ``flexlift
live --estimate`` over the lift's network.

Readings are gathered into windows of their own times; a window is taken once a reading
later than its end plus the sensors' largest latency has come (so every reading of it has
arrived), then the members advance to its end and are updated
(:meth:`flexlift.estimate.filter.Estimator.assimilate`), every reading goes with its
prediction to the detector (:class:`flexlift.estimate.detect.Detector`), and at every
``forecast_every_s`` the members are run on to the end (:func:`flexlift.estimate.forecast.
forecast`). A reading that comes after its window was taken is *late*: counted, given to the
detector without a prediction, not assimilated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from flexlift.errors import InputError
from flexlift.estimate.detect import Detector
from flexlift.estimate.filter import Estimator, window_steps
from flexlift.estimate.forecast import forecast
from flexlift.sensors.config import sensors_of

#: the controller whose advice commanded members are forecast under too: the master's laws
#: (flexlift.live.master runs the coordinated mode's)
ADVICE_MODE = "coordinated"


@dataclass(frozen=True)
class Settings:
    """How the estimator runs: ``members`` of the ensemble, the assimilation ``window_s``
    [s], a forecast every ``forecast_every_s`` [s] of lift time (0: none), the ``seed``, the
    detector's ``false_alarms_per_hour``."""

    members: int = 16
    window_s: float = 2.0
    forecast_every_s: float = 120.0
    seed: int = 0
    false_alarms_per_hour: float = 1e-3

    def check(self) -> None:
        if self.members < 2:
            raise InputError("--members", self.members, "at least 2 members")
        if not (math.isfinite(self.window_s) and self.window_s > 0):
            raise InputError("--window", self.window_s, "a positive time [s]")
        if not (math.isfinite(self.forecast_every_s) and self.forecast_every_s >= 0):
            raise InputError("--forecast-every", self.forecast_every_s,
                             "a time [s] >= 0 (0: no forecasts)")
        if not (math.isfinite(self.false_alarms_per_hour) and self.false_alarms_per_hour > 0):
            raise InputError("--false-alarms", self.false_alarms_per_hour,
                             "a positive rate [1/h]")


class Watch:
    """The estimator, the detector and the forecasts of one lift of ``scenario``, fed one
    reading at a time (:meth:`add`) and flushed at the end (:meth:`flush`).

    Attributes
    ----------
    history : list of (float, dict)
        Each window's end [s] and :meth:`Estimator.state` there.
    forecasts : list of dict
        :func:`~flexlift.estimate.forecast.forecast` at every ``forecast_every_s``.
    alarms : list of Alarm
        Every alarm raised, in order.
    late : int
        Readings that came after their window was taken.
    """

    def __init__(self, scenario, settings: Settings, plant=None, progress=None,
                 control: str | None = None, command_delay_s: float | None = None):
        settings.check()
        if plant is None:
            from flexlift.ascent.plant import coupled_plant

            plant = coupled_plant(scenario)  # the one plant: the sensors' and every member's
        self.settings, self.progress = settings, progress
        self.est = Estimator(scenario, sensors_of(scenario, plant.names, for_log=True),
                             settings.members, settings.seed, plant=plant, control=control)
        self.names = list(self.est.names)
        self.detector = Detector(self.est.sensors, self.names, settings.false_alarms_per_hour)
        self.window = window_steps(scenario, settings.window_s)
        self.horizon = max((s.latency_s for s in self.est.sensors), default=0.0)
        self.length = float(scenario.simulation.run_length_s)
        self.t_end, self.buffer, self.late = self.window, [], 0
        self.history, self.forecasts, self.alarms = [], [], []
        self.next_forecast = settings.forecast_every_s or math.inf
        self.commands: list[tuple[float, str, str, float]] = []  # not yet applied
        # commanded members: a valve's feedback is judged against its command by live's own
        # not_obeyed alarm; against members set at the command's send time it would flag the
        # command's travel time as a fault (the feedback goes to the detector unpredicted)
        self.valve_sensors = ({s.name for s in self.est.sensors
                               if s.quantity in ("fill_flow", "purge")}
                              if self.est.valves else set())
        self.latest = -math.inf  # the latest reading's time [s]
        #: a command sent reaches its valve within this [s] (default a control period: the
        #: rig's next chunk, a valve's next cycle)
        self.delay_s = (1.0 / scenario.control.sample_rate_Hz if command_delay_s is None
                        else float(command_delay_s))

    @property
    def known(self) -> set[str]:
        """The sensors' names (``<bag>/<quantity>``) this lift has."""
        return {s.name for s in self.est.sensors}

    def add(self, reading) -> list:
        """Take ``reading`` (:class:`flexlift.sensors.log.Reading`); the windows it completes
        are taken. Returns the alarms raised."""
        before = len(self.alarms)
        if reading.time_s <= self.t_end - self.window and self.history:  # window taken
            self.late += 1
            self.est.counts.late = self.late
            self.alarms.extend(self.detector.update(reading, None, None))
            return self.alarms[before:]
        while reading.time_s > self.t_end + self.horizon + 1e-9 and self.t_end < self.length:
            self._take()
        self.buffer.append(reading)
        self.latest = max(self.latest, reading.time_s)
        return self.alarms[before:]

    def command(self, time_s: float, bag: str, valve: str, value: float) -> None:
        """A valve command sent at ``time_s`` [s] (``valve`` fill [m^3/s at the bag's
        pressure, as the loop's controllers give it] or purge [-]): commanded members take it
        at its time, when their window is taken."""
        self.commands.append((time_s, bag, valve, value))

    def flush(self) -> list:
        """Take the windows still holding readings (the stream has ended); the alarms
        raised."""
        before = len(self.alarms)
        while self.buffer and self.t_end < self.length + self.window:
            self._take()
        return self.alarms[before:]

    def _take(self) -> None:
        t, est, detector = self.t_end, self.est, self.detector
        self._commanded(t)
        for p in est.assimilate(t, self.buffer):
            if p.sensor in self.valve_sensors or est.lost:
                self.alarms.extend(detector.update(_reading(p), None, None))
            else:
                self.alarms.extend(detector.update(_reading(p), p.mean, p.std))
        # silence is judged up to the latest reading, not past the stream's end
        self.alarms.extend(detector.tick(min(t, self.latest)))
        self.history.append((t, est.state()))
        if t >= self.next_forecast:
            f = forecast(est)
            if est.valves:  # commanded: also under the controller's advice, from now
                f["advice"] = forecast(est, ADVICE_MODE)
            self.forecasts.append(f)
            self.next_forecast += self.settings.forecast_every_s
        if self.progress is not None:
            self.progress(min(t / self.length, 1.0))
        self.buffer = [r for r in self.buffer if r.time_s > t]
        self.t_end += self.window


    def _commanded(self, t: float) -> None:
        """The commands sent up to ``t`` [s], each applied with the members advanced to its
        time (a command before the members' time acts from their time: it came late)."""
        due = sorted(c for c in self.commands if c[0] <= t)
        self.commands = [c for c in self.commands if c[0] > t]
        ens = self.est.ensemble
        for time_s, bag, valve, value in due:
            ens.advance(max(int(round(time_s / ens.dt)) + 1, ens.step))
            self.est.command(bag, valve, value, free_air=False, delay_s=self.delay_s)


def _reading(p):
    from flexlift.sensors.log import Reading

    return Reading(p.time_s, p.sensor, p.value)
