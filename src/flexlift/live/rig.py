"""``flexlift rig``: a stand-in for the lift (docs/reference/live.md#the-rig). The plant of
the scenario, simulated by the compiled loop in commanded mode
(:meth:`flexlift.ascent.loop.Ascent.command`), in real time or ``speed`` times faster: each
sensor of the scenario's ``sensors:`` section published at its rate with its noise, latency
and dropouts (:class:`flexlift.sensors.tap.SensorTap`: the sensors of ``flexlift simulate
--sensor-log``), the valve commands received obeyed (a valve with no
new command stays where it is), the scenario's faults run as the simulation runs them, and
said to no one.

The loop advances one control period of the scenario per chunk; between chunks it applies
the commands received (each valve's highest sequence number so far: a repeat, or an older
command arriving late, is dropped and counted), takes the sensors' readings due, publishes
those whose latency has passed, and sleeps until the wall clock has caught up. When it falls
behind (the machine too slow for ``speed``) it runs on without sleeping and counts the lag.
"""

from __future__ import annotations

import math
import time

from flexlift.ascent.loop import prepare
from flexlift.live.messages import Tally, parse_command, reading_payload, sensor_topic
from flexlift.live.mqtt import QOS_READING


class Rig:
    """The rig of ``scenario`` for lift ``lift`` over ``link``
    (:class:`~flexlift.live.mqtt.Link`, subscribed to :meth:`command_topics`)."""

    def __init__(self, scenario, link, lift: str, speed: float = 1.0,
                 duration: float | None = None):
        from flexlift.sensors.tap import SensorTap

        self.scenario, self.link, self.lift, self.speed = scenario, link, lift, float(speed)
        self.ascent = prepare(scenario, "commanded", duration)
        self.names = list(self.ascent.plant.names)
        self.index = {self.ascent.plant.names[i]: j for j, i in enumerate(self.ascent.controllers.bags)}
        self.tap = SensorTap(self.ascent)
        self.tally = Tally()
        self.last_seq: dict[tuple[str, str], int] = {}
        self.applied = self.repeats = 0
        self.lag_s = 0.0
        self.published = 0
        self.result = None

    def command_topics(self) -> str:
        """The topics the rig subscribes to."""
        return f"flexlift/{self.lift}/command/#"

    def periods(self) -> dict:
        """Each sensor's period [s], by name."""
        return {s.name: s.period_s for s in self.tap.sensors}

    def obey(self) -> None:
        """Apply the commands received since the last call (newest sequence number only)."""
        for _, topic, payload in self.link.drain():
            command = parse_command(topic, payload, self.lift, self.index, self.tally)
            if command is None:
                continue
            key = (command.bag, command.valve)
            if command.seq <= self.last_seq.get(key, -1):
                self.repeats += 1
                continue
            self.last_seq[key] = command.seq
            j = self.index[command.bag]
            if command.valve == "fill":
                self.ascent.command(j, fill=command.value)
            else:
                self.ascent.command(j, opening=command.value)
            self.applied += 1

    def _publish_due(self) -> None:
        """Publish the readings delivered by now (taken, and their latency passed)."""
        for reading in self.tap.take():
            source, _, quantity = reading.sensor.rpartition("/")
            self.link.publish(sensor_topic(self.lift, source, quantity),
                              reading_payload(reading.time_s, reading.value), QOS_READING)
            self.published += 1

    def run_loop(self, stop, wall_limit: float = math.inf, ended=None) -> None:
        """Step the plant until its run ends, ``stop`` is set or ``wall_limit`` [s] passes;
        then set ``ended`` (a :class:`threading.Event`, or None) at once, before the run's
        result is made: no reading will come again, and live, told so within its
        sensors' silence, ends on the readings sent (docs/reference/live.md: Ending)."""
        run, settings = self.ascent, self.ascent.settings
        run.start()
        k_period = settings.k_ctrl
        start = time.monotonic()
        while not stop.is_set() and time.monotonic() - start < wall_limit:
            self.obey()
            k, k_next = int(run.state.counters[0]), run.next_stop()
            if k_next is None:
                break
            k_stop = min(k_next, k - k % k_period + k_period)
            if run.after_chunk(run._advance(k_stop)):
                break
            t = (int(run.state.counters[0]) - 1) * settings.dt
            self._publish_due()
            ahead = t / self.speed - (time.monotonic() - start)
            if ahead > 0:
                stop.wait(ahead)
            else:
                self.lag_s = max(self.lag_s, -ahead)
        if ended is not None:
            ended.set()
        self.result = run.finish(summary_only=True)

    def run(self, stop, wall_limit: float = math.inf, ended=None) -> None:
        """The rig's thread: :meth:`run_loop`."""
        self.run_loop(stop, wall_limit, ended)
