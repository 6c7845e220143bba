"""The live chain through a real Mosquitto on this machine (issue 42's network benchmark):
``flexlift rig`` and ``flexlift live`` as the subprocesses users run, on the machine's two
cores, every sensor at 10 Hz (docs/reference/live.md#through-mosquitto).

The benchmark starts its own Mosquitto (Debian's /usr/sbin/mosquitto, its own configuration
in a temporary folder, on a free 127.0.0.1 port; stopped by its PID at the end, also on an
error) and, in this process, an *observer*: a client subscribed to every topic of the lift,
stamping each message with this machine's clock (POSIX) as the broker hands it out. live's
log (``live.sqlite``) holds the time each reading was received, each command sent and each
control period begun (after the readings received until then were read). The cases:

- ``latency``: the 73-bag plan (the tanker on 73 external 50 t catalogue bags at 10 lift
  points, as benchmarks/bench_contingency.py builds it), 6 sensors at every bag (depth,
  pitch, sling force, fill flow, purge, supply pressure) and the hull's inclinometer, all at
  10 Hz (4,390 readings/s), the rig at real time, live --control master, for ``--seconds``
  of lift time. Sensor-to-command latency: for every reading a control period took (the
  readings live received after the previous period began and before this one did) where
  that period sent commands: the observer's time of the period's first command minus the
  observer's time of the reading. Also the same from each such period's newest reading
  only (the pipeline without the wait for the period) and live's own part (its log: the
  first command sent minus the reading received).
- ``flood``: the tanker (10 Hz sensors), live --control master, the rig at real time, once
  as it is and once with every reading published ten times (a flooder in this process
  republishes each nine more times: ten times the rate, the copies late); the control
  periods' intervals on this machine's clock (p50, p99, max against the scenario's 0.1 s).
- ``rig50``: the tanker's rig at ``--speed 50`` driven by live --control master to its end:
  the rig's lag behind its schedule (each reading's observer time minus its lift time / 50,
  less the least of these: p50, p99, max; and the rig's own largest lag) and its wall time
  against duration / 50.
- ``master``: the tanker lifted by live --control master through the rig at ``--speed``
  (default 4) to arrival: outcome, largest speed and pitch against the coordinated
  simulation of the same scenario (flexlift simulate's, true inputs).

Run (the cases one after another; about 25 minutes in all, most of it ``master``)::

    PYTHONPATH=src python benchmarks/live_network.py --case latency --repeat 2
    PYTHONPATH=src python benchmarks/live_network.py --case flood rig50
    PYTHONPATH=src python benchmarks/live_network.py --case master --speed 4

Each case's result is written into benchmarks/live_network.json (the other cases' results
kept) with the date, the load average before and after, and the commands run.
"""

from __future__ import annotations

import argparse
import bisect
import contextlib
import json
import math
import os
import re
import sqlite3
import subprocess
import sys
import tempfile
import threading
import time
from importlib.resources import files
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent / "tests"))
from live_helpers import SENSORS_10HZ, Mosquitto  # noqa: E402 - the tests' broker, sensors

OUT = HERE / "live_network.json"
PYTHON = sys.executable
#: the tanker's sensors, every one at 10 Hz: the live tests' own (benchmarks/live_master.py's,
#: live_master_10hz.json)
TANKER_SENSORS = SENSORS_10HZ
#: six sensors at every bag of the 73-bag plan and the hull's inclinometer, all at 10 Hz
BAGS73_SENSORS = """
sensors:
  seed: 3
  depth: {{rate_Hz: 10, noise_m: 0.02, latency_s: 0.2}}
  pitch: {{at: [hull, {bags}], rate_Hz: 10}}
  sling_force: {{rate_Hz: 10, noise_N: 5000.0, latency_s: 0.1}}
  fill_flow: {{rate_Hz: 10}}
  purge: {{rate_Hz: 10}}
  supply_pressure: {{rate_Hz: 10}}
"""
PERIOD_S = 0.1  # the tanker's control period (control.sample_rate_Hz 10)


def tanker_yaml() -> str:
    text = (files("flexlift.scenarios") / "tanker.yaml").read_text()
    return text.replace("output_interval_s: 1.0", "output_interval_s: 0.1")


def write_tanker(folder: Path) -> Path:
    path = folder / "tanker-10hz.yaml"
    path.write_text(tanker_yaml() + TANKER_SENSORS)
    return path


def write_bags73(folder: Path) -> Path:
    """The 73-bag plan (bench_contingency.py's ``bags73``: balanced layout, no internal bags,
    the 50 t catalogue bag) as a scenario file, with :data:`BAGS73_SENSORS`."""
    text = re.sub(r"  catalogue_bag:\n(    .*\n)+", "  catalogue_bag: {lift_t: 50}\n",
                  tanker_yaml())
    text = text.replace("internal_bags: 3 ", "internal_bags: 0 ")
    text = text.replace("layout: mode_nodes", "layout: balanced")
    bags = ", ".join(f"bag_{i}" for i in range(1, 74))
    path = folder / "bags73-10hz.yaml"
    path.write_text(text + BAGS73_SENSORS.format(bags=bags))
    return path


def loadavg() -> list[float]:
    return [round(x, 2) for x in os.getloadavg()]


class Observer:
    """A client subscribed to ``flexlift/<lift>/#`` recording (POSIX time, topic, payload);
    ``flood``: each reading received published ``flood`` more times (MQTT 5's no-local: the
    copies are not received back)."""

    def __init__(self, url: str, lift: str, flood: int = 0):
        import paho.mqtt.client as mqtt
        from paho.mqtt.subscribeoptions import SubscribeOptions

        self.messages: list[tuple[float, str, bytes]] = []
        self.flood, self.flooded = flood, 0
        self.ready = threading.Event()
        host, port = url.removeprefix("mqtt://").split(":")
        self.client = mqtt.Client(mqtt.CallbackAPIVersion.VERSION2, client_id=f"observer-{lift}",
                                  protocol=mqtt.MQTTv5)
        self.client.max_queued_messages_set(0)

        def on_connect(client, userdata, flags, reason, properties):
            client.subscribe(f"flexlift/{lift}/#", options=SubscribeOptions(qos=0, noLocal=True))
            self.ready.set()

        def on_message(client, userdata, message):
            self.messages.append((time.time(), message.topic, message.payload))
            if self.flood and "/sensor/" in message.topic:
                for _ in range(self.flood):
                    client.publish(message.topic, message.payload, qos=0)
                self.flooded += self.flood

        self.client.on_connect, self.client.on_message = on_connect, on_message
        self.client.connect(host, int(port), keepalive=30)
        self.client.loop_start()
        if not self.ready.wait(10):
            raise RuntimeError("the observer did not connect")

    def stop(self) -> None:
        self.client.disconnect()
        self.client.loop_stop()


def flexlift(*args: str, out: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=os.environ.get("PYTHONPATH", str(HERE.parent / "src")))
    return subprocess.Popen([PYTHON, "-m", "flexlift", *args], stdout=open(out, "wb"),  # noqa: SIM115
                            stderr=subprocess.STDOUT, env=env)


def wait_for_line(path: Path, needle: str, timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if path.exists() and needle in path.read_text(errors="replace"):
            return True
        time.sleep(0.1)
    return False


def stop_proc(proc: subprocess.Popen, timeout: float) -> int | None:
    try:
        return proc.wait(timeout)
    except subprocess.TimeoutExpired:
        os.kill(proc.pid, 2)  # SIGINT: live and rig end cleanly
        try:
            return proc.wait(20)
        except subprocess.TimeoutExpired:
            os.kill(proc.pid, 9)
            return proc.wait(5)


def chain(folder: Path, scenario: Path, lift: str, speed: float, until: str, wall_limit: float,
          flood: int = 0, ends: str = "live") -> dict:
    """One run: Mosquitto, the observer (and flooder), live --control master, the rig; the
    processes' outputs, the observer's messages, live's log and report."""
    broker = Mosquitto(folder).start()
    procs: list[subprocess.Popen] = []
    observer = None
    try:
        live_out, rig_out = folder / "live.out", folder / "rig.out"
        cmd_live = ["live", str(scenario), "--broker", broker.url, "--out", str(folder / "out"),
                    "--control", "master", "--until", until, "--no-dashboard", "--no-plan",
                    "--lift", lift, "--wall-limit", f"{wall_limit:g}"]
        cmd_rig = ["rig", str(scenario), "--broker", broker.url, "--speed", f"{speed:g}",
                   "--lift", lift, "--wall-limit", f"{wall_limit:g}"]
        procs.append(flexlift(*cmd_live, out=live_out))
        if not wait_for_line(live_out, "controlled bags", 120):
            raise RuntimeError(f"live did not start: {live_out.read_text()}")
        observer = Observer(broker.url, lift, flood)
        t0 = time.time()
        procs.append(flexlift(*cmd_rig, out=rig_out))
        if ends == "live":  # live ends at its --until; the rig is then stopped (SIGINT)
            rc_live = stop_proc(procs[0], wall_limit + 120)
            rc_rig = stop_proc(procs[1], 0)
        else:  # the rig ends with its plant's run; live (no readings any more) is stopped
            rc_rig = stop_proc(procs[1], wall_limit + 120)
            time.sleep(3)
            rc_live = stop_proc(procs[0], 0)
        wall = time.time() - t0
        observer.stop()
        report = json.loads((folder / "out" / "report.json").read_text())
        return {"wall_s": wall, "rc": (rc_live, rc_rig), "live_out": live_out.read_text(),
                "rig_out": rig_out.read_text(), "messages": observer.messages,
                "flooded": observer.flooded, "log": folder / "out" / "live.sqlite",
                "report": report, "commands": [" ".join(["flexlift", *cmd_live]),
                                                " ".join(["flexlift", *cmd_rig])]}
    finally:
        if observer is not None:
            with contextlib.suppress(Exception):
                observer.stop()
        for p in procs:
            if p.poll() is None:
                os.kill(p.pid, 9)
                p.wait(5)
        broker.stop()


def quantiles(x, ms: bool = True) -> dict:
    x = np.asarray(x, dtype=float)
    if x.size == 0:
        return {"n": 0}
    k = 1000.0 if ms else 1.0
    q = np.percentile(x, [50, 95, 99]) * k
    return {"n": int(x.size), "p50": round(q[0], 2), "p95": round(q[1], 2),
            "p99": round(q[2], 2), "max": round(float(x.max()) * k, 2)}


def _observed(messages):
    """Observer times of readings, by (source, quantity, time), and of commands, by seq."""
    readings, commands = {}, {}
    for recv, topic, payload in messages:
        parts = topic.split("/")
        data = json.loads(payload)
        if parts[2] == "sensor":
            readings.setdefault((parts[3], parts[4], round(data["time"], 6)), recv)
        elif parts[2] == "command":
            commands.setdefault(data["seq"], recv)
    return readings, commands


def latencies(run: dict) -> dict:
    """Sensor-to-command latency of a run (module docstring)."""
    db = sqlite3.connect(run["log"])
    periods = db.execute("SELECT recv, time FROM periods ORDER BY rowid").fetchall()
    reads = db.execute("SELECT recv, time, source, quantity FROM readings WHERE late = 0 "
                       "ORDER BY rowid").fetchall()
    cmds = db.execute("SELECT recv, seq FROM commands WHERE sent = 1 ORDER BY rowid").fetchall()
    db.close()
    starts = [p[0] for p in periods]
    obs_r, obs_c = _observed(run["messages"])
    first_cmd: dict[int, tuple[float, float]] = {}  # period: (live's send, observer's time)
    for recv, seq in cmds:
        k = bisect.bisect_right(starts, recv) - 1
        if k >= 0 and k not in first_cmd and seq in obs_c:
            first_cmd[k] = (recv, obs_c[seq])
    taken: dict[int, list] = {}
    for recv, t, source, quantity in reads:
        k = bisect.bisect_left(starts, recv)
        if k in first_cmd:
            taken.setdefault(k, []).append((recv, obs_r.get((source, quantity, round(t, 6)))))
    every, newest, own = [], [], []
    for k, rows in taken.items():
        live_cmd, obs_cmd = first_cmd[k]
        seen = [o for _, o in rows if o is not None]
        every += [obs_cmd - o for o in seen]
        if seen:
            newest.append(obs_cmd - max(seen))
        own += [live_cmd - r for r, _ in rows]
    times = [m[0] for m in run["messages"] if "/sensor/" in m[1]]
    span = times[-1] - times[0] if len(times) > 1 else math.nan
    intervals = np.diff(starts)
    return {"readings_observed": len(times), "readings_per_s": round(len(times) / span, 1),
            "readings_live": len(reads), "periods": len(periods),
            "commanding_periods": len(first_cmd),
            "reading_to_command_ms": quantiles(every),
            "newest_reading_to_command_ms": quantiles(newest),
            "live_receive_to_send_ms": quantiles(own),
            "period_interval_ms": quantiles(intervals)}


def periods_of(run: dict, skip_s: float = 5.0) -> dict:
    """The control periods' intervals on this machine's clock (the first ``skip_s`` of lift
    time left out: the start), and on the lift's clock."""
    db = sqlite3.connect(run["log"])
    rows = np.array(db.execute("SELECT recv, time FROM periods ORDER BY rowid").fetchall())
    n_late = db.execute("SELECT count(*) FROM readings WHERE late = 1").fetchone()[0]
    n_read = db.execute("SELECT count(*) FROM readings").fetchone()[0]
    db.close()
    rows = rows[rows[:, 1] >= rows[0, 1] + skip_s]
    wall, lift = np.diff(rows[:, 0]), np.diff(rows[:, 1])
    span = rows[-1, 0] - rows[0, 0]
    return {"periods": int(len(rows)), "periods_per_s": round(len(rows) / span, 2),
            "wall_interval_ms": quantiles(wall), "lift_interval_ms": quantiles(lift),
            "over_1.5_periods": int((wall > 1.5 * PERIOD_S).sum()),
            "readings_logged": int(n_read), "late_logged": int(n_late),
            "readings_per_s_logged": round(n_read / span, 1)}


def rig_lag(run: dict, speed: float) -> dict:
    """The rig's lag behind its schedule from the observer's times (module docstring)."""
    pairs = []
    for recv, topic, payload in run["messages"]:
        if "/sensor/" in topic:
            pairs.append(recv - json.loads(payload)["time"] / speed)
    lag = np.asarray(pairs) - min(pairs)
    m = re.search(r"largest lag ([0-9.]+) s", run["rig_out"])
    return {"lag_ms": quantiles(lag), "rig_largest_lag_s": float(m.group(1)) if m else None}


def simulation(scenario_path: Path) -> dict:
    from flexlift import load_scenario
    from flexlift.ascent.loop import simulate

    r = simulate(load_scenario(scenario_path), control="coordinated", summary_only=True)
    h = r.headline
    return {"outcome": r.outcome.get("kind"), "max_ascent_velocity_ms": h["max_ascent_velocity_ms"],
            "max_pitch_deg": h["max_pitch_deg"]}


def rig_plant(rig_out: str) -> dict:
    m = re.search(r"the plant: (\w+), max ascent velocity ([0-9.]+) m/s, max pitch ([0-9.]+) deg",
                  rig_out)
    return {"outcome": m.group(1), "max_ascent_velocity_ms": float(m.group(2)),
            "max_pitch_deg": float(m.group(3))} if m else {"outcome": None}


def _summary(run: dict) -> dict:
    lift = run["report"]["lift"]
    return {"wall_s": round(run["wall_s"], 1), "exit": run["rc"], "ended": lift["ended"],
            "end_time_s": lift["end_time_s"], "readings": lift["readings"],
            "late": lift["late_readings"], "commands": lift["commands"],
            "stale_periods": lift["stale_periods"], "alarms": lift["alarms"],
            "rig": run["rig_out"].strip().splitlines()[-1], "commands_run": run["commands"]}


def case_latency(folder: Path, args) -> dict:
    scenario = write_bags73(folder)
    out = []
    for i in range(args.repeat):
        sub = folder / f"latency-{i}"
        sub.mkdir()
        before = loadavg()
        run = chain(sub, scenario, "b73", 1.0, f"{args.seconds:g}", args.seconds + 60)
        row = {"load_before": before, "load_after": loadavg(), **_summary(run), **latencies(run)}
        print(json.dumps(row), flush=True)
        out.append(row)
    return {"scenario": "73-bag plan, 6 sensors a bag + the hull's pitch, 10 Hz", "runs": out}


def case_flood(folder: Path, args) -> dict:
    scenario = write_tanker(folder)
    out = []
    for flood in (0, 9):
        sub = folder / f"flood-{flood}"
        sub.mkdir()
        before = loadavg()
        run = chain(sub, scenario, "tk", 1.0, f"{args.seconds:g}", args.seconds + 60, flood)
        row = {"copies": flood, "load_before": before, "load_after": loadavg(),
               "flooder_published": run["flooded"], **_summary(run), **periods_of(run)}
        print(json.dumps(row), flush=True)
        out.append(row)
    return {"scenario": "tanker, 10 Hz sensors", "runs": out}


def case_rig50(folder: Path, args) -> dict:
    scenario = write_tanker(folder)
    sub = folder / "rig50"
    sub.mkdir()
    before = loadavg()
    run = chain(sub, scenario, "tk", 50.0, "6000", 600, ends="rig")
    from flexlift import load_scenario

    duration = None
    m = re.findall(r"t = ([0-9.]+)", run["live_out"])
    with contextlib.suppress(Exception):
        duration = float(load_scenario(scenario).simulation.duration_s)
    row = {"load_before": before, "load_after": loadavg(), **_summary(run),
           **rig_lag(run, 50.0), "plant": rig_plant(run["rig_out"]),
           "duration_s": duration, "last_said_t": m[-1] if m else None}
    print(json.dumps(row), flush=True)
    return row


def case_master(folder: Path, args) -> dict:
    scenario = write_tanker(folder)
    sub = folder / "master"
    sub.mkdir()
    before = loadavg()
    run = chain(sub, scenario, "tk", args.speed, "6000", 9000 / args.speed, ends="rig")
    sim = simulation(scenario)
    plant = rig_plant(run["rig_out"])
    lift = run["report"]["lift"]
    rel = {k: round(100 * (plant[k] / sim[k] - 1), 1) for k in
           ("max_ascent_velocity_ms", "max_pitch_deg") if plant.get(k) is not None}
    row = {"speed": args.speed, "load_before": before, "load_after": loadavg(),
           **_summary(run), "plant": plant, "simulation": sim, "plant_vs_simulation_pct": rel,
           "live_saw": {"arrived_s": lift["arrived_s"], "max_ascent_velocity_ms":
                        lift["max_ascent_velocity_ms"], "max_pitch_deg": lift["max_pitch_deg"]},
           **rig_lag(run, args.speed), **periods_of(run)}
    print(json.dumps(row), flush=True)
    return row


CASES = {"latency": case_latency, "flood": case_flood, "rig50": case_rig50,
         "master": case_master}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--case", nargs="+", choices=list(CASES), default=list(CASES))
    p.add_argument("--repeat", type=int, default=2, help="latency: runs (default 2)")
    p.add_argument("--seconds", type=float, default=60.0,
                   help="latency, flood: lift time of a run [s] (default 60)")
    p.add_argument("--speed", type=float, default=4.0, help="master: the rig's speed")
    p.add_argument("--out", default=str(OUT))
    args = p.parse_args(argv)
    out = Path(args.out)
    results = json.loads(out.read_text()) if out.exists() else {}
    for name in args.case:
        with tempfile.TemporaryDirectory(prefix=f"live-network-{name}-") as tmp:
            started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
            before = loadavg()
            result = CASES[name](Path(tmp), args)
            results[name] = {"date": started, "load_before": before, "load_after": loadavg(),
                             "argv": sys.argv[1:], "nproc": os.cpu_count(), **(
                                 result if isinstance(result, dict) else {"result": result})}
        out.write_text(json.dumps(results, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
