"""Live operation through a real Mosquitto (issue 42): the master controller driving the rig
with the broker restarted midway and hostile messages; the master lifting a short variant of
the tanker through the rig to its end, safe as its simulation (the full tanker through
Mosquitto is benchmarks/live_network.py's ``master`` case:
docs/reference/live.md#what-it-achieves); ``kill -9`` of live and its log read back; ``live
--rig`` on the embedded broker end to end."""

import json
import os
import signal
import subprocess
import sys
import threading
import time
from importlib.resources import files

import paho.mqtt.client as mqtt
import pytest
from live_helpers import SENSORS, SENSORS_10HZ, mosquitto, wait_until  # noqa: F401 - the fixture

#: the rig's speed in the tests (times real time)
SPEED = 100.0
HOSTILE = [
    ("flexlift/tk/sensor/bag_1/depth", b"not json", "not_json"),
    ("flexlift/tk/sensor/bag_1/depth", b'{"time": 1, "value": NaN}', "not_finite"),
    ("flexlift/tk/sensor/bag_1/depth", b'{"time": 1, "value": "deep"}', "wrong_type"),
    ("flexlift/tk/sensor/bag_99/depth", b'{"time": 1, "value": 3}', "unknown_bag"),
    ("flexlift/tk/sensor/bag_1/temperature", b'{"time": 1, "value": 3}', "unknown_quantity"),
    ("flexlift/tk/sensor/bag_1/depth", b"\x00" * 10_000, "bad_value"),
]


def _scenario_file(tmp_path):
    text = (files("flexlift.scenarios") / "tanker.yaml").read_text() + SENSORS
    path = tmp_path / "tanker-live.yaml"
    path.write_text(text)
    return path


def _flexlift(*args, **kw):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    return subprocess.Popen([sys.executable, "-m", "flexlift", *args], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


def _logged(log, readings: int, limit_s: float = 240.0) -> bool:
    """Whether live's log ``log`` holds more than ``readings`` readings within ``limit_s``."""
    from flexlift.live.log import read_table

    def enough():
        try:
            return len(read_table(log, "readings")) > readings
        except Exception:  # noqa: BLE001 - not there yet
            return False
    return wait_until(enough, limit_s, 0.2)


def _hostile(url_port):
    client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2)
    client.connect("127.0.0.1", url_port)
    client.loop_start()
    for topic, payload, _ in HOSTILE:
        client.publish(topic, payload, qos=1).wait_for_publish(5)
    client.loop_stop()
    client.disconnect()


def _master_and_rig(scenario, mosquitto, tmp_path, speed):  # noqa: F811
    """The rig at ``speed`` and live's master session (lift ``tk``) on ``mosquitto``, both
    linked; live's log in ``tmp_path``. Returns (rig, live's link, log, what live said, live)."""
    from flexlift.live.broker import parse_broker
    from flexlift.live.log import LiveLog
    from flexlift.live.mqtt import Link
    from flexlift.live.rig import Rig
    from flexlift.live.session import Live

    address = parse_broker(mosquitto.url)
    rig = Rig(scenario, Link(address, ["flexlift/tk/command/#"], "rig"), "tk", speed=speed)
    link = Link(address, ["flexlift/tk/sensor/#"], "live")
    assert link.start() and rig.link.start()
    log = LiveLog(tmp_path / "live.sqlite", {"lift": "tk"})
    said = []
    live = Live(scenario, link, log, "tk", "master", said.append, periods=rig.periods())
    return rig, link, log, said, live


def test_master_through_mosquitto_survives_a_restart_and_hostile_messages(mosquitto, tmp_path):  # noqa: F811
    """The master controller on the network's readings drives the rig (100x) through the
    pull; the broker is restarted midway (readings stale: filling stopped and said, then
    control resumed; both ends reconnect; no command applied twice) and hostile messages
    are counted by reason, logged, and crash nothing."""
    pytest.importorskip("flexlift.sensors.tap")  # the sensors of issue 43
    from flexlift import load_scenario
    from flexlift.live.log import read_table

    scenario = load_scenario(_scenario_file(tmp_path))
    rig, link, log, said, live = _master_and_rig(scenario, mosquitto, tmp_path, SPEED)
    abort = threading.Event()

    def restart():
        if wait_until(lambda: live.board.t_max > 100.0 or abort.is_set(), 40.0):
            _hostile(mosquitto.port)
            wait_until(lambda: live.tally.total >= len(HOSTILE), 5.0)
            mosquitto.stop()
            time.sleep(1.0)
            mosquitto.start()

    threads = [threading.Thread(target=rig.run, args=(abort, 60.0)),
               threading.Thread(target=restart)]
    for t in threads:
        t.start()
    try:
        outcome = live.run(800.0, abort, wall_limit=50.0)
    finally:
        abort.set()
        for t in threads:
            t.join(30)
        link.stop()
        rig.link.stop()
        log.close()
    assert outcome.reason == "time"
    assert link.connects >= 2 and rig.link.connects >= 2, "both reconnected"
    assert any("readings stale" in line and "filling stopped" in line for line in said), said
    assert any("readings back" in line for line in said), said
    assert {r: live.tally.counts[r] for _, _, r in HOSTILE} == {r: 1 for _, _, r in HOSTILE}
    assert len(read_table(tmp_path / "live.sqlite", "dropped")) == len(HOSTILE)
    commands = read_table(tmp_path / "live.sqlite", "commands")
    assert outcome.commands == len(commands) > 4 and 4 <= rig.applied <= len(commands)
    assert rig.ascent.state.n.sum() > rig.ascent.plant.initial_moles().sum(), "it filled"


def test_kill_9_of_live_then_the_log_reads_back(tmp_path):
    """``live --rig`` (embedded broker) killed with SIGKILL: its log opens and holds every
    reading received up to a second before the kill, in time order."""
    pytest.importorskip("flexlift.sensors.tap")  # the sensors of issue 43
    from flexlift.live.log import read_readings

    proc = _flexlift("live", str(_scenario_file(tmp_path)), "--rig", "--speed", "100",
                     "--out", str(tmp_path / "out"), "--lift", "tk", "--no-plan")
    log = tmp_path / "out" / "live.sqlite"
    try:
        assert _logged(log, 200), proc.stderr.read() if proc.poll() else ""
        time.sleep(1.3)
        killed_at = time.time()
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait(10)
    finally:
        if proc.poll() is None:
            proc.kill()
    rows = list(read_readings(log))
    times = [r["time"] for r in rows]
    assert times == sorted(times)
    last_recv = max(r["recv"] for r in rows)
    assert killed_at - last_recv < 1.0, "at most the last second lost"
    assert {r["sensor"].split("/")[1] for r in rows} >= {"depth", "sling_force", "pitch"}


def test_live_rig_embedded_end_to_end(tmp_path):
    """``flexlift live SCENARIO --rig`` with no broker: the embedded broker, the rig and live
    in one command, ended at a time, with its report."""
    pytest.importorskip("flexlift.sensors.tap")  # the sensors of issue 43
    proc = _flexlift("live", str(_scenario_file(tmp_path)), "--rig", "--speed", "200",
                     "--out", str(tmp_path / "out"), "--until", "200", "--no-plan",
                     "--lift", "tk")
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 0, err
    assert "embedded broker on mqtt://127.0.0.1:" in out
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["lift"]["ended"] == "time" and report["lift"]["end_time_s"] >= 200
    assert report["lift"]["readings"] > 200 * 15 * 0.8
    assert report["lift"]["commands"] > 0
    assert (tmp_path / "out" / "report.md").read_text().startswith("# Lift tk (master)")


def test_live_with_its_rig_ends_when_the_rig_has_ended(tmp_path):
    """``--until arrived`` with ``--rig``: the rig's plant ends at its scenario's duration
    (150 s, held on the seabed all along); live then reads what is left and ends
    (``rig_ended``, exit 1: not arrived), not waiting for an arrival that cannot come, and
    not taking the end for its sensors gone silent."""
    pytest.importorskip("flexlift.sensors.tap")
    path = _scenario_file(tmp_path)
    path.write_text(path.read_text().replace("duration_s: 6000.0", "duration_s: 150.0"))
    proc = _flexlift("live", str(path), "--rig", "--speed", "200", "--out",
                     str(tmp_path / "out"), "--until", "arrived", "--no-plan", "--lift", "tk",
                     "--wall-limit", "200")
    out, err = proc.communicate(timeout=300)
    assert proc.returncode == 1, err
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["lift"]["ended"] == "rig_ended"
    assert 149.0 <= report["lift"]["end_time_s"] <= 150.0  # its last reading's time
    # an end the rig said is no silent network: no stale readings, no silent alarm
    assert "readings stale" not in out and "silent" not in report["lift"]["alarms"], out[-2000:]


def test_live_refuses_bad_options(tmp_path):
    from flexlift.cli import main

    assert main(["live", "tanker", "--out", str(tmp_path / "o"), "--until", "soon"]) == 2
    assert main(["live", "tanker", "--out", str(tmp_path / "o"), "--broker", "http://x"]) == 2


def test_live_refuses_a_taken_dashboard_port_before_writing(tmp_path, capsys):
    import socket

    from flexlift.cli import main

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen(1)
        port = taken.getsockname()[1]
        assert main(["live", "tanker", "--out", str(tmp_path / "o"), "--rig",
                     "--dashboard", str(port)]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "--dashboard" in err and str(port) in err
    assert not (tmp_path / "o").exists()
    assert main(["live", "tanker", "--out", str(tmp_path / "o"), "--dashboard", "70000"]) == 2


def test_sigint_ends_live_cleanly(tmp_path):
    """SIGINT to ``live --rig``: it stops, closes its log and writes its report, exit 0."""
    pytest.importorskip("flexlift.sensors.tap")
    from flexlift.live.log import read_table

    proc = _flexlift("live", str(_scenario_file(tmp_path)), "--rig", "--speed", "50",
                     "--out", str(tmp_path / "out"), "--lift", "tk", "--no-plan")
    log = tmp_path / "out" / "live.sqlite"
    try:
        assert _logged(log, 100)
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0, err
    assert "ended: interrupted" in out
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["lift"]["ended"] == "interrupted"
    assert report["lift"]["readings"] == len(read_table(log, "readings"))


class _Inbox:
    """A stand-in link holding messages to drain."""

    def __init__(self, messages):
        self.messages = messages

    def drain(self):
        out, self.messages = self.messages, []
        return out


def test_the_rig_applies_each_command_once_and_never_an_older_one(tanker):
    pytest.importorskip("flexlift.sensors.tap")
    from flexlift.live.messages import command_payload
    from flexlift.live.rig import Rig

    fill, purge = "flexlift/tk/command/bag_1/fill", "flexlift/tk/command/bag_2/purge"
    inbox = _Inbox([(0.0, fill, command_payload(5, 1.0, 0.1)),
                    (0.0, fill, command_payload(5, 1.0, 0.1)),   # a repeat (QoS 1)
                    (0.0, fill, command_payload(4, 0.9, 0.3)),   # older, arriving late
                    (0.0, purge, command_payload(4, 0.9, 0.5)),  # another valve's own order
                    (0.0, fill, b"junk")])
    rig = Rig(tanker, inbox, "tk")
    rig.obey()
    assert (rig.applied, rig.repeats, rig.tally.total) == (2, 2, 1)
    cs = rig.ascent.control_state
    assert cs.fill[rig.index["bag_1"]] == pytest.approx(0.1)
    assert cs.opening[rig.index["bag_2"]] == pytest.approx(0.5)
    assert cs.fill[rig.index["bag_2"]] == 0.0 and cs.opening[rig.index["bag_1"]] == 0.0


def test_live_serves_the_dashboard_with_the_lift_as_read(tmp_path):
    """``live --rig`` serves the dashboard (a free port, printed as ``flexlift live: dashboard
    on URL``): while the lift runs, its snapshot holds every bag of the scenario with the
    depths read and a state at a glance; SIGINT ends live and closes the dashboard's port."""
    pytest.importorskip("flexlift.sensors.tap")
    import queue
    import socket
    import urllib.parse
    import urllib.request

    from flexlift.live.dashboard import STATES

    err = tmp_path / "stderr.txt"
    with open(err, "w") as stderr:
        env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
        proc = subprocess.Popen(
            [sys.executable, "-m", "flexlift", "live", str(_scenario_file(tmp_path)), "--rig",
             "--speed", "20", "--out", str(tmp_path / "out"), "--until", "6000", "--no-plan",
             "--lift", "tk"], env=env, stdout=subprocess.PIPE, stderr=stderr, text=True)
    lines: queue.Queue = queue.Queue()
    threading.Thread(target=lambda: [lines.put(x) for x in proc.stdout], daemon=True).start()
    out, seen = [], []
    try:
        url, deadline = None, time.monotonic() + 240.0  # room for a cold numba compile
        while url is None and time.monotonic() < deadline and proc.poll() is None:
            try:
                out.append(lines.get(timeout=1.0))
            except queue.Empty:
                continue
            if out[-1].startswith("flexlift live: dashboard on "):
                url = out[-1].split()[-1]
        assert url and url.startswith("http://127.0.0.1:"), ("no dashboard line", out,
                                                             err.read_text()[-2000:])
        for _ in range(40):  # at most ~20 s
            snap = json.loads(urllib.request.urlopen(url + "snapshot", timeout=2).read())
            if snap and all(b["depth_m"] is not None for b in snap["bags"]):
                seen.append(snap)
                break
            time.sleep(0.5)
        proc.send_signal(signal.SIGINT)
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
    assert proc.returncode == 0, err.read_text()[-2000:]
    assert seen, "no snapshot with every bag's depth"
    snap = seen[0]
    assert [b["name"] for b in snap["bags"]] == [f"bag_{i}" for i in range(1, 8)]
    assert snap["state"] in STATES and snap["lift"] == "tk" and snap["mode"] == "master"
    assert 0 < min(b["depth_m"] for b in snap["bags"]) <= snap["limits"]["water_depth_m"]
    port = urllib.parse.urlsplit(url).port
    with pytest.raises(OSError), socket.create_connection(("127.0.0.1", port), timeout=1):
        pass  # the dashboard stopped with live



#: the short tanker's changes to the built-in tanker (``_short_tanker``)
SHORT_TANKER = (("water_depth_m: 350.0", "water_depth_m: 70.0"),
                ("target_height_m: 300.0", "target_height_m: 20.0"),
                ("breakout_time_s: 400.0", "breakout_time_s: 20.0"),
                ("hold_time_s: 600.0", "hold_time_s: 30.0"),
                ("duration_s: 6000.0", "duration_s: 600.0"),
                ("output_interval_s: 1.0", "output_interval_s: 0.1"))
#: the rig's speed for the short tanker's whole lift (times real time)
LIFT_SPEED = 10.0
#: the plant's peak ascent speed through the network against the simulation's: within this
#: fraction; its peak pitch within :data:`LIFT_PITCH_DEG` (the test's docstring says why not
#: the issue's 10 %)
LIFT_SPEED_TOLERANCE = 0.3
LIFT_PITCH_DEG = 0.5


def _short_tanker(tmp_path):
    """The tanker, shortened so that its whole lift fits the suite: raised 20 m from 70 m of
    water (not 300 m from 350 m: the same 50 m of water above the target, so the gas expands
    at the end as in the full lift), the seabed's hold decaying twenty times faster
    (``breakout_time_s`` 20 s, not 400 s: separation at about 130 s, not 1,860 s), the target
    held 30 s (not 600 s), at most 600 s; every sensor at 10 Hz (``SENSORS_10HZ``). Its
    coordinated simulation: safe, the target held at 330 s, 0.208 m/s and 0.219 deg at most
    (the full tanker's: 0.208 m/s, 0.214 deg)."""
    text = (files("flexlift.scenarios") / "tanker.yaml").read_text()
    for old, new in SHORT_TANKER:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "short-tanker-live.yaml"
    path.write_text(text + SENSORS_10HZ)
    return path


def test_master_through_mosquitto_lifts_the_short_tanker_safe_as_its_simulation(
        mosquitto, tmp_path):  # noqa: F811
    """The master controller on the network's readings drives the rig through a real
    Mosquitto from the first fill to the lift's end (the rig's plant ended by the target
    held): outcome safe, as the coordinated simulation of the same scenario, at its time;
    live's own heights at the target; the plant's peak ascent speed within
    ``LIFT_SPEED_TOLERANCE`` of the simulation's and its peak pitch within ``LIFT_PITCH_DEG``.

    A variant of the tanker (``_short_tanker``: 330 s of lift, about 35 s of this machine at
    10x): the full tanker's 3,450 s would take minutes at the speeds the chain holds here; it
    is benchmarks/live_network.py's ``master`` case (10 % its goal, at ``--speed 4``).

    Why not 10 % here: at speed the network's time counts ``LIFT_SPEED`` times. The rig obeys
    a command at the first control period (10 ms of wall time at 10x) after it arrives, and
    the round trip (readings to Mosquitto, live's next period, the command back) takes
    about that on two shared cores: measured, the commands took effect 0.1 s of lift time
    after their stamp at the median, 0.3 s at p95, 0.4 s at p99, 0.6 to 0.8 s at most (at 5x:
    0.01, 0.2, 0.3, 0.33 s; on a real lift, at 1x, a 100 ms period holds the round trip).
    The laws tolerate 0.3 s of lateness in the speed, not 0.6 s (docs/reference/live.md
    #what-it-achieves). So the lift stays safe at 10x but its peaks spread: in twelve runs
    at 8 to 10x (this variant and a longer one) the speed came 3 to 19 % above the
    simulation's and the pitch 35 % below to 100 % above it (0.14 to 0.44 deg, against a
    15 deg limit); at 5x both were within 10 % (67 s of wall time); at 20x the lift ran
    away (3.3 m/s, 30 deg)."""
    pytest.importorskip("flexlift.sensors.tap")
    from flexlift import load_scenario
    from flexlift.ascent.loop import simulate
    from flexlift.live.log import read_table

    scenario = load_scenario(_short_tanker(tmp_path))
    sim = simulate(scenario, control="coordinated", summary_only=True)
    assert sim.outcome["kind"] == "safe", sim.outcome  # the variant itself: safe, arrived
    duration = scenario.simulation.duration_s
    assert sim.headline["end_time_s"] < duration - 100.0, "ended by the target held"
    rig, link, log, said, live = _master_and_rig(scenario, mosquitto, tmp_path, LIFT_SPEED)
    stop, rig_done = threading.Event(), threading.Event()
    wall_limit = 2.0 * duration / LIFT_SPEED  # the rig's plant ends by 600 s of lift

    def run_rig():
        try:
            rig.run(stop, wall_limit, ended=rig_done)  # as live --rig: said at its end
        finally:
            rig_done.set()

    thread = threading.Thread(target=run_rig)
    started = time.monotonic()
    thread.start()
    try:
        outcome = live.run(duration, stop, wall_limit=wall_limit + 15.0,
                           source_ended=rig_done)
    finally:
        stop.set()
        thread.join(30)
        link.stop()
        rig.link.stop()
        log.close()
    wall = time.monotonic() - started
    assert not thread.is_alive()
    plant, h, target = rig.result, rig.result.headline, scenario.control.target_height_m
    print(f"short tanker at {LIFT_SPEED:g}x through Mosquitto: {wall:.1f} s wall, rig lag "
          f"{rig.lag_s:.2f} s, {outcome.readings} readings, {outcome.commands} commands "
          f"({rig.applied} applied); plant {plant.outcome['kind']} at {h['end_time_s']} s, "
          f"{h['max_ascent_velocity_ms']} m/s, {h['max_pitch_deg']} deg; simulation "
          f"{sim.headline['end_time_s']} s, {sim.headline['max_ascent_velocity_ms']} m/s, "
          f"{sim.headline['max_pitch_deg']} deg")
    assert outcome.reason == "rig_ended", (outcome.reason, wall, said[-5:])
    assert plant.outcome["kind"] == "safe", (plant.outcome, said[-5:])
    assert h["end_time_s"] == pytest.approx(sim.headline["end_time_s"], abs=20.0)
    assert all(abs(z - target) <= scenario.limits.arrival_tolerance_m
               for z in live.master.heights().values()), live.master.heights()
    # the rig said it ended: its last readings are no silent network (no stale readings,
    # no silent alarm at the end), and on them live judges the lift arrived
    assert live.arrived() and not live.stale, (live.stale, said[-5:])
    assert not [a for a in outcome.alarms if a[1] == "silent" and a[0] >= h["end_time_s"] - 10.0
                ], [a for a in outcome.alarms if a[1] == "silent"][:5]
    assert h["max_ascent_velocity_ms"] == pytest.approx(
        sim.headline["max_ascent_velocity_ms"], rel=LIFT_SPEED_TOLERANCE)
    assert h["max_pitch_deg"] == pytest.approx(sim.headline["max_pitch_deg"],
                                               abs=LIFT_PITCH_DEG)
    commands = read_table(tmp_path / "live.sqlite", "commands")
    assert outcome.commands == len(commands) > 100 and rig.repeats == 0
    assert 0.99 * len(commands) <= rig.applied <= len(commands), "the rig obeyed them"
