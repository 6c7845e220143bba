"""``flexlift replay``: the estimator and the fault detector over a recorded sensor log
(docs/guide/replay.md).

The log is streamed (:class:`flexlift.sensors.log.LogReader`: bounded memory, every bad line
counted by its reason). Readings are gathered into windows of their own times; a window is
taken once a reading later than its end plus the sensors' largest latency has been read (so
every reading of it has arrived), then the members advance to its end and are updated
(:meth:`flexlift.estimate.filter.Estimator.assimilate`), every reading goes with its
prediction to the detector (:class:`flexlift.estimate.detect.Detector`), and at every
``forecast_every_s`` the members are run on to the end (:func:`flexlift.estimate.forecast.
forecast`). A reading that arrives after its window was taken is *late*: counted, given to
the detector without a prediction, not assimilated.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass

import numpy as np

from flexlift.errors import InputError
from flexlift.estimate.detect import Detector
from flexlift.estimate.filter import Estimator, window_steps
from flexlift.estimate.forecast import forecast
from flexlift.sensors.config import sensors_of
from flexlift.sensors.log import LogReader

#: the estimated quantities given per bag (the others are the hull's or the lift's)
PER_BAG = ("height", "gas_volume", "leak")


@dataclass(frozen=True)
class Settings:
    """How the replay runs: ``members`` of the ensemble, the assimilation ``window_s`` [s],
    a forecast every ``forecast_every_s`` [s] of lift time (0: none), the ``seed``, the
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


def replay(log_path, scenario, settings: Settings, progress=None) -> dict:
    """The estimator over the log ``log_path`` of a lift of ``scenario``; returns
    ``{"summary": ..., "history": [(time, Estimator.state()), ...], "names": bags}`` (what
    :func:`flexlift.output.replay.write_replay` writes)."""
    settings.check()
    wall = time.perf_counter()
    from flexlift.ascent.plant import coupled_plant

    plant = coupled_plant(scenario)  # the one plant: the sensors' bags and every member's
    est = Estimator(scenario, sensors_of(scenario, plant.names, for_log=True),
                    settings.members, settings.seed, plant=plant)
    names = list(est.names)
    detector = Detector(est.sensors, names, settings.false_alarms_per_hour)
    reader = LogReader(log_path, known={s.name for s in est.sensors})
    window = window_steps(scenario, settings.window_s)
    horizon = max((s.latency_s for s in est.sensors), default=0.0)
    t_end, buffer, late = window, [], 0
    history, forecasts, alarms = [], [], []
    next_forecast = settings.forecast_every_s or math.inf
    length = float(scenario.simulation.run_length_s)

    def take(t: float) -> None:
        nonlocal next_forecast
        for p in est.assimilate(t, buffer):
            alarms.extend(detector.update(_reading(p), p.mean, p.std))
        alarms.extend(detector.tick(t))
        history.append((t, est.state()))
        if t >= next_forecast:
            forecasts.append(forecast(est))
            next_forecast += settings.forecast_every_s
        if progress is not None:
            progress(min(t / length, 1.0))

    for reading in reader:
        if reading.time_s <= t_end - window and history:  # its window was taken already
            late += 1
            alarms.extend(detector.update(reading, None, None))
            continue
        while reading.time_s > t_end + horizon + 1e-9 and t_end < length:
            take(t_end)
            buffer = [r for r in buffer if r.time_s > t_end]
            t_end += window
        buffer.append(reading)
    while buffer and t_end < length + window:
        take(t_end)
        buffer = [r for r in buffer if r.time_s > t_end]
        t_end += window
    est.counts.late = late
    if not history:
        raise InputError("LOG", str(log_path), "holds no reading of this scenario's sensors "
                         f"({reader.report.text()})")
    seconds = time.perf_counter() - wall
    lift = history[-1][0]
    summary = {
        "scenario": scenario.name, "log": str(log_path), "settings": asdict(settings),
        "lift_time_s": round(lift, 3), "wall_time_s": round(seconds, 3),
        "speed_x_real_time": round(lift / max(seconds, 1e-9), 1),
        "alarms": [a.to_dict() for a in alarms],
        "forecasts": forecasts,
        "estimate": _final(history[-1][1], names),
        "filter": asdict(est.counts),
        "log_report": reader.report.to_dict(),
        "sensors_never_heard": list(detector.never_heard),
    }
    return {"summary": summary, "history": history, "names": names}


def _reading(p):
    from flexlift.sensors.log import Reading

    return Reading(p.time_s, p.sensor, p.value)


def _final(state: dict, names) -> dict:
    """The estimate at the log's end: each quantity's 5, 50 and 95 %, by bag where per
    bag."""
    out = {}
    for name, q in state.items():
        q = np.asarray(q)
        if name in PER_BAG:
            out[name] = {b: [round(float(v), 4) for v in q[:, j]] for j, b in enumerate(names)}
        else:
            out[name] = [round(float(v), 6) for v in q[:, 0]]
    return out
