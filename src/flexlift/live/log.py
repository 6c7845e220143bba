"""The live log: every reading, command, alarm and dropped message, with the time it was
received, appended to SQLite as it comes (docs/reference/live.md#the-live-log).

SQLite in WAL mode with ``synchronous=NORMAL``: a committed transaction survives the process
being killed at any moment (``kill -9``; only a power cut may lose the last commits), and
readers never block the writer. Rows are committed at least every :data:`COMMIT_S`, so a
killed ``live`` loses at most that much. One writer (the live loop's thread).
"""

from __future__ import annotations

import sqlite3
import time
from collections.abc import Iterator
from pathlib import Path

#: the longest time between commits [s]
COMMIT_S = 0.5
#: the log's schema version (meta table)
SCHEMA = 1

_TABLES = """
CREATE TABLE IF NOT EXISTS meta (key TEXT PRIMARY KEY, value TEXT);
CREATE TABLE IF NOT EXISTS readings (recv REAL, time REAL, source TEXT, quantity TEXT,
                                     value REAL, late INTEGER);
CREATE TABLE IF NOT EXISTS commands (recv REAL, seq INTEGER, time REAL, bag TEXT,
                                     valve TEXT, value REAL, sent INTEGER);
CREATE TABLE IF NOT EXISTS alarms (recv REAL, time REAL, kind TEXT, source TEXT, text TEXT);
CREATE TABLE IF NOT EXISTS dropped (recv REAL, reason TEXT, topic TEXT);
CREATE TABLE IF NOT EXISTS periods (recv REAL, time REAL);
"""


class LiveLog:
    """The writer of one log file (created; an existing log is appended to)."""

    def __init__(self, path: Path, meta: dict | None = None):
        self.path = Path(path)
        self._db = sqlite3.connect(self.path, isolation_level=None, check_same_thread=False)
        self._db.execute("PRAGMA journal_mode=WAL")
        self._db.execute("PRAGMA synchronous=NORMAL")
        self._db.executescript(_TABLES)
        # the readings appended since the last commit, inserted at the commit in one
        # executemany (one INSERT each cost 73 bags x 6 sensors at 10 Hz a quarter of a
        # core); what a kill loses is the same: the transaction not yet committed
        self._readings: list[tuple] = []
        self._db.execute("BEGIN")
        self._last_commit = time.monotonic()
        rows = {"schema": str(SCHEMA), **{k: str(v) for k, v in (meta or {}).items()}}
        self._db.executemany("INSERT OR REPLACE INTO meta VALUES (?, ?)", rows.items())
        self.commit()

    def reading(self, recv: float, reading, late: bool) -> None:
        """Append a reading received at ``recv`` [s since filling began]."""
        self._readings.append((recv, reading.time, reading.source, reading.quantity,
                               reading.value, int(late)))
        self._maybe_commit()

    def command(self, recv: float, command, sent: bool) -> None:
        """Append a command (``sent``: published; False: advised only)."""
        self._db.execute("INSERT INTO commands VALUES (?, ?, ?, ?, ?, ?, ?)",
                         (recv, command.seq, command.time, command.bag, command.valve,
                          command.value, int(sent)))
        self._maybe_commit()

    def alarm(self, recv: float, t: float, kind: str, source: str, text: str) -> None:
        """Append an alarm raised at ``t`` [s]."""
        self._db.execute("INSERT INTO alarms VALUES (?, ?, ?, ?, ?)",
                         (recv, t, kind, source, text))
        self._maybe_commit()

    def dropped(self, recv: float, reason: str, topic: str) -> None:
        """Append a message dropped as malformed."""
        self._db.execute("INSERT INTO dropped VALUES (?, ?, ?)", (recv, reason, topic[:200]))
        self._maybe_commit()

    def period(self, recv: float, t: float) -> None:
        """Append a control period begun at ``recv`` [POSIX s], the readings received until
        then read, at lift time ``t`` [s] (how the period held; the readings each took)."""
        self._db.execute("INSERT INTO periods VALUES (?, ?)", (recv, t))
        self._maybe_commit()

    def _maybe_commit(self) -> None:
        if time.monotonic() - self._last_commit >= COMMIT_S:
            self.commit()

    def commit(self) -> None:
        """Commit what was appended (and begin the next transaction)."""
        self._flush()
        self._db.execute("COMMIT")
        self._db.execute("BEGIN")
        self._last_commit = time.monotonic()

    def _flush(self) -> None:
        if self._readings:
            self._db.executemany("INSERT INTO readings VALUES (?, ?, ?, ?, ?, ?)",
                                 self._readings)
            self._readings = []

    def tick(self) -> None:
        """Called by the live loop every period: commit if COMMIT_S has passed."""
        self._maybe_commit()

    def close(self) -> None:
        """Commit and close."""
        self._flush()
        self._db.execute("COMMIT")
        self._db.close()


def _connect(path) -> sqlite3.Connection:
    if not Path(path).is_file():
        raise FileNotFoundError(f"no live log at {path}")
    return sqlite3.connect(path)


def read_readings(path) -> Iterator[dict]:
    """The readings of a live log in the sensor log's form, ``{"time", "sensor", "value"}``
    (time [s since filling began], sensor ``<bag>/<quantity>``), ordered by time (a late
    reading in its place), with ``recv`` and ``late`` as extra keys."""
    db = _connect(path)
    try:
        rows = db.execute("SELECT time, source, quantity, value, recv, late FROM readings "
                          "ORDER BY time, rowid")
        for t, source, quantity, value, recv, late in rows:
            yield {"time": t, "sensor": f"{source}/{quantity}", "value": value,
                   "recv": recv, "late": bool(late)}
    finally:
        db.close()


def read_table(path, table: str) -> list[tuple]:
    """Every row of ``table`` (commands, alarms, dropped, meta, readings, periods) in the
    order written."""
    if table not in ("commands", "alarms", "dropped", "meta", "readings", "periods"):
        raise ValueError(f"no table {table!r} in a live log")
    db = _connect(path)
    try:
        return db.execute(f"SELECT * FROM {table} ORDER BY rowid").fetchall()  # noqa: S608
    finally:
        db.close()
