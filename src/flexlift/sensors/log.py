"""The sensor log: one reading a line, JSON lines or CSV (docs/reference/sensor-log.md).

JSON lines: ``{"time": 12.5, "sensor": "aft_1/depth", "value": 341.2}``; CSV: the header
``time,sensor,value`` then ``12.5,aft_1/depth,341.2``. ``time`` is seconds since filling began,
or an ISO 8601 time in UTC (``2026-12-07T07:00:12.5Z``), taken relative to the ``origin``
given to the reader (default: the log's first ISO time). Values are SI
(:data:`flexlift.scenario.sensors.QUANTITIES`).

:class:`LogReader` streams a log of any size in bounded memory (one line at a time, a line at
most :data:`MAX_LINE` bytes) and yields the good readings in the order of the file; every bad
line is counted by its reason (:data:`REASONS`), the first few kept with their line numbers,
never a crash and never a silent skip. :class:`LogWriter` appends readings.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from datetime import UTC, datetime

from flexlift.errors import InputError, clean

#: the longest line read [bytes]; a longer one is a bad line (``too_long``), skipped to its end
MAX_LINE = 4096
#: bad lines kept as examples per reason (line number and the start of the line)
EXAMPLES = 3
#: why a line is bad
REASONS = {
    "malformed": "not a reading: not JSON / not three CSV columns, or a field missing",
    "unknown_sensor": "the sensor is not <bag>/<quantity> of a known bag and quantity",
    "nan": "the value or time is NaN or infinite",
    "not_a_number": "text (or true/false) where a number belongs",
    "bad_time": "the time is neither seconds nor an ISO 8601 UTC time",
    "time_backwards": "earlier than the same sensor's previous reading",
    "duplicate": "the same sensor at the same time again",
    "truncated_last_line": "the last line ends without a newline and does not parse",
    "too_long": f"a line longer than {MAX_LINE} bytes",
}
CSV_HEADER = "time,sensor,value"


@dataclass(frozen=True)
class Reading:
    """One reading: ``time_s`` [s since filling began], ``sensor`` ("<bag>/<quantity>"),
    ``value`` (SI)."""

    time_s: float
    sensor: str
    value: float


@dataclass
class LogReport:
    """What a read found: good readings, bad lines by reason, examples of each."""

    lines: int = 0
    readings: int = 0
    bad: dict[str, int] = field(default_factory=dict)
    examples: dict[str, list[str]] = field(default_factory=dict)

    def add(self, reason: str, number: int, line: str) -> None:
        """Count a bad line ``number`` (1-based) for ``reason``."""
        self.bad[reason] = self.bad.get(reason, 0) + 1
        kept = self.examples.setdefault(reason, [])
        if len(kept) < EXAMPLES:
            kept.append(f"line {number}: {clean(line.strip(), 60)}")

    @property
    def bad_lines(self) -> int:
        return sum(self.bad.values())

    def to_dict(self) -> dict:
        """JSON-ready: ``lines``, ``readings``, ``bad_lines``, ``bad`` and ``examples``."""
        return {"lines": self.lines, "readings": self.readings, "bad_lines": self.bad_lines,
                "bad": dict(self.bad), "examples": {k: list(v) for k, v in self.examples.items()}}

    def text(self) -> str:
        """One line: readings and bad lines by reason."""
        if not self.bad:
            return f"{self.readings:,} readings in {self.lines:,} lines, no bad line"
        parts = ", ".join(f"{n:,} {r}" for r, n in sorted(self.bad.items()))
        return f"{self.readings:,} readings in {self.lines:,} lines; bad lines: {parts}"


class _Bad(Exception):
    def __init__(self, reason: str):
        self.reason = reason


def parse_time(text, origin: list) -> float:
    """Seconds since filling began from a number or an ISO 8601 UTC time (relative to
    ``origin[0]``, a datetime set from the first ISO time when None)."""
    if isinstance(text, bool):
        raise _Bad("not_a_number")
    if isinstance(text, int | float):
        t = float(text)
    else:
        try:
            t = float(text)
        except ValueError:
            t = None
        if t is None:
            try:
                moment = datetime.fromisoformat(str(text).strip().replace("Z", "+00:00"))
            except ValueError:
                raise _Bad("bad_time") from None
            if moment.tzinfo is None or moment.utcoffset().total_seconds() != 0:
                raise _Bad("bad_time")
            if origin[0] is None:
                origin[0] = moment
            t = (moment - origin[0]).total_seconds()
    if not math.isfinite(t):
        raise _Bad("nan")
    return t


def parse_value(value) -> float:
    """A reading's value: a finite number (JSON number or CSV text of one)."""
    if isinstance(value, bool) or value is None:
        raise _Bad("not_a_number")
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise _Bad("not_a_number") from None
    if not math.isfinite(v):
        raise _Bad("nan")
    return v


def _fields(line: str) -> tuple[object, object, object]:
    """(time, sensor, value) of a JSON or CSV line."""
    text = line.strip()
    if text.startswith("{"):
        try:
            obj = json.loads(text)
        except ValueError:
            raise _Bad("malformed") from None
        if not isinstance(obj, dict) or not {"time", "sensor", "value"} <= obj.keys():
            raise _Bad("malformed")
        return obj["time"], obj["sensor"], obj["value"]
    row = next(csv.reader([text]), [])
    if len(row) != 3:
        raise _Bad("malformed")
    return row[0], row[1].strip(), row[2]


class LogReader:
    """Stream a sensor log's good readings; ``report`` counts the bad lines.

    Parameters
    ----------
    path : path-like
        The log (JSON lines or CSV, as in the module's docstring).
    known : set of str, optional
        The sensors that exist ("<bag>/<quantity>"); any other is ``unknown_sensor``
        (default: every sensor accepted).
    origin : datetime, optional
        The moment filling began, for ISO times (default: the log's first ISO time).
    """

    def __init__(self, path, known: Iterable[str] | None = None,
                 origin: datetime | None = None):
        self.path = os.fspath(path)
        self.known = None if known is None else set(known)
        self.report = LogReport()
        self._origin = [origin]
        self._last: dict[str, float] = {}

    def __iter__(self) -> Iterator[Reading]:
        try:
            handle = open(self.path, "rb")  # noqa: SIM115 - closed below
        except OSError as error:
            raise InputError("LOG", self.path, f"cannot be read ({error.strerror})") from None
        with handle:
            number = 0
            while True:
                raw = handle.readline(MAX_LINE + 1)
                if not raw:
                    return
                number += 1
                if len(raw) > MAX_LINE and not raw.endswith(b"\n"):
                    self.report.lines += 1
                    self.report.add("too_long", number, raw[:60].decode("utf-8", "replace"))
                    while (rest := handle.readline(MAX_LINE + 1)) and not rest.endswith(b"\n"):
                        pass
                    continue
                reading = self._line(raw, number)
                if reading is not None:
                    yield reading

    def _line(self, raw: bytes, number: int) -> Reading | None:
        line = raw.decode("utf-8", "replace")
        if not line.strip() or (number == 1 and line.strip() == CSV_HEADER):
            return None
        self.report.lines += 1
        try:
            reading = self._reading(line)
        except _Bad as bad:
            last = not raw.endswith(b"\n")
            self.report.add("truncated_last_line" if last else bad.reason, number, line)
            return None
        self.report.readings += 1
        return reading

    def _reading(self, line: str) -> Reading:
        time, sensor, value = _fields(line)
        if not isinstance(sensor, str) or "/" not in sensor:
            raise _Bad("unknown_sensor" if isinstance(sensor, str) else "malformed")
        if self.known is not None and sensor not in self.known:
            raise _Bad("unknown_sensor")
        t = parse_time(time, self._origin)
        v = parse_value(value)
        before = self._last.get(sensor)
        if before is not None and t < before:
            raise _Bad("time_backwards")
        if before is not None and t == before:
            raise _Bad("duplicate")
        self._last[sensor] = t
        return Reading(t, sensor, v)


def format_line(reading: Reading, as_csv: bool) -> str:
    """A reading as one line of the log (with its newline); numbers to the last bit."""
    if as_csv:
        out = io.StringIO()
        csv.writer(out, lineterminator="\n").writerow(
            [repr(reading.time_s), reading.sensor, repr(reading.value)])
        return out.getvalue()
    return json.dumps({"time": reading.time_s, "sensor": reading.sensor,
                       "value": reading.value}) + "\n"


class LogWriter:
    """Append readings to a sensor log (CSV when the name ends ``.csv``, else JSON lines),
    flushed after every :meth:`write`. A new CSV log begins with its header."""

    def __init__(self, path):
        self.path = os.fspath(path)
        self.as_csv = self.path.lower().endswith(".csv")
        self._handle = open(self.path, "a", encoding="utf-8", newline="")  # noqa: SIM115
        if self.as_csv and self._handle.tell() == 0:
            self._handle.write(CSV_HEADER + "\n")

    def write(self, readings: Iterable[Reading]) -> int:
        """Append ``readings``; returns how many."""
        n = 0
        for reading in readings:
            self._handle.write(format_line(reading, self.as_csv))
            n += 1
        self._handle.flush()
        return n

    def close(self) -> None:
        self._handle.close()

    def __enter__(self) -> LogWriter:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def utc_now_iso() -> str:
    """The current time as ISO 8601 UTC (for a live log's receive times)."""
    return datetime.now(UTC).isoformat().replace("+00:00", "Z")
