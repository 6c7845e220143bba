"""Messages, the live log and the board of live operation (issue 42): no broker needed."""

import math
import sqlite3
import subprocess
import sys

import pytest

from flexlift.live import log as livelog
from flexlift.live.board import Board
from flexlift.live.messages import (
    Reading,
    Tally,
    command_payload,
    parse_command,
    parse_reading,
    parse_time,
    reading_payload,
    sensor_topic,
)

BAGS = {"bag_1", "bag_2"}


def _parse(topic, payload, epoch=None):
    tally = Tally()
    return parse_reading(topic, payload, "tk", BAGS, tally, epoch=epoch), tally


def test_a_reading_round_trips():
    got, tally = _parse(sensor_topic("tk", "bag_1", "depth"), reading_payload(12.5, 340.25))
    assert got == Reading(12.5, "bag_1", "depth", 340.25)
    assert got.sensor == "bag_1/depth" and tally.total == 0


def test_iso_times_are_seconds_since_filling_began():
    assert parse_time("2026-12-07T06:00:10Z", epoch=parse_time_epoch()) == pytest.approx(10.0)
    assert parse_time("2026-12-07T06:00:10+01:00", epoch=0.0) is None  # UTC only
    assert parse_time("2026-12-07T06:00:10", epoch=0.0) is None  # no zone
    assert parse_time("2026-12-07T06:00:10Z", epoch=None) is None
    assert parse_time(True, epoch=None) is None


def parse_time_epoch():
    from datetime import UTC, datetime

    return datetime(2026, 12, 7, 6, 0, 0, tzinfo=UTC).timestamp()


@pytest.mark.parametrize("topic, payload, reason", [
    ("flexlift/tk/sensor/bag_1/depth", b"{not json", "not_json"),
    ("flexlift/tk/sensor/bag_1/depth", b"\xff\xfe", "not_json"),
    ("flexlift/tk/sensor/bag_1/depth", b"[1, 2]", "not_object"),
    ("flexlift/tk/sensor/bag_1/depth", b'{"time": 1}', "missing_field"),
    ("flexlift/tk/sensor/bag_1/depth", b'{"time": 1, "value": NaN}', "not_finite"),
    ("flexlift/tk/sensor/bag_1/depth", b'{"time": 1, "value": Infinity}', "not_finite"),
    ("flexlift/tk/sensor/bag_1/depth", b'{"time": 1, "value": "3"}', "wrong_type"),
    ("flexlift/tk/sensor/bag_1/depth", b'{"time": 1, "value": true}', "wrong_type"),
    ("flexlift/tk/sensor/bag_1/depth", b'{"time": "soon", "value": 3}', "bad_time"),
    ("flexlift/tk/sensor/bag_9/depth", b'{"time": 1, "value": 3}', "unknown_bag"),
    ("flexlift/tk/sensor/bag_1/colour", b'{"time": 1, "value": 3}', "unknown_quantity"),
    ("flexlift/tk/sensor/hull/purge", b'{"time": 1, "value": 3}', "hull_quantity"),
    ("flexlift/other/sensor/bag_1/depth", b'{"time": 1, "value": 3}', "topic"),
    ("flexlift/tk/sensor/bag_1", b'{"time": 1, "value": 3}', "topic"),
    ("flexlift/tk/sensor/bag_1/depth", b"[" * 100_000, "bad_value"),
    ("flexlift/tk/sensor/bag_1/depth", b"[" * 3000, "not_json"),
])
def test_malformed_readings_are_counted_by_reason(topic, payload, reason):
    got, tally = _parse(topic, payload)
    assert got is None
    assert dict(tally.counts) == {reason: 1}


def test_commands_parse_and_refuse():
    tally = Tally()
    c = parse_command("flexlift/tk/command/bag_1/purge", command_payload(7, 3.0, 0.5), "tk",
                      BAGS, tally)
    assert (c.seq, c.bag, c.valve, c.value) == (7, "bag_1", "purge", 0.5)
    for topic, payload in [("flexlift/tk/command/bag_1/purge", b'{"seq": 1, "time": 0, "value": 2}'),
                           ("flexlift/tk/command/bag_1/fill", b'{"seq": 1.5, "time": 0, "value": 0}'),
                           ("flexlift/tk/command/bag_1/open", b'{"seq": 1, "time": 0, "value": 0}'),
                           ("flexlift/tk/command/bag_7/fill", b'{"seq": 1, "time": 0, "value": 0}'),
                           ("flexlift/tk/command/bag_1/fill", b'{"seq": 1, "time": 0, "value": -1}')]:
        assert parse_command(topic, payload, "tk", BAGS, tally) is None
    assert dict(tally.counts) == {"bad_value": 2, "wrong_type": 1, "topic": 1, "unknown_bag": 1}


def test_board_orders_by_time_and_marks_late_readings():
    board = Board(["bag_1"], rate=1.0)
    assert not board.add(Reading(1.0, "bag_1", "depth", 350.0), wall=0.0)
    assert not board.add(Reading(2.0, "bag_1", "depth", 349.0), wall=1.0)
    assert board.add(Reading(1.5, "bag_1", "depth", 360.0), wall=1.1)  # late: kept aside
    assert board.value("bag_1", "depth") == 349.0
    assert board.speed("bag_1") == pytest.approx(1.0)  # depth falling 1 m/s: rising
    assert board.late == 1
    board.add(Reading(2.5, "bag_1", "depth", 349.5), wall=1.5)  # a new depth: a new speed
    assert board.speed("bag_1") == pytest.approx(3 / 7)  # the slope of the three


def test_board_silent_after_twice_the_period():
    board = Board(["bag_1"], periods={"bag_1/depth": 0.5}, rate=2.0)
    board.add(Reading(10.0, "bag_1", "depth", 300.0), wall=100.0)
    assert board.silent(100.4) == []  # 0.8 s of lift time: within twice the period
    assert board.silent(100.6) == ["bag_1/depth"]  # 1.2 s
    assert board.now(100.6) == pytest.approx(11.2)


def test_the_clock_rate_is_learnt_from_the_readings():
    board = Board(["bag_1"])
    for i in range(200):
        board.add(Reading(i * 0.5, "bag_1", "depth", 300.0), wall=i * 0.01)  # 50x
    assert board.rate == pytest.approx(50.0, rel=0.05)


def test_log_survives_kill_9_to_its_last_commit(tmp_path):
    """A writer killed with SIGKILL mid-stream: every row committed more than COMMIT_S before
    the kill reads back, in time order, late ones marked."""
    path = tmp_path / "live.sqlite"
    code = f"""
import os, signal, time, sys
sys.path[:0] = {sys.path!r}
from flexlift.live.log import LiveLog
from flexlift.live.messages import Reading
log = LiveLog({str(path)!r}, {{"lift": "tk"}})
t0 = time.monotonic()
i = 0
while time.monotonic() - t0 < 1.6:
    log.reading(time.time(), Reading(i * 0.01, "bag_1", "depth", 300.0 - i * 1e-3), False)
    i += 1
    if i == 50:
        log.reading(time.time(), Reading(0.2, "bag_1", "depth", 1.0), True)
    time.sleep(0.0005)
print(i, flush=True)
os.kill(os.getpid(), signal.SIGKILL)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, timeout=60)
    assert out.returncode == -9
    written = int(out.stdout)
    rows = list(livelog.read_readings(path))
    normal = [r for r in rows if not r["late"]]
    # committed at least every COMMIT_S: at most that much (plus a margin) lost
    assert len(normal) >= written - (livelog.COMMIT_S + 0.3) / 1.6 * written
    assert len(normal) <= written
    times = [r["time"] for r in rows]
    assert times == sorted(times)
    assert [r["time"] for r in normal] == pytest.approx([i * 0.01 for i in range(len(normal))])
    assert sum(r["late"] for r in rows) == 1 and rows[0]["sensor"] == "bag_1/depth"
    assert dict(livelog.read_table(path, "meta"))["lift"] == "tk"
    with sqlite3.connect(path) as db:
        assert db.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    assert not math.isnan(rows[-1]["value"])


def test_each_control_period_is_logged_with_its_start_and_lift_time(tmp_path, tanker):
    """live logs every control period it runs (its start on this machine's clock, after the
    readings received until then were read, and its lift time): how the period held."""
    import time

    from flexlift.live.session import Live

    log = livelog.LiveLog(tmp_path / "live.sqlite")
    live = Live(tanker, None, log, "tk", "advise", say=lambda line: None)
    before = time.time()
    for k in range(3):
        live.period(0.1 * k, time.monotonic())
    log.close()
    rows = livelog.read_table(tmp_path / "live.sqlite", "periods")
    assert [t for _, t in rows] == pytest.approx([0.0, 0.1, 0.2])
    starts = [recv for recv, _ in rows]
    assert before <= starts[0] <= starts[1] <= starts[2] <= time.time()
