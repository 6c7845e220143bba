"""``flexlift live``: read every sensor, run the master controller (or advise), raise alarms,
log everything, and end on arrival, at a time, or on SIGINT (docs/reference/live.md).

One thread does the work, once per control period of the lift's clock
(:class:`~flexlift.live.board.Board`): the messages received since the last period (paho's
network thread queues them), the controller's sample, the commands that changed, the alarms,
the log's commit. A flood only lengthens the queue read each period: the period holds while
the messages of one period are read within it (benchmarks/live.py).

Stale readings (a depth or sling force of a controlled bag silent past twice its period, as
when the rig or the network is gone): every fill valve is commanded shut, the purge valves
are held where they are, and it is said; control resumes when the readings come back. A rig
run in this process that has said it ended (``source_ended``) is not a network gone silent:
its last readings are judged at the moment live was told (:meth:`Live._last`).
"""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from typing import NamedTuple

from flexlift.live.alarms import Alarms
from flexlift.live.board import Board
from flexlift.live.master import Master
from flexlift.live.messages import (
    Command,
    Tally,
    command_payload,
    command_topic,
    parse_reading,
)
from flexlift.live.mqtt import QOS_COMMAND

#: a command is sent when it differs from the last sent by this: fill as a fraction of the
#: largest fill, and opening [-]
SEND_FILL_FRACTION, SEND_OPENING = 0.01, 0.01
#: the longest sleep of the loop [s of wall time] (messages are read at least this often)
MAX_SLEEP_S = 0.05
#: the rig run in this process has ended: the readings still on their way are read until
#: none has come for this long of wall time [s]
LAST_READINGS_S = 0.5
#: the rig has ended: the readings still on their way are read until none has come for
#: :data:`LAST_READINGS_S`, for at most this [s of wall time] (a loaded broker may hold
#: the last seconds of a fast rig for longer than one wait)
LAST_READINGS_MAX_S = 10.0


class Outcome(NamedTuple):
    """How a live run ended and what it saw."""

    reason: str  # arrived, time, interrupted, no_readings, rig_ended
    t_end: float  # lift time at the end [s]
    arrived_s: float | None
    max_speed: float  # largest upward speed of a bag seen [m/s]
    max_pitch: float  # largest |pitch| of the hull seen [rad]
    readings: int
    late: int
    dropped: dict
    commands: int
    alarms: list
    stale_periods: int


class Live:
    """One live run of ``scenario`` over ``link`` (:class:`~flexlift.live.mqtt.Link`),
    logging to ``log`` (:class:`~flexlift.live.log.LiveLog`); ``control``: master or
    advise; ``say``: a function taking a line for the operator."""

    def __init__(self, scenario, link, log, lift: str, control: str = "master",
                 say=print, rate: float | None = None, periods: dict | None = None,
                 master: Master | None = None):
        self.scenario, self.link, self.log, self.lift = scenario, link, log, lift
        self.control, self.say = control, say
        self.master = master or Master(scenario)
        self.names = set(self.master.plant.names)
        self.board = Board(self.master.plant.names, periods, rate)
        self.alarms = Alarms(scenario.limits, float(self.master.plant.records.bags.water_depth),
                             float(self.master.controllers.fill_max))
        self.tally = Tally()
        self.sent: dict[str, tuple[float, float]] = {}
        self.seq = int(time.time() * 1000)  # grows across restarts of live
        self.commands = 0
        self.stale = False
        self.stale_periods = 0
        self.arrived_s: float | None = None
        self._source_ended = False  # the run ended because the rig said it had ended
        self.max_speed, self.max_pitch = 0.0, 0.0
        self._offset = time.time() - time.monotonic()  # monotonic -> POSIX
        self._range: dict[str, str] = {}
        self.dashboard = None  # a started flexlift.live.dashboard.Dashboard, or None
        self.first_depth: dict[str, float] = {}  # each bag's first depth read (live/view.py)
        self.estimate = None  # a started flexlift.live.estimate.LiveEstimate, or None

    def read(self) -> None:
        """Take every message received since the last call."""
        for wall, topic, payload in self.link.drain():
            recv = wall + self._offset
            before = self.tally.total
            reading = parse_reading(topic, payload, self.lift, self.names, self.tally,
                                    epoch=self.epoch)
            if reading is None:
                if self.tally.total > before:
                    self.log.dropped(recv, self.tally.last[-1][0], topic)
                continue
            late = self.board.add(reading, wall)
            self.log.reading(recv, reading, late)
            if self.estimate is not None:
                self.estimate.put(reading.time, reading.sensor, reading.value)
            why = self.alarms.reading(reading)
            if why is not None:
                self._range[reading.sensor] = why
            if reading.quantity == "pitch" and reading.source == "hull" and not late:
                self.max_pitch = max(self.max_pitch, abs(reading.value))

    def _send(self, t: float, bag: str, valve: str, value: float) -> None:
        self.seq += 1
        command = Command(self.seq, t, bag, valve, value)
        sent = self.control == "master"
        if sent:
            self.link.publish(command_topic(self.lift, bag, valve),
                              command_payload(self.seq, t, value), qos=QOS_COMMAND)
        self.log.command(time.time(), command, sent)
        if sent and self.estimate is not None:  # the lift's clock is at least its latest reading's
            self.estimate.put_command(max(t, self.board.t_max), bag, valve, value)
        self.commands += 1
        self.alarms.command_changed(bag, "fill_flow" if valve == "fill" else "purge")

    def command(self, t: float, wanted: dict) -> None:
        """Send (or, advising, log) each valve set-point that changed enough."""
        fill_tol = SEND_FILL_FRACTION * float(self.master.controllers.fill_max)
        for bag, (fill, opening) in wanted.items():
            old = self.sent.get(bag)
            if old is None or abs(fill - old[0]) > fill_tol or (fill == 0.0 < old[0]):
                self._send(t, bag, "fill", fill)
                old = (fill, old[1] if old else math.nan)
            if math.isnan(old[1]) or abs(opening - old[1]) > SEND_OPENING or (
                    opening == 0.0 < old[1]):
                self._send(t, bag, "purge", opening)
                old = (old[0], opening)
            self.sent[bag] = old

    def _required_silent(self, silent: list[str]) -> list[str]:
        need = {f"{b}/{q}" for b in self.master.bags for q in ("depth", "sling_force")}
        return [s for s in silent if s in need]

    def _stale(self, t: float, silent: list[str]) -> bool:
        """Stop filling when the controller's readings go stale; say when they come back."""
        gone = self._required_silent(silent)
        if gone and not self.stale:
            self.stale = True
            self.say(f"t = {t:.1f} s: readings stale ({', '.join(gone[:4])}"
                     f"{', ...' if len(gone) > 4 else ''}): filling stopped, valves held")
            self.command(t, {b: (0.0, self.sent.get(b, (0.0, 0.0))[1]) for b in self.master.bags})
        elif not gone and self.stale:
            self.stale = False
            self.say(f"t = {t:.1f} s: readings back: control resumed")
        self.stale_periods += self.stale
        return self.stale

    def period(self, t: float, wall: float) -> None:
        """One control period at lift time ``t``."""
        self.log.period(time.time(), t)
        silent = self.board.silent(wall)
        if not self._stale(t, silent):
            wanted = self.master.step(t, self.board)
            if wanted is not None:
                self.command(t, wanted)
        for bag in self.board.bags:
            v = self.board.speed(bag)
            if v is not None:
                self.max_speed = max(self.max_speed, v)
        for t_a, kind, source, text in self.alarms.check(t, self.board, self.sent, silent,
                                                         self._range):
            self.log.alarm(time.time(), t_a, kind, source, text)
            self.say(f"t = {t_a:.1f} s: ALARM {kind} {source}: {text}")
        self._range = {}
        if self.estimate is not None:
            self._estimated()
        if self.dashboard is not None:
            from flexlift.live.view import snapshot_of

            self.dashboard.publish(snapshot_of(self, t))
        self.log.tick()

    def _estimated(self) -> None:
        """The estimator's alarms raised since the last period: logged (kind, bag, the
        message with its confidence and the advice) and said."""
        for a in self.estimate.new_alarms():
            text = f"{a.message} (confidence {a.confidence:.2f}); {a.advice}"
            self.log.alarm(time.time(), a.time_s, f"estimator:{a.kind}", a.bag, text)
            self.say(f"t = {a.time_s:.1f} s: ESTIMATOR {a.kind} {a.bag}: {text}")

    def arrived(self) -> bool:
        """Every controlled bag within the arrival tolerance of the target."""
        c, lim = self.scenario.control, self.scenario.limits
        z = self.master.heights()
        return bool(z) and all(abs(h - c.target_height_m) <= lim.arrival_tolerance_m
                               for h in z.values()) and not self.stale

    def run(self, until, stop: threading.Event, epoch: float | None = None,
            wall_limit: float = math.inf,
            source_ended: threading.Event | None = None) -> Outcome:
        """Run until ``until`` ("arrived" or a lift time [s]), ``stop`` is set,
        ``wall_limit`` [s of wall time] passes or ``source_ended`` is set (the rig run in
        this process has ended: ``rig_ended``, after the readings still queued are read);
        then commit the log."""
        self.epoch = epoch if epoch is not None else time.time()
        self._source_ended = False
        start = time.monotonic()
        try:
            reason = self._loop(until, stop, start, wall_limit, source_ended)
        except KeyboardInterrupt:  # SIGINT: end here, cleanly
            reason = "interrupted"
        self.log.commit()
        # (the rig ended: the lift's clock stopped with its last reading)
        t_end = self.board.t_max if self._source_ended else self.board.now(time.monotonic())
        return Outcome(reason, t_end, self.arrived_s,
                       self.max_speed, self.max_pitch, self.board.count, self.board.late,
                       dict(Counter(self.tally.counts)), self.commands,
                       list(self.alarms.raised), self.stale_periods)

    def _last(self, until, stop, wall_end: float) -> str:
        """The rig has ended (live saw it at ``wall_end``, monotonic [s]): the readings
        still on their way read (until none has come for :data:`LAST_READINGS_S`, at most
        :data:`LAST_READINGS_MAX_S`), a last period at the last reading's time, and the
        reason: ``arrived`` if every bag then is at the target and arrival was awaited, else
        ``rig_ended``.

        The last period judges the sensors' silence at ``wall_end``, not after the wait: a
        rig that has said it ended is no network gone silent, so the readings it sent up to
        its end are not stale for having stopped since; a sensor already silent at the end
        (its node, or the broker, gone before the rig ended) is, and then the lift is not
        taken as arrived."""
        deadline, count = time.monotonic() + LAST_READINGS_MAX_S, -1
        while self.board.count != count and time.monotonic() < deadline:
            count = self.board.count
            if stop.wait(LAST_READINGS_S):
                break
            self.read()
        t = self.board.t_max  # the last reading's time: the lift's clock stopped with the rig
        if math.isfinite(t):
            self.period(t, wall_end)
            if until == "arrived" and self.arrived():
                self.arrived_s = t
                return "arrived"
        return "rig_ended"

    def _loop(self, until, stop, start: float, wall_limit: float,
              source_ended: threading.Event | None = None) -> str:
        t_next, reason = -math.inf, "interrupted"
        while not stop.is_set():
            wall = time.monotonic()
            if wall - start > wall_limit:
                reason = "time" if self.board.count else "no_readings"
                break
            if source_ended is not None and source_ended.is_set():
                self._source_ended = True
                return self._last(until, stop, wall)
            self.read()
            t = self.board.now(time.monotonic())
            if math.isfinite(t) and t >= t_next:
                self.period(t, time.monotonic())
                t_next = max(t_next + self.master.period, t) if math.isfinite(t_next) else t
                if until == "arrived" and self.arrived():
                    self.arrived_s, reason = t, "arrived"
                    break
                if until != "arrived" and t >= float(until):
                    reason = "time"
                    break
            gap = (t_next - t) / self.board.rate if math.isfinite(t) else MAX_SLEEP_S
            stop.wait(min(max(gap, 0.0), MAX_SLEEP_S))
        return reason
