"""``flexlift replay``: the estimator and the fault detector over a recorded sensor log
(docs/guide/replay.md).

The log is streamed (:class:`flexlift.sensors.log.LogReader`: bounded memory, every bad line
counted by its reason) into a :class:`flexlift.estimate.watch.Watch`, which takes the
readings window by window (its docstring says how, and what a late reading is).
"""

from __future__ import annotations

import time
from dataclasses import asdict

import numpy as np

from flexlift.errors import InputError
from flexlift.estimate.watch import Settings, Watch
from flexlift.sensors.log import LogReader

__all__ = ["Settings", "replay"]

#: the estimated quantities given per bag (the others are the hull's or the lift's)
PER_BAG = ("height", "gas_volume", "leak")


def replay(log_path, scenario, settings: Settings, progress=None) -> dict:
    """The estimator over the log ``log_path`` of a lift of ``scenario``; returns
    ``{"summary": ..., "history": [(time, Estimator.state()), ...], "names": bags}`` (what
    :func:`flexlift.output.replay.write_replay` writes)."""
    wall = time.perf_counter()
    watch = Watch(scenario, settings, progress=progress)
    reader = LogReader(log_path, known=watch.known)
    for reading in reader:
        watch.add(reading)
    watch.flush()
    history, names, est = watch.history, watch.names, watch.est
    if not history:
        raise InputError("LOG", str(log_path), "holds no reading of this scenario's sensors "
                         f"({reader.report.text()})")
    seconds = time.perf_counter() - wall
    lift = history[-1][0]
    summary = {
        "scenario": scenario.name, "log": str(log_path), "settings": asdict(settings),
        "lift_time_s": round(lift, 3), "wall_time_s": round(seconds, 3),
        "speed_x_real_time": round(lift / max(seconds, 1e-9), 1),
        "alarms": [a.to_dict() for a in watch.alarms],
        "forecasts": watch.forecasts,
        "estimate": final(history[-1][1], names),
        "filter": asdict(est.counts),
        "log_report": reader.report.to_dict(),
        "sensors_never_heard": list(watch.detector.never_heard),
    }
    return {"summary": summary, "history": history, "names": names}


def final(state: dict, names) -> dict:
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
