"""How ``flexlift live`` ends when its readings stop (docs/reference/live.md: Ending): a rig
that has said it ended (``source_ended``, as ``live --rig`` is told) is no sensor network
gone silent, so the lift's arrival is judged on the readings sent up to the end; readings that
stop with no end said (the rig killed, the broker gone) are stale: filling stopped, every
silent sensor alarmed. No broker: a stand-in link feeds live a made-up lift of 1 Hz gauges on
the short tanker's four controlled bags (their per-bag filters: no hull observer)."""

import json
import threading
import time
from importlib.resources import files

import pytest

#: lift seconds per second of this machine's clock (the rig's ``--speed``)
RATE = 10.0
#: the controlled bags, their gauges' period [s], rest depth [m] and rise speed [m/s]
BAGS = ("bag_1", "bag_2", "bag_3", "bag_4")
PERIOD_S, REST_DEPTH_M, RISE_M_S = 1.0, 60.0, 0.2
#: the rise starts here [s]; the target (20 m) is reached 100 s later
RISE_START_S = 15.0
GAUGES = f"""
sensors:
  seed: 3
  depth: {{at: [{", ".join(BAGS)}], rate_Hz: 1.0, noise_m: 0.02}}
  sling_force: {{at: [{", ".join(BAGS)}], rate_Hz: 1.0}}
  pitch: null
  fill_flow: null
  purge: null
  supply_pressure: null
"""


@pytest.fixture(scope="module")
def short_tanker(tmp_path_factory):
    """The short tanker (test_live.py's ``SHORT_TANKER``: 20 m raised in 70 m of water) with
    gauges at its controlled bags only."""
    from test_live import SHORT_TANKER

    from flexlift import load_scenario

    text = (files("flexlift.scenarios") / "tanker.yaml").read_text()
    for old, new in SHORT_TANKER:
        text = text.replace(old, new)
    path = tmp_path_factory.mktemp("end") / "short-tanker-gauges.yaml"
    path.write_text(text + GAUGES)
    return load_scenario(path)


class _Network:
    """A stand-in link: the messages put, drained by live; the commands published, kept."""

    def __init__(self):
        self.inbox, self.published = [], []

    def drain(self):
        out, self.inbox = self.inbox, []
        return out

    def publish(self, topic, payload, qos=0):
        self.published.append((topic, payload))


def _put(net, t: float, wall: float) -> None:
    """Every gauge's reading of lift time ``t`` [s], received at ``wall`` [monotonic s]:
    held at the rest depth, then rising at ``RISE_M_S`` to the target, then held there."""
    from flexlift.live.messages import reading_payload, sensor_topic

    depth = REST_DEPTH_M - min(max(t - RISE_START_S, 0.0) * RISE_M_S, 20.0)
    for bag in BAGS:
        net.inbox.append((wall, sensor_topic("tk", bag, "depth"), reading_payload(t, depth)))
        net.inbox.append((wall, sensor_topic("tk", bag, "sling_force"),
                          reading_payload(t, 2.0e6)))


def _lifted_to(scenario, tmp_path, t_fed: float, t_queued: float):
    """A master live on the stand-in network, fed the lift period by period up to
    ``t_fed`` [s] (its readings received as they would be at ``RATE``, the last of them
    as the feed began), and the readings after it up to ``t_queued`` put on the network unread: (live,
    network, what it said)."""
    from flexlift.live.log import LiveLog
    from flexlift.live.session import Live

    net, said = _Network(), []
    periods = {f"{b}/{q}": PERIOD_S for b in BAGS for q in ("depth", "sling_force")}
    live = Live(scenario, net, LiveLog(tmp_path / "live.sqlite", {"lift": "tk"}), "tk",
                "master", said.append, rate=RATE, periods=periods)
    assert live.master.hull is None  # the per-bag filters: the gauges are made up
    live.epoch = time.time()
    now = time.monotonic()
    wall = lambda t: now + (t - t_fed) / RATE  # noqa: E731 - received at RATE, t_fed now
    t = 0.0
    while t <= t_fed:
        _put(net, t, wall(t))
        live.read()
        live.period(t, wall(t))
        t += PERIOD_S
    while t <= t_queued:
        _put(net, t, time.monotonic())  # sent before the end, on their way: received now
        t += PERIOD_S
    return live, net, said


def _run_with_the_end_said(live):
    """``live`` run to ``arrived`` with the rig's end already said; its log closed."""
    ended = threading.Event()
    ended.set()
    outcome = live.run("arrived", threading.Event(), epoch=live.epoch, wall_limit=30.0,
                       source_ended=ended)
    live.log.close()
    return outcome


def test_a_rig_that_ended_after_arrival_ends_live_arrived(short_tanker, tmp_path):
    """The rig ends (said) with the last readings on their way, the bags at the target in
    them: live reads them, ends ``arrived`` at the last reading's time, with no stale
    readings and no silent alarm (its last period is at least 0.5 s of this machine after
    the last reading: 5 s of lift at 10x, past every gauge's silence)."""
    live, net, said = _lifted_to(short_tanker, tmp_path, 105.0, 125.0)
    assert not live.arrived(), "not yet at the target when the rig ends"
    outcome = _run_with_the_end_said(live)
    assert outcome.reason == "arrived", (outcome.reason, said[-3:], live.master.heights())
    assert outcome.t_end == outcome.arrived_s == 125.0
    assert not [a for a in outcome.alarms if a[1] == "silent"], outcome.alarms[:5]
    assert not any("stale" in line for line in said), said
    assert outcome.stale_periods == 0


def test_readings_stopping_with_no_end_said_are_stale(short_tanker, tmp_path):
    """The rig killed mid-rise (no end said): its readings go stale, live says so, stops
    filling (every fill commanded 0) and alarms every silent gauge; not arrived."""
    live, net, said = _lifted_to(short_tanker, tmp_path, 80.0, 80.0)
    outcome = live.run("arrived", threading.Event(), epoch=live.epoch, wall_limit=1.5)
    live.log.close()
    assert outcome.reason == "time" and outcome.arrived_s is None, outcome.reason
    assert any("readings stale" in line and "filling stopped" in line for line in said), said
    silent = {a[2] for a in outcome.alarms if a[1] == "silent"}
    assert silent == {f"{b}/{q}" for b in BAGS for q in ("depth", "sling_force")}, silent
    fills = [json.loads(p)["value"] for topic, p in net.published if topic.endswith("/fill")]
    assert max(fills) > 0.0 and all(live.sent[b][0] == 0.0 for b in BAGS), live.sent
    assert live.stale and outcome.stale_periods > 0


def test_readings_stopped_before_the_rig_said_it_ended_are_stale(short_tanker, tmp_path):
    """The bags at the target, then no reading for 0.5 s of this machine (5 s of lift: the
    network gone) before the rig says it ended: its end does not make the old readings
    fresh; stale, the gauges alarmed, not arrived (``rig_ended``)."""
    live, net, said = _lifted_to(short_tanker, tmp_path, 125.0, 125.0)
    time.sleep(0.5)
    outcome = _run_with_the_end_said(live)
    assert outcome.reason == "rig_ended" and outcome.t_end == 125.0, outcome.reason
    assert {a[2] for a in outcome.alarms if a[1] == "silent"} == {
        f"{b}/{q}" for b in BAGS for q in ("depth", "sling_force")}
    assert live.stale and not live.arrived()


def test_the_rig_says_it_ended_before_it_makes_its_result(tmp_path):
    """The rig sets ``ended`` as soon as its plant's run ends, before the run's result is
    made (which takes long enough, on a loaded machine, for live's clock to run past its
    sensors' silence): live is told within the silence, and no reading is sent after."""
    from live_helpers import SENSORS

    from flexlift import load_scenario
    from flexlift.live.rig import Rig

    text = (files("flexlift.scenarios") / "tanker.yaml").read_text()
    path = tmp_path / "tanker-60s.yaml"
    path.write_text(text.replace("duration_s: 6000.0", "duration_s: 60.0") + SENSORS)
    net, ended, seen = _Network(), threading.Event(), []
    rig = Rig(load_scenario(path), net, "tk", speed=1e6)
    finish = rig.ascent.finish

    def result(*args, **kw):
        seen.append((ended.is_set(), len(net.published)))
        return finish(*args, **kw)

    rig.ascent.finish = result
    rig.run(threading.Event(), ended=ended)
    assert seen == [(True, rig.published)] and rig.published > 0
    assert rig.result.headline["end_time_s"] == pytest.approx(60.0, abs=0.2)
