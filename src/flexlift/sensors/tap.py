"""The readings of a running simulation: the loop stepped chunk by chunk, its new rows read
between chunks (docs/reference/sensor-log.md#simulate).

:class:`SensorTap` is attached to an :class:`flexlift.ascent.loop.Ascent`; after each chunk
:meth:`SensorTap.take` turns the rows the loop recorded since the last call into readings
(:func:`flexlift.sensors.truth.true_values`, :class:`flexlift.sensors.model.SensorModel`)
and returns those delivered by the run's time. :func:`run_with_log` runs a whole ascent so and
appends its readings to a log (``flexlift simulate --sensor-log``).
"""

from __future__ import annotations

import math

from flexlift.errors import InputError
from flexlift.sensors.config import Sensor, sensors_of
from flexlift.sensors.log import LogWriter, Reading
from flexlift.sensors.model import SensorModel, sensor_faults
from flexlift.sensors.truth import true_values


def check_rates(scenario, sensors: list[Sensor]) -> None:
    """InputError for a sensor faster than the loop's recorded rows
    (``simulation.output_interval_s``): its readings would be interpolated, not sampled."""
    row = scenario.simulation.output_interval_s
    for s in sensors:
        if s.period_s < row - 1e-9:
            raise InputError(f"sensors.{s.quantity}.rate_Hz", s.rate_Hz,
                             f"at most 1 / simulation.output_interval_s = {1 / row:g} Hz "
                             "(readings are sampled from the recorded rows: shorten "
                             "simulation.output_interval_s)")


class SensorTap:
    """The sensors of a run (``run``: an :class:`~flexlift.ascent.loop.Ascent` not yet
    started), read between its chunks.

    Parameters
    ----------
    run : Ascent
    sensors : list of Sensor, optional
        Default: the scenario's (:func:`flexlift.sensors.config.sensors_of`, ``for_log``).
    """

    def __init__(self, run, sensors: list[Sensor] | None = None):
        scenario = run.scenario
        self.run = run
        self.sensors = (sensors_of(scenario, run.plant.names, for_log=True)
                        if sensors is None else sensors)
        check_rates(scenario, self.sensors)
        seed = scenario.sensors.seed if scenario.sensors is not None else 0
        self.model = SensorModel(self.sensors, seed)
        self._row = 0

    def take(self, final: bool = False) -> list[Reading]:
        """Readings of the rows recorded since the last call, delivered by the run's current
        time (every one left when ``final``)."""
        run = self.run
        rec, cl = run.recorder, run.clusters
        r1 = int(rec.counts[0])
        if r1 > self._row:
            values = true_values(self.sensors, run.plant.names, cl.of_bag, run.records.bags,
                                 rec, self._row, r1, run.switches.supply)
            t = rec.t[self._row:r1]
            faults = sensor_faults(self.sensors, run.plant.names, cl.of_bag, run.switches,
                                   float(t[0]))
            self.model.add_rows(t.copy(), values, faults)
            self._row = r1
        now = math.inf if final else float(run.state.counters[0]) * run.settings.dt
        return self.model.delivered(now)


def run_with_log(run, path, progress=None, summary_only: bool = False):
    """Run ``run`` (an :class:`~flexlift.ascent.loop.Ascent`) to its end as
    :meth:`~flexlift.ascent.loop.Ascent.run` does, appending its sensors' readings to the log
    ``path`` after every chunk; returns ``(result, readings written)``. The readings are
    those of the whole run, also when the numerics fail (the result's error is raised after
    the log is complete)."""
    with LogWriter(path) as writer:
        tap = SensorTap(run)
        run.start(progress)
        written = 0
        while (k_stop := run.next_stop()) is not None:
            code = run._advance(k_stop)
            ended = run.after_chunk(code)
            written += writer.write(tap.take())
            if ended:
                break
        written += writer.write(tap.take(final=True))
    return run.finish(summary_only), written
