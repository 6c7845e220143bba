"""The sensors: the scenario's section, the log (reader, writer, every bad line), the sensor
model and the true values from the loop's records (src/flexlift/sensors)."""

import json
import tracemalloc

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.cli import main
from flexlift.errors import InputError
from flexlift.scenario.schema import parse_scenario
from flexlift.sensors import LogReader, LogWriter, Reading, SensorModel, sensors_of
from flexlift.sensors.config import Sensor

TOY = {"control": {"target_height_m": 10.0}, "seabed": {"breakout_time_s": 40.0},
       "simulation": {"hold_time_s": 20.0}}


def _scenario(**extra):
    return parse_scenario({**TOY, **extra})


# ------------------------------------------------------------------ the section
def test_the_section_refuses_unknown_keys_and_names_units():
    with pytest.raises(InputError, match="noise"):
        _scenario(sensors={"depth": {"noise": 0.1}})
    with pytest.raises(InputError, match="rate_Hz"):
        _scenario(sensors={"depth": {"rate_Hz": -1}})
    s = _scenario(sensors={"depth": {"noise_m": 0.2, "rate_Hz": 2}, "pitch": None,
                           "sling_force": {"at": ["bag_1"], "dropout": 0.1}})
    got = sensors_of(s, ["bag_1", "bag_2"])
    names = [x.name for x in got]
    assert names[:2] == ["bag_1/depth", "bag_2/depth"] and "hull/pitch" not in names
    assert got[0].noise == 0.2 and got[0].rate_Hz == 2
    assert [x.name for x in got if x.quantity == "sling_force"] == ["bag_1/sling_force"]


def test_no_section_no_sensors_but_the_log_default():
    s = _scenario()
    assert sensors_of(s, ["bag_1"]) == []
    names = {x.name for x in sensors_of(s, ["bag_1"], for_log=True)}
    assert names == {"hull/pitch", "bag_1/depth", "bag_1/sling_force", "bag_1/fill_flow",
                     "bag_1/purge", "bag_1/supply_pressure"}


def test_a_sensor_at_an_unknown_bag_or_a_hull_sling_is_refused():
    with pytest.raises(InputError, match="sensors.depth.at.*bag_9"):
        sensors_of(_scenario(sensors={"depth": {"at": ["bag_9"]}}), ["bag_1"])
    with pytest.raises(InputError, match="sensors.sling_force.at"):
        sensors_of(_scenario(sensors={"sling_force": {"at": ["hull"]}}), ["bag_1"])


def test_the_checksum_of_a_scenario_without_sensors_is_unchanged_by_the_section():
    a, b = _scenario(), _scenario(sensors={"depth": {"noise_m": 0.2}})
    assert a.checksum() != b.checksum()
    assert a.checksum() == parse_scenario(a.model_dump(mode="json")).checksum()


# ------------------------------------------------------------------ the log
def _read(tmp_path, text, known=None, name="log.jsonl"):
    p = tmp_path / name
    p.write_bytes(text.encode())
    reader = LogReader(p, known)
    return list(reader), reader.report


def test_every_bad_line_is_counted_by_its_reason(tmp_path):
    known = {"a/depth", "a/pitch"}
    lines = [
        '{"time": 0, "sensor": "a/depth", "value": 1.0}',
        '{"time": 1, "sensor": "b/depth", "value": 1.0}',      # unknown sensor
        '{"time": 1, "sensor": "a/depth", "value": NaN}',      # NaN
        '{"time": 1, "sensor": "a/depth", "value": "deep"}',   # text for a number
        '{"time": 1, "sensor": "a/depth", "value": true}',     # a boolean
        'not json at all',                                     # malformed
        '{"time": 2, "sensor": "a/depth", "value": 2.0}',
        '{"time": 1.5, "sensor": "a/depth", "value": 2.0}',    # time backwards
        '{"time": 2, "sensor": "a/depth", "value": 2.0}',      # duplicate
        '{"time": 1.5, "sensor": "a/pitch", "value": 0.1}',    # another sensor: fine
        '{"time": "yesterday", "sensor": "a/pitch", "value": 0.1}',  # bad time
        'x' * 5000,                                            # too long
        '{"time": 3, "sensor": "a/depth", "val',               # truncated last line
    ]
    good, report = _read(tmp_path, "\n".join(lines), known)
    assert [(r.time_s, r.sensor) for r in good] == [(0, "a/depth"), (2, "a/depth"),
                                                    (1.5, "a/pitch")]
    assert report.bad == {"unknown_sensor": 1, "nan": 1, "not_a_number": 2, "malformed": 1,
                          "time_backwards": 1, "duplicate": 1, "bad_time": 1, "too_long": 1,
                          "truncated_last_line": 1}
    assert report.lines == len(lines) and report.readings == 3
    assert "line 2" in report.examples["unknown_sensor"][0]
    assert "truncated_last_line" in report.text()


def test_csv_and_iso_times(tmp_path):
    text = ("time,sensor,value\n2026-12-07T07:00:00Z,a/depth,10\n"
            "2026-12-07T07:00:01.5Z,a/depth,11\n2026-12-07T08:00:00+01:00,a/depth,12\n"
            "2026-12-07T07:00:02,a/depth,13\n")
    good, report = _read(tmp_path, text, name="log.csv")
    assert [(r.time_s, r.value) for r in good] == [(0.0, 10.0), (1.5, 11.0)]
    assert report.bad == {"bad_time": 2}  # not UTC, no zone


def test_the_writer_appends_and_reads_back_to_the_last_bit(tmp_path):
    for name in ("log.jsonl", "log.csv"):
        path = tmp_path / name
        first = [Reading(0.1, "a/depth", 1 / 3), Reading(0.2, "hull/pitch", -1e-17)]
        with LogWriter(path) as w:
            w.write(first)
        with LogWriter(path) as w:
            w.write([Reading(0.3, "a/depth", 2.5)])
        got = list(LogReader(path))
        assert got == [*first, Reading(0.3, "a/depth", 2.5)]
    assert (tmp_path / "log.csv").read_text().count("time,sensor,value") == 1


def test_a_large_log_is_read_in_bounded_memory(tmp_path):
    path = tmp_path / "big.jsonl"
    line = '{"time": %d, "sensor": "a/depth", "value": 1.0}\n'
    lines = 100_000  # ~5 MB: the file read whole, or its readings kept, is over the bound
    with open(path, "w") as f:
        for k in range(lines):
            f.write(line % k)
    tracemalloc.start()
    reader = LogReader(path, {"a/depth"})
    n = sum(1 for _ in reader)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert n == lines and reader.report.bad_lines == 0
    assert peak < 2_000_000  # [bytes]: a line at a time, not the file


# ------------------------------------------------------------------ the model
def _sensor(**kw):
    base = {"bag": "a", "quantity": "depth", "rate_Hz": 2.0, "noise": 0.0, "latency_s": 0.0,
            "dropout": 0.0}
    return Sensor(**{**base, **kw})


def test_the_model_samples_at_its_rate_with_its_noise_dropout_and_latency():
    t = np.arange(0.0, 1001.0)
    true = np.column_stack([t * 0.5, t * 0.5, t * 0.5])
    sensors = [_sensor(), _sensor(bag="b", noise=0.3, dropout=0.2), _sensor(bag="c",
                                                                            latency_s=1.25)]
    model = SensorModel(sensors, seed=7)
    model.add_rows(t[:400], true[:400])
    model.add_rows(t[400:], true[400:])
    got = model.delivered()
    a = [r for r in got if r.sensor == "a/depth"]
    assert [r.time_s for r in a] == list(np.arange(0, 2001) / 2.0)
    assert all(r.value == r.time_s * 0.5 for r in a)  # interpolated between rows, no noise
    b = np.array([(r.time_s, r.value) for r in got if r.sensor == "b/depth"])
    assert 0.15 < 1 - len(b) / 2001 < 0.25
    assert abs(np.std(b[:, 1] - b[:, 0] * 0.5) - 0.3) < 0.03
    # delivery order: c's readings 1.25 s late, so after a's of the next sample or two
    order = [r.sensor for r in got if r.sensor != "b/depth"][:6]
    assert order == ["a/depth", "a/depth", "a/depth", "c/depth", "a/depth", "c/depth"]


def test_the_readings_do_not_depend_on_the_chunks():
    t = np.arange(0.0, 101.0)
    true = np.column_stack([np.sin(t)])
    one = SensorModel([_sensor(noise=0.1, dropout=0.3)], seed=3)
    one.add_rows(t, true)
    many = SensorModel([_sensor(noise=0.1, dropout=0.3)], seed=3)
    for k in range(0, 101, 7):
        many.add_rows(t[k:k + 7], true[k:k + 7])
    assert one.delivered() == many.delivered()


# ------------------------------------------------------------------ the simulated log
@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    from flexlift.ascent.loop import prepare
    from flexlift.sensors.tap import run_with_log

    tmp = tmp_path_factory.mktemp("log")
    scenario = _scenario(sensors={"seed": 1, "depth": {"noise_m": 0.0},
                                  "pitch": {"noise_rad": 0.0, "at": ["hull", "bag_1"]},
                                  "sling_force": {"noise_N": 0.0},
                                  "fill_flow": {"noise_m3_s": 0.0, "rate_Hz": 0.5},
                                  "purge": None, "supply_pressure": {"noise_Pa": 0.0}},
                         faults=[{"kind": "supply_failure", "bag": "bag_2", "time_s": 100.0}])
    result, n = run_with_log(prepare(scenario, duration=300.0), tmp / "log.jsonl")
    readings = list(LogReader(tmp / "log.jsonl"))
    assert n == len(readings)
    return scenario, result, readings


def test_the_log_holds_the_loops_recorded_values(simulated):
    scenario, result, readings = simulated
    ds, depth = result.dataset, scenario.environment.water_depth_m
    by = {}
    for r in readings:
        by.setdefault(r.sensor, []).append((r.time_s, r.value))
    t = ds["time"].values
    for sensor, var, f in (("bag_3/depth", "height", lambda h: depth - h),
                           ("bag_1/pitch", "pitch_angle", lambda p: p),
                           ("bag_4/sling_force", "sling_force", lambda p: p)):
        got = np.array(by[sensor])
        want = f(ds[var].sel(bag="bag_" + sensor[4]).values)
        assert np.allclose(got[:, 1], np.interp(got[:, 0], t, want), rtol=1e-9, atol=1e-6), sensor
    hull = np.array(by["hull/pitch"])
    assert np.allclose(hull[:, 1], np.interp(hull[:, 0], t, ds["pitch"].values), atol=1e-12)
    assert len(by["bag_1/fill_flow"]) == 151  # 0.5 Hz over 0..300 s


def test_a_lost_supply_shows_in_its_pressure(simulated):
    _, _, readings = simulated
    p = [(r.time_s, r.value) for r in readings if r.sensor == "bag_2/supply_pressure"]
    before = [v for t, v in p if t < 99]
    after = [v for t, v in p if t > 101]
    assert min(before) > 2e5 and max(after) == pytest.approx(101_325.0, rel=0.02)
    other = [v for t, v in readings_of(readings, "bag_1/supply_pressure") if t > 101]
    assert min(other) > 2e5


def readings_of(readings, name):
    return [(r.time_s, r.value) for r in readings if r.sensor == name]


def test_simulate_sensor_log_cli(tmp_path, capsys):
    sc = tmp_path / "s.yaml"
    sc.write_text(json.dumps({**TOY, "sensors": {"depth": {"rate_Hz": 0.5}, "pitch": None,
                                                 "sling_force": None, "fill_flow": None,
                                                 "purge": None, "supply_pressure": None}}))
    log = tmp_path / "log.csv"
    assert main(["simulate", str(sc), "--duration", "60", "--sensor-log", str(log)]) == 0
    rows = list(LogReader(log))
    assert len(rows) == 31 * 7 and {r.sensor.split("/")[1] for r in rows} == {"depth"}
    capsys.readouterr()
    assert main(["simulate", str(sc), "--duration", "60", "--sensor-log", str(log)]) == 2
    err = capsys.readouterr().err
    assert "--sensor-log" in err and "already exists" in err and err.count("\n") == 1
    assert len(list(LogReader(log))) == len(rows)  # never overwritten


def test_a_sensor_faster_than_the_rows_is_refused(tmp_path, capsys):
    sc = tmp_path / "s.yaml"
    sc.write_text(json.dumps({**TOY, "sensors": {"depth": {"rate_Hz": 10}}}))
    assert main(["simulate", str(sc), "--duration", "10", "--sensor-log",
                 str(tmp_path / "l.jsonl")]) == 2
    err = capsys.readouterr().err
    assert "sensors.depth.rate_Hz" in err and "output_interval_s" in err
    assert not (tmp_path / "l.jsonl").exists()


def test_the_tanker_has_no_sensors_section():
    assert load_scenario("tanker").sensors is None
