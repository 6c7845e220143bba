"""The lift's messages on the network (docs/reference/messages.md): topics, payloads, parsing.

Readings: topic ``flexlift/<lift>/sensor/<bag or hull>/<quantity>``, payload JSON
``{"time": ..., "value": ...}``; ``time`` ISO 8601 UTC or seconds since filling began,
``value`` in SI units (:data:`QUANTITIES`). Commands: topic
``flexlift/<lift>/command/<bag>/fill|purge``, payload ``{"seq": ..., "time": ..., "value":
...}``: a sequence number (an integer growing with every command the controller sends), the
controller's time [s since filling began] and the set-point (fill: the gas flow into the bag at its own pressure [m^3/s], as
the loop's controllers give it; purge: valve opening [-]).

Parsing never raises: a message that is not a reading or a command of this lift is counted
by its reason (:class:`Tally`) and dropped.
"""

from __future__ import annotations

import json
import math
import re
from collections import Counter
from datetime import datetime, timedelta
from typing import NamedTuple

from flexlift.scenario.sensors import HULL_QUANTITIES
from flexlift.scenario.sensors import QUANTITIES as SENSOR_QUANTITIES

#: the lowest and highest value each quantity can plausibly read (SI; noise included)
RANGES = {"depth": (0.0, 12_000.0), "pitch": (-math.pi / 2, math.pi / 2),
          "sling_force": (-1e5, 1e9), "fill_flow": (-0.1, 100.0), "purge": (-0.1, 1.1),
          "supply_pressure": (0.0, 1e8)}
#: quantity: (unit, where it is measured: "bag" or "both" (bags and the hull), lowest and
#: highest plausible value); the quantities and units are the sensors' own
#: (:data:`flexlift.scenario.sensors.QUANTITIES`)
QUANTITIES = {q: (unit, "both" if q in HULL_QUANTITIES else "bag", *RANGES[q])
              for q, (unit, _) in SENSOR_QUANTITIES.items()}
#: the source name of the hull's own sensors
HULL = "hull"
#: the two valves a command moves
VALVES = ("fill", "purge")
#: why a message was dropped
REASONS = ("topic", "not_json", "not_object", "missing_field", "wrong_type", "not_finite",
           "bad_time", "unknown_bag", "unknown_quantity", "hull_quantity", "bad_value")
#: the largest payload read [bytes]: a longer one is dropped unread (as ``bad_value``)
MAX_PAYLOAD = 4096


class Reading(NamedTuple):
    """One sensor reading: ``time`` [s since filling began], ``source`` (a bag's name or
    ``hull``), ``quantity``, ``value`` (SI)."""

    time: float
    source: str
    quantity: str
    value: float

    @property
    def sensor(self) -> str:
        """The sensor's name in the sensor log, ``<bag>/<quantity>``."""
        return f"{self.source}/{self.quantity}"


class Command(NamedTuple):
    """One valve command: ``seq`` (its number), ``time`` [s], ``bag``, ``valve`` (fill or
    purge), ``value`` (fill [m^3/s at the bag's pressure]; purge opening [-])."""

    seq: int
    time: float
    bag: str
    valve: str
    value: float


class Tally:
    """Malformed messages counted by reason (:data:`REASONS`), with the last few kept."""

    def __init__(self, keep: int = 20):
        self.counts: Counter = Counter()
        self.last: list[tuple[str, str]] = []
        self._keep = keep

    def drop(self, reason: str, topic: str) -> None:
        """Count one message dropped for ``reason``."""
        self.counts[reason] += 1
        self.last = (self.last + [(reason, topic[:200])])[-self._keep:]

    @property
    def total(self) -> int:
        """Messages dropped so far."""
        return sum(self.counts.values())


def sensor_topic(lift: str, source: str, quantity: str) -> str:
    """The topic of a reading."""
    return f"flexlift/{lift}/sensor/{source}/{quantity}"


def command_topic(lift: str, bag: str, valve: str) -> str:
    """The topic of a valve command."""
    return f"flexlift/{lift}/command/{bag}/{valve}"


def reading_payload(time: float, value: float) -> bytes:
    """The payload of a reading at ``time`` [s since filling began]."""
    return json.dumps({"time": round(float(time), 6), "value": float(value)}).encode()


def command_payload(seq: int, time: float, value: float) -> bytes:
    """The payload of a command."""
    return json.dumps({"seq": int(seq), "time": round(float(time), 6),
                       "value": float(value)}).encode()


def parse_time(raw, epoch: float | None) -> float | None:
    """Seconds since filling began from a number, or from an ISO 8601 UTC string with
    ``epoch`` the POSIX time [s] filling began; None if neither."""
    if isinstance(raw, bool):
        return None
    if isinstance(raw, (int, float)):
        return float(raw) if math.isfinite(raw) else None
    if not isinstance(raw, str) or epoch is None or len(raw) > 40:
        return None
    try:
        when = datetime.fromisoformat(raw.replace("Z", "+00:00"))
    except ValueError:
        return None
    if when.tzinfo is None or when.utcoffset() != timedelta(0):
        return None  # UTC only
    return when.timestamp() - epoch


def _payload(payload: bytes, topic: str, tally: Tally, fields: tuple[str, ...]):
    """The payload as a dict holding ``fields``, or None (counted)."""
    if len(payload) > MAX_PAYLOAD:
        tally.drop("bad_value", topic)
        return None
    try:
        data = json.loads(payload)
    except (ValueError, UnicodeDecodeError, RecursionError):
        tally.drop("not_json", topic)
        return None
    if not isinstance(data, dict):
        tally.drop("not_object", topic)
        return None
    if any(f not in data for f in fields):
        tally.drop("missing_field", topic)
        return None
    return data


def _number(raw, topic: str, tally: Tally) -> float | None:
    """A finite number, or None (counted: a wrong type, or NaN / infinite)."""
    if isinstance(raw, bool) or not isinstance(raw, (int, float)):
        tally.drop("wrong_type", topic)
        return None
    if not math.isfinite(raw):
        tally.drop("not_finite", topic)
        return None
    return float(raw)


def parse_reading(topic: str, payload: bytes, lift: str, bags, tally: Tally,
                  epoch: float | None = None) -> Reading | None:
    """The reading of a message of lift ``lift`` whose bags are ``bags`` (names), or None
    with its reason counted in ``tally``; never raises. JSON's ``NaN`` and ``Infinity``
    count as ``not_finite``."""
    parts = topic.split("/")
    if len(parts) != 5 or parts[0] != "flexlift" or parts[1] != lift or parts[2] != "sensor":
        tally.drop("topic", topic)
        return None
    source, quantity = parts[3], parts[4]
    if quantity not in QUANTITIES:
        tally.drop("unknown_quantity", topic)
        return None
    if source != HULL and source not in bags:
        tally.drop("unknown_bag", topic)
        return None
    if source == HULL and QUANTITIES[quantity][1] == "bag":
        tally.drop("hull_quantity", topic)
        return None
    data = _payload(payload, topic, tally, ("time", "value"))
    if data is None:
        return None
    value = _number(data["value"], topic, tally)
    if value is None:
        return None
    t = parse_time(data["time"], epoch)
    if t is None:
        tally.drop("bad_time", topic)
        return None
    return Reading(t, source, quantity, value)


def parse_command(topic: str, payload: bytes, lift: str, bags, tally: Tally) -> Command | None:
    """The command of a message, or None with its reason counted; never raises. A fill
    must be >= 0, an opening in [0, 1]."""
    parts = topic.split("/")
    if (len(parts) != 5 or parts[0] != "flexlift" or parts[1] != lift
            or parts[2] != "command" or parts[4] not in VALVES):
        tally.drop("topic", topic)
        return None
    if parts[3] not in bags:
        tally.drop("unknown_bag", topic)
        return None
    data = _payload(payload, topic, tally, ("seq", "time", "value"))
    if data is None:
        return None
    seq = data["seq"]
    if isinstance(seq, bool) or not isinstance(seq, int):
        tally.drop("wrong_type", topic)
        return None
    t, value = _number(data["time"], topic, tally), None
    if t is not None:
        value = _number(data["value"], topic, tally)
    if value is None:
        return None
    if value < 0 or (parts[4] == "purge" and value > 1):
        tally.drop("bad_value", topic)
        return None
    return Command(seq, t, parts[3], parts[4], value)


def lift_name(name: str) -> str:
    """A lift's name as one topic level: letters, digits, ``_ . -`` (others become ``_``)."""
    return re.sub(r"[^A-Za-z0-9_.-]", "_", name)[:64] or "lift"
