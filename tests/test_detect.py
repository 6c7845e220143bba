"""Fault detection and isolation (src/flexlift/estimate/detect.py,
docs/theory/fault-detection.md): every fault kind detected and named on a simulated log of
the tanker, within the issue's delays; nothing raised on a noisy fault-free log; the
CUSUM's false-alarm rate on Gaussian noise as stated."""

import math

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent.loop import prepare
from flexlift.estimate.detect import Detector
from flexlift.estimate.detect_stats import Cusum, cusum_threshold, silent_periods
from flexlift.scenario.schema import parse_scenario
from flexlift.scenario.sensors import QUANTITIES
from flexlift.sensors import LogReader, sensors_of
from flexlift.sensors.tap import run_with_log

NOISE_KEY = {"depth": "noise_m", "pitch": "noise_rad", "sling_force": "noise_N",
             "fill_flow": "noise_m3_s", "purge": "noise_fraction", "supply_pressure": "noise_Pa"}
DROPOUT = 0.02  # every sensor loses 2 % of its readings
HOLD_FAULT_S = 300.0  # the bags are filled, the hull held by the seabed
ASCENT_FAULT_S = 1850.0  # the purges open at ~1878 s: breakout
LONG_S = 1990.0
#: (kind, bag, time [s], extra fault fields)
FAULTS = [
    ("bag_rupture", "bag_3", HOLD_FAULT_S, {}),
    ("sling_break", "bag_1", HOLD_FAULT_S, {}),
    ("supply_failure", "bag_5", HOLD_FAULT_S, {}),
    ("sensor_drift", "bag_4", HOLD_FAULT_S, {"rate_m_s": 0.01}),
    ("sensor_stuck", "bag_6", HOLD_FAULT_S, {}),
    ("sensor_dropout", "bag_2", HOLD_FAULT_S, {"duration_s": 60.0}),
    ("fill_valve_stuck_open", "bag_7", HOLD_FAULT_S, {}),
    ("fill_valve_stuck_closed", "bag_4", HOLD_FAULT_S, {}),
    ("dump_valve_stuck_closed", "bag_1", ASCENT_FAULT_S, {}),
]
#: the issue's goals: a rupture or sling break within 30 s, the others within 120 s
MAX_DELAY_S = {"bag_rupture": 30.0, "sling_break": 30.0}


def _scenario(noise: bool, faults=()):
    d = load_scenario("tanker").model_dump(mode="json")
    section = {"seed": 1}
    for q in QUANTITIES:
        spec = {"at": ["hull"]} if q == "pitch" else {}
        if not noise:
            spec |= {NOISE_KEY[q]: 0.0}
        spec["dropout"] = DROPOUT if noise else 0.0
        section[q] = spec
    d["sensors"] = section
    d["faults"] = list(faults)
    return parse_scenario(d)


def _log(tmp, name, scenario, duration):
    path = tmp / f"{name}.jsonl"
    run = prepare(scenario, duration=duration)
    run_with_log(run, path)
    return list(LogReader(path)), run.plant.names


@pytest.fixture(scope="module")
def lift(tmp_path_factory):
    """The predictions (the fault-free lift without noise), the sensors, the bags."""
    tmp = tmp_path_factory.mktemp("detect")
    exact, names = _log(tmp, "exact", _scenario(noise=False), LONG_S)
    predicted = {(r.sensor, r.time_s): r.value for r in exact}
    sensors = sensors_of(_scenario(noise=True), names)
    return tmp, predicted, sensors, names


def _detect(lift, readings, **kw):
    _, predicted, sensors, names = lift
    noise = {s.name: s.noise for s in sensors}
    det = Detector(sensors, names, **kw)
    out = []
    for r in readings:
        mean = predicted.get((r.sensor, r.time_s))
        out += det.update(r, mean, noise[r.sensor] if mean is not None else None)
        out += det.tick(r.time_s)
    return out


def _faulty(lift, kind, bag, time_s, extra):
    tmp = lift[0]
    fault = {"kind": kind, "bag": bag, "time_s": time_s, **extra}
    duration = time_s + 140.0
    readings, _ = _log(tmp, kind, _scenario(noise=True, faults=[fault]), duration)
    return readings


@pytest.mark.parametrize("kind,bag,time_s,extra", FAULTS, ids=[f[0] for f in FAULTS])
def test_each_fault_is_detected_and_named(lift, kind, bag, time_s, extra):
    alarms = _detect(lift, _faulty(lift, kind, bag, time_s, extra))
    assert alarms, f"{kind} not detected"
    first = alarms[0]
    named = (first.kind, *first.alternatives)
    assert first.bag == bag and kind in named, [a.message for a in alarms]
    delay = first.time_s - time_s
    assert 0.0 <= delay <= MAX_DELAY_S.get(kind, 120.0), (kind, delay)
    assert 0.0 < first.confidence <= 1.0 and first.message and first.advice
    assert first.confidence > (0.45 if first.alternatives else 0.9)
    if time_s == HOLD_FAULT_S:  # the hull held by the seabed: the fault stays at its bag
        assert all(a.bag == bag for a in alarms), [a.message for a in alarms]


def test_a_noisy_fault_free_lift_raises_nothing(lift):
    """Filling, the hold and breakout (0 .. 1990 s), every sensor noisy and losing 2 % of
    its readings: no alarm."""
    readings, _ = _log(lift[0], "clean", _scenario(noise=True), LONG_S)
    assert len(readings) > 60_000
    assert _detect(lift, readings) == []


def test_the_cusums_false_alarm_rate_is_the_stated_one():
    """Two-sided CUSUMs on N(0, 1) noise, restarted after each alarm: the alarms per sample
    are 1 / ARL as Siegmund's approximation gives the threshold for, within four standard
    deviations of the count (Poisson) plus 3 % for the approximation (measured: < 1 % at
    nu = 0.5)."""
    rng = np.random.default_rng(20261207)
    arl, nu, chains, steps = 250.0, 0.5, 2000, 1500
    h = cusum_threshold(arl, nu)
    up, down, count = np.zeros(chains), np.zeros(chains), 0
    for _ in range(steps):
        e = rng.standard_normal(chains)
        up, down = np.maximum(0.0, up + e - nu), np.maximum(0.0, down - e - nu)
        hit = (up > h) | (down > h)
        count += int(hit.sum())
        up[hit], down[hit] = 0.0, 0.0
    expected = chains * steps / arl
    assert abs(count - expected) <= 4.0 * math.sqrt(expected) + 0.03 * expected, (count, expected)
    # the class runs the same recursion
    c = Cusum(h, nu)
    e = rng.standard_normal(400)
    flags = [c.update(x, float(k)) for k, x in enumerate(e)]
    u = d = 0.0
    for x, f in zip(e, flags):
        u, d = max(0.0, u + x - nu), max(0.0, d - x - nu)
        assert f == (0 if max(u, d) <= h else (1 if u >= d else -1))


def test_the_budget_is_split_over_the_sensors_and_their_tests(lift):
    """Each sensor's CUSUM threshold is the one of its share of the false alarms per hour;
    the silence test waits the dropouts' k periods, dropout^k within the share."""
    _, _, sensors, names = lift
    det = Detector(sensors, names, false_alarms_per_hour=0.01)
    share = 0.01 / (3 * len(sensors))
    for s in sensors:
        tr = det.tracks[s.name]
        per_sample = share / (3600.0 * s.rate_Hz)
        assert tr.h == pytest.approx(cusum_threshold(1.0 / per_sample, 0.5))
        k = silent_periods(DROPOUT, per_sample)
        assert tr.k_silent == k and DROPOUT ** k <= per_sample < DROPOUT ** (k - 1)


def test_a_stuck_sensor_needs_its_repeats_and_a_silent_one_its_periods():
    from flexlift.sensors import Reading
    from flexlift.sensors.config import Sensor

    s = Sensor("a", "depth", 1.0, 0.05, 0.0, 0.3)
    det = Detector([s], ["a"], resolution={"depth": 0.01})
    tr = det.tracks["a/depth"]
    # 0.01 m steps under 0.05 m noise: a repeat by chance 5.6 %; the repeats needed
    p = 0.01 / (2 * math.sqrt(math.pi) * 0.05)
    m = math.ceil(math.log(tr.per_sample) / math.log(p))
    assert m > 1
    rng = np.random.default_rng(3)
    out, t = [], 0.0
    for _ in range(50):
        out += det.update(Reading(t, "a/depth", round(100 + rng.normal(0, 0.05), 2)), 100, 0.05)
        t += 1
    assert out == []  # chance repeats, fewer than m in a row
    for j in range(m + 1):  # the value, then m repeats of it
        out += det.update(Reading(t, "a/depth", 123.45), None, None)
        assert out == [] and (tr.stuck_p is None) == (j < m)
        t += 1
    out += det.tick(t + 1)  # once the isolation wait (two periods) is over
    assert [(a.kind, a.bag, a.sensor) for a in out] == [("sensor_stuck", "a", "a/depth")]
    # silence: k periods of a 30 % dropout
    k = tr.k_silent
    assert det.tick(t - 1 + k - 0.5) == []
    alarms = det.tick(t - 1 + k)
    assert [a.kind for a in alarms] == ["sensor_dropout"]
    assert alarms[0].confidence == pytest.approx(1 - 0.3 ** k)


# ------------------------------------------------------------------ the signature table
def _two_bags():
    from flexlift.sensors.config import Sensor

    noise = {"depth": 0.05, "sling_force": 20_000.0, "fill_flow": 0.002}
    return [Sensor(b, q, 1.0, n, 0.0, 0.0) for b in ("a", "b") for q, n in noise.items()]


def _synthetic(changes, seconds=40, fault_s=10):
    """Readings of bags a and b at 1 Hz, N(prediction, noise), the prediction constant;
    from ``fault_s`` on, ``changes[(bag, quantity)](t since the fault)`` is added to the
    reading (not to the prediction)."""
    from flexlift.sensors import Reading

    sensors = _two_bags()
    mean = {"depth": 350.0, "sling_force": 3.0e6, "fill_flow": 0.0}
    rng = np.random.default_rng(5)
    det, out = Detector(sensors, ["a", "b"]), []
    for k in range(seconds):
        for s in sensors:
            z = mean[s.quantity] + rng.normal(0.0, s.noise)
            change = changes.get((s.bag, s.quantity))
            if change is not None and k >= fault_s:
                z += change(k - fault_s, mean[s.quantity])
            out += det.update(Reading(float(k), s.name, z), mean[s.quantity], s.noise)
        out += det.tick(float(k))
    return [(a.kind, a.bag) for a in out]


def test_the_signatures_name_the_kind():
    """The table of docs/theory/fault-detection.md on synthetic readings: a sling force
    gone to zero is a broken sling unless the bag is being filled (then a rupture that
    emptied it); a fill flow alone is a stuck-open valve; a depth gauge alone is drifting,
    but not when another bag's gauge moves with it (the hull moved)."""
    to_zero = lambda k, m: -m  # noqa: E731
    filling = lambda k, m: 17.0  # noqa: E731
    ramp = lambda k, m: -0.02 * k  # noqa: E731
    assert _synthetic({("a", "sling_force"): to_zero}) == [("sling_break", "a")]
    assert _synthetic({("a", "sling_force"): to_zero, ("a", "fill_flow"): filling}) == \
        [("bag_rupture", "a")]
    decay = lambda k, m: -m * (1 - math.exp(-(k + 1) / 5.0))  # noqa: E731
    assert _synthetic({("b", "sling_force"): decay}) == [("bag_rupture", "b")]
    assert _synthetic({("b", "fill_flow"): filling}) == [("fill_valve_stuck_open", "b")]
    assert _synthetic({("a", "depth"): ramp}) == [("sensor_drift", "a")]
    assert _synthetic({("a", "depth"): ramp, ("b", "depth"): ramp}) == []


def test_a_controllers_short_fills_are_not_a_stuck_valve_a_lasting_one_is():
    """docs/theory/fault-detection.md#persistence: fills of two seconds in every five, far
    beyond the meter's noise (the lift's controller topping its bags up where the members
    did not), flag the fill flow's CUSUM but never name a fill valve stuck open; the same
    flow lasting is named, once it has filled most of the 30 s span, not before."""
    from flexlift.estimate.detect import PERSIST_S

    pulses = lambda k, m: 0.5 if k % 5 < 2 else 0.0  # noqa: E731
    assert _synthetic({("b", "fill_flow"): pulses}, seconds=200) == []
    lasting = lambda k, m: 0.5  # noqa: E731
    assert _synthetic({("b", "fill_flow"): lasting}, seconds=200) == \
        [("fill_valve_stuck_open", "b")]
    # named once most of the span is of the fault (at 10 s; 26 of the 30 readings beyond
    # the reference: about 24 s, the readings before it being noise), and within the span
    assert _synthetic({("b", "fill_flow"): lasting}, seconds=10 + int(0.7 * PERSIST_S)) == []
    assert _synthetic({("b", "fill_flow"): lasting}, seconds=10 + int(PERSIST_S) + 1) == \
        [("fill_valve_stuck_open", "b")]


def _purge_only(lift_open, seconds=120):
    """A bag with a dump-valve feedback only (1 Hz, noise 0.01): the members open it 3 s in
    every 6; ``lift_open(k)`` is what the lift's reads at second k."""
    from flexlift.sensors import Reading
    from flexlift.sensors.config import Sensor

    sensor = Sensor("b", "purge", 1.0, 0.01, 0.0, 0.0)
    rng = np.random.default_rng(8)
    det, out = Detector([sensor], ["b"]), []
    for k in range(seconds):
        mean = 1.0 if (k // 3) % 2 == 0 else 0.0
        z = lift_open(k) + rng.normal(0.0, 0.01)
        out += det.update(Reading(float(k), sensor.name, z), mean, 0.01)
        out += det.tick(float(k))
    return [(a.kind, a.bag, a.time_s) for a in out]


def test_a_dump_valve_cycled_at_other_moments_is_not_stuck_one_shut_throughout_is():
    """docs/theory/fault-detection.md#persistence: the lift's controller cycles its dump
    valve at other moments than the members (out of step by half a cycle: every reading
    a hundred noise widths off, both ways): no dump valve named stuck; shut throughout while
    the members open it, it is named, once it has read shut over most of the 30 s span."""
    out_of_step = lambda k: 1.0 if ((k + 3) // 3) % 2 == 0 else 0.0  # noqa: E731
    assert _purge_only(out_of_step) == []
    named = _purge_only(lambda k: 0.0)
    assert [(kind, bag) for kind, bag, _ in named] == [("dump_valve_stuck_closed", "b")]
    assert 24.0 <= named[0][2] <= 31.0
