"""``flexlift replay`` (estimate/replay.py, estimate/forecast.py, output/replay.py,
cli/replay.py): the estimator and the detector over a recorded log."""

import json

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent.loop import prepare
from flexlift.cli import main
from flexlift.sensors.tap import run_with_log

PULL_S = 240.0  # held on the seabed all along: the filter tracks it (test_estimator.py)


@pytest.fixture(scope="module")
def pull_log(tmp_path_factory):
    path = tmp_path_factory.mktemp("replay") / "pull.jsonl"
    run_with_log(prepare(load_scenario("tanker"), duration=PULL_S), path)
    return path


@pytest.fixture(scope="module")
def replayed(pull_log, tmp_path_factory):
    out = tmp_path_factory.mktemp("replay-out") / "out"
    code = main(["replay", str(pull_log), "tanker", "--out", str(out), "--members", "6",
                 "--forecast-every", "100", "--quiet"])
    return code, out, json.loads((out / "summary.json").read_text())


def test_a_fault_free_pull_raises_nothing_and_writes_the_folder(replayed):
    code, out, s = replayed
    assert code == 0 and s["alarms"] == []
    assert {p.name for p in out.iterdir()} >= {"summary.json", "estimates.nc", "replay.png",
                                               "report.html"}
    assert s["lift_time_s"] == pytest.approx(PULL_S, abs=2.0)
    f = s["filter"]
    assert f["assimilated"] > 0 and f["gated"] <= 0.01 * f["assimilated"]
    assert f["widened"] == 0 and f["rejected"] == 0
    assert s["log_report"]["bad_lines"] == 0


def test_the_forecasts_give_breakout_and_arrival_bands_of_every_member(replayed):
    _, _, s = replayed
    times = [f["time_s"] for f in s["forecasts"]]
    assert times == [100.0, 200.0]
    for f in s["forecasts"]:
        for key in ("breakout_time_s", "arrival_time_s", "separation_time_s"):
            b = f[key]
            # (a member whose hold outlasts the run has no breakout: the band is of those
            # that have one, and says how many)
            assert b["p5"] <= b["p50"] <= b["p95"] and 1 <= b["n"] <= f["members"] == 6, key
        assert f["breakout_time_s"]["p5"] > f["time_s"]  # still to come
        assert 0.0 <= f["p_unsafe"] <= 1.0


def test_the_estimated_histories_are_named_as_results_are(replayed):
    import xarray as xr

    _, out, s = replayed
    ds = xr.load_dataset(out / "estimates.nc")
    assert ds.height.dims == ("time", "quantile", "bag") and ds.height.attrs["units"] == "m"
    assert ds.holding_force.dims == ("time", "quantile")
    assert list(ds["quantile"].values) == [5.0, 50.0, 95.0]
    lo, mid, hi = ds.holding_force.values[-1]
    assert lo <= mid <= hi
    assert np.all(np.abs(ds.height.values[:, 1, :]) < 0.05)  # held on the seabed


def test_bad_lines_are_counted_by_reason_and_the_rest_replayed(pull_log, tmp_path):
    lines = pull_log.read_text().splitlines()[:2000]
    bad = [lines[0], "not json", '{"time": 1.0, "sensor": "bag_99/depth", "value": 1}',
           '{"time": "x", "sensor": "bag_1/depth", "value": 1}',
           '{"time": 2.0, "sensor": "bag_1/depth", "value": NaN}', *lines[1:],
           '{"time": 9']
    log = tmp_path / "bad.jsonl"
    log.write_text("\n".join(bad))  # the last line truncated
    out = tmp_path / "out"
    code = main(["replay", str(log), "tanker", "--out", str(out), "--members", "4",
                 "--forecast-every", "0", "--quiet"])
    s = json.loads((out / "summary.json").read_text())
    assert code == 0 and s["forecasts"] == []
    reasons = s["log_report"]["bad"]
    assert reasons.get("malformed", 0) >= 1 and reasons.get("unknown_sensor") == 1
    assert reasons.get("truncated_last_line") == 1
    assert s["filter"]["assimilated"] > 0


@pytest.mark.parametrize("argv, field", [
    (["--members", "1"], "--members"),
    (["--window", "-1"], "--window"),
    (["--forecast-every", "nan"], "--forecast-every"),
])
def test_bad_settings_are_one_line_and_exit_2(pull_log, tmp_path, capsys, argv, field):
    code = main(["replay", str(pull_log), "tanker", "--out", str(tmp_path / "o"), *argv])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and field in err[0]
    assert not (tmp_path / "o").exists()


def test_a_missing_log_is_one_line_and_exit_2(tmp_path, capsys):
    code = main(["replay", str(tmp_path / "none.jsonl"), "tanker", "--out",
                 str(tmp_path / "o")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "none.jsonl" in err[0]


def test_a_folder_not_flexlifts_is_refused_before_the_work(pull_log, tmp_path, capsys,
                                                          monkeypatch):
    import flexlift.estimate.replay as replay_module

    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    monkeypatch.setattr(replay_module, "replay", lambda *a, **k: pytest.fail("replayed"))
    code = main(["replay", str(pull_log), "tanker", "--out", str(mine)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "did not write" in err[0]
    assert (mine / "notes.txt").read_text() == "keep"
