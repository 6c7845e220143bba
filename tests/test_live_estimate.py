"""``flexlift live --estimate`` (live/estimate.py, estimate/watch.py): the estimator and the
fault detector on the lift's network readings, its members commanded by the master's own
commands, its alarms said, logged and reported."""

import json
import os
import subprocess
import sys
from importlib.resources import files

import pytest
from live_helpers import SENSORS

from flexlift.live.log import read_table

pytest.importorskip("flexlift.sensors.tap")

FAULT = """faults:
  - {kind: bag_rupture, bag: bag_3, time_s: 100.0}
"""
RUPTURE_S = 100.0


def test_live_estimate_names_a_rupture_within_30_s_and_nothing_before(tmp_path):
    """The tanker rig at 10x real time, bag_3 ruptured at 100 s (the hull held on the seabed,
    the master filling): the estimator's one alarm is that rupture, at that bag, within the
    issue's 30 s; it is said, in the log's alarms and in the report, with the forecasts."""
    path = tmp_path / "tanker-live.yaml"
    path.write_text((files("flexlift.scenarios") / "tanker.yaml").read_text() + SENSORS + FAULT)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "flexlift", "live", str(path), "--rig", "--speed", "10",
         "--until", "140", "--estimate", "--members", "8", "--forecast-every", "50",
         "--no-plan", "--no-dashboard", "--lift", "tk", "--out", str(out)],
        env=env, capture_output=True, text=True, timeout=240)
    assert proc.returncode == 0, proc.stderr
    est = json.loads((out / "report.json").read_text())["estimate"]
    assert est["error"] is None and est["unread"] == 0
    found = [(a["kind"], a["bag"]) for a in est["alarms"]]
    assert found == [("bag_rupture", "bag_3")], est["alarms"]
    delay = est["alarms"][0]["time_s"] - RUPTURE_S
    assert 0.0 < delay <= 30.0
    assert est["estimated_to_s"] >= 138.0 and est["behind_s"] < 5.0
    assert [f["time_s"] for f in est["forecasts"]][:2] == [50.0, 100.0]  # 140: the last
    assert all(f["under"] == "the commands as they stand, held" for f in est["forecasts"])
    for f in est["forecasts"]:  # and under the controller's advice, taking over then
        a = f["advice"]
        assert a["under"] == "the coordinated controller, taking over now", a
        assert a["arrival_time_s"] is not None and a["arrival_time_s"]["p50"] > f["time_s"]
    assert "ESTIMATOR bag_rupture bag_3" in proc.stdout
    logged = [(kind, source) for _, _, kind, source, _ in read_table(out / "live.sqlite",
                                                                      "alarms")
              if kind.startswith("estimator:")]
    assert logged == [("estimator:bag_rupture", "bag_3")]
    report = (out / "report.md").read_text()
    assert "What the estimator made of the readings" in report and "bag_rupture" in report


def test_live_with_no_reading_ends_saying_so_not_at_minus_infinity(tmp_path, capsys):
    """A broker nobody runs and a 2 s wall limit: live ends ``no_readings``, saying it ended
    before any reading came (not ``t = -inf s``), exit 1 (not arrived)."""
    import socket

    from flexlift.cli import main

    with socket.socket() as s:  # a free loopback port, closed again: nobody listens there
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    code = main(["live", "tanker", "--broker", f"mqtt://127.0.0.1:{port}", "--out",
                 str(tmp_path / "out"), "--wall-limit", "2", "--no-plan", "--no-dashboard"])
    out = capsys.readouterr().out
    assert code == 1
    assert "ended: no_readings before any reading came" in out and "-inf" not in out
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    assert report["lift"]["ended"] == "no_readings" and report["lift"]["end_time_s"] is None


def test_live_estimate_with_one_member_is_refused_before_writing(tmp_path, capsys):
    """``--estimate --members 1``: one line naming --members, exit 2, no folder."""
    from flexlift.cli import main

    code = main(["live", "tanker", "--out", str(tmp_path / "out"), "--estimate",
                 "--members", "1", "--no-dashboard"])
    err = capsys.readouterr().err
    assert code == 2 and "--members" in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()
