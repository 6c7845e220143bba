"""The estimator inside ``flexlift live --estimate`` (docs/reference/live.md#the-estimator):
the replay's :class:`~flexlift.estimate.watch.Watch` fed from the lift's network, on its own
thread, so that the control period never waits for the ensemble.

The session hands every reading it parsed to :meth:`LiveEstimate.put` (a bounded queue: a
reading that finds it full is counted as ``dropped_queue_full``, never waited for), and, when the
master controls the lift, every command it sent to :meth:`LiveEstimate.put_command`: the
members are then *commanded* (their valves set as the master's commands set the lift's, at
the commands' times: the later of the command's stamp and the latest reading's time, since
the lift's clock has passed that), not run by a controller of their own that would drift from the
master's. Advising (``--control advise``), the valves are the operator's: the members run the
scenario's controller. The thread takes them
in the order they came, the Watch windows them by their own times (a reading later than its
window is counted late). The session takes the alarms raised since it last asked
(:meth:`LiveEstimate.new_alarms`) every period. When the lift ends, :meth:`stop` lets the
thread read what is queued for at most ``drain_s`` of wall time, then flushes the windows
still holding readings; how far the estimator was behind the lift at the end is said
(``behind_s``).
"""

from __future__ import annotations

import math
import queue
import threading
from dataclasses import asdict

from flexlift.estimate.watch import Settings, Watch
from flexlift.sensors.log import Reading

#: the readings waiting for the estimator, at most
QUEUE_MAX = 200_000
#: a command's travel from the master to its valve, at most [s of wall time] (the network
#: and the threads on both sides); in the lift's time, times the lift's clock rate
COMMAND_LATENCY_S = 0.1
#: the longest wait for a reading before the thread looks at its stop flag [s of wall time]
POLL_S = 0.1


class LiveEstimate:
    """The estimator of ``scenario``'s lift over its live readings (``plant``: the session's
    own, the one plant)."""

    def __init__(self, scenario, settings: Settings, plant=None, commanded: bool = False,
                 rate: float = 1.0):
        from flexlift.ascent.loop import COMMANDED

        # a command's travel: the network's and the threads' latency, in the lift's time
        delay = max(1.0 / scenario.control.sample_rate_Hz, COMMAND_LATENCY_S * rate)
        self.watch = Watch(scenario, settings, plant=plant,
                           control=COMMANDED if commanded else None, command_delay_s=delay)
        self.known = self.watch.known
        self.queue: queue.Queue = queue.Queue(QUEUE_MAX)
        self.dropped = self.unknown = 0
        self.latest_time = -math.inf  # the latest reading's time put [s]
        self._taken = 0  # alarms handed to the session
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self.error: str | None = None
        self._thread = threading.Thread(target=self._work, name="flexlift-estimate",
                                        daemon=True)

    def start(self) -> LiveEstimate:
        self._thread.start()
        return self

    def put(self, time_s: float, sensor: str, value: float) -> None:
        """A reading from the network: queued for the thread (never blocks)."""
        if sensor not in self.known:
            self.unknown += 1
            return
        self.latest_time = max(self.latest_time, time_s)
        self._queue(Reading(time_s, sensor, value))

    def put_command(self, time_s: float, bag: str, valve: str, value: float) -> None:
        """A command the master sent (``valve`` fill [m^3/s at the bag's pressure] or purge
        [-])."""
        self._queue((time_s, bag, valve, value))

    def _queue(self, item) -> None:
        try:
            self.queue.put_nowait(item)
        except queue.Full:
            self.dropped += 1

    def _work(self) -> None:
        try:
            while not self._stop.is_set():
                try:
                    reading = self.queue.get(timeout=POLL_S)
                except queue.Empty:
                    continue
                with self._lock:
                    if isinstance(reading, Reading):
                        self.watch.add(reading)
                    else:
                        self.watch.command(*reading)
        except Exception as error:  # noqa: BLE001 - the lift goes on; the failure is said
            self.error = f"{type(error).__name__}: {error}"

    def new_alarms(self) -> list:
        """The alarms raised since the last call."""
        with self._lock:
            fresh = self.watch.alarms[self._taken:]
            self._taken = len(self.watch.alarms)
        return fresh

    def stop(self, drain_s: float = 30.0) -> None:
        """End the thread after it has read the queue (at most ``drain_s`` of wall time),
        then take the windows still holding readings."""
        deadline = threading.Event()
        timer = threading.Timer(drain_s, deadline.set)
        timer.start()
        while not self.queue.empty() and not deadline.is_set() and self.error is None:
            deadline.wait(POLL_S)
        timer.cancel()
        self._stop.set()
        self._thread.join(POLL_S * 20)
        with self._lock:
            if self.error is None:
                try:
                    self.watch.flush()
                except Exception as error:  # noqa: BLE001
                    self.error = f"{type(error).__name__}: {error}"

    def summary(self) -> dict:
        """What the estimator made of the lift: its alarms and forecasts, the filter's
        counts, the readings it never took (``unread``, queued when the lift ended and the
        drain time ran out), and how far behind the latest reading it stood (``behind_s``)."""
        w = self.watch
        t = w.history[-1][0] if w.history else None
        behind = (None if t is None or not math.isfinite(self.latest_time)
                  else round(max(self.latest_time - t, 0.0), 3))
        return {"settings": asdict(w.settings), "alarms": [a.to_dict() for a in w.alarms],
                "forecasts": w.forecasts, "filter": asdict(w.est.counts),
                "estimated_to_s": t, "behind_s": behind, "unread": self.queue.qsize(),
                "dropped_queue_full": self.dropped, "unknown_sensor": self.unknown,
                "error": self.error}
