"""Issue 23: a sweep's outcomes (safe, unsafe, not achieved, incomplete, failed to run) with
their probabilities, and a programming error in a case stops the sweep (exit 1) with the
finished cases kept, on every engine."""

from __future__ import annotations

import json

import pytest
import sweep_helpers as h
from test_sweep import SHORT, mc, write_spec

from flexlift.cli import main
from flexlift.sweep import aggregate as agg
from flexlift.sweep import parse_spec, run_sweep
from flexlift.sweep.executors import DaskEngine, Processes, Serial
from flexlift.sweep.worker import CaseError


def _result(outcome: str | None, criteria: dict, status: str = "completed") -> dict:
    return {"status": status, "outcome": outcome, "criteria": criteria, "headline": {},
            "error": None if status == "completed" else "numerics failed"}


def _records(results: list[dict]) -> dict:
    return {i: {"case": i, "status": r["status"], "values": {}, "results": {"m": r}}
            for i, r in enumerate(results)}


OK = {"pitch": True, "reached_target": True}


def test_outcomes_split_the_failure_probability_and_all_criteria_is_their_union():
    recs = _records([
        _result("safe", OK),
        _result("incomplete", {"pitch": True, "reached_target": False}),
        _result("unsafe", {"pitch": False, "reached_target": False}),
        _result("not_achieved", {"pitch": True, "reached_target": False}),
        _result(None, {}, status="failed"),
    ])
    fp = agg.failure_probability(recs, ["m"])["m"]
    op = agg.outcome_probability(recs, ["m"])["m"]
    # all criteria: any criterion failed, the incomplete run too (it did not hold the target)
    assert fp[agg.ALL]["failed"] == 4 and fp[agg.ALL]["n"] == 5
    assert fp["reached_target"]["failed"] == 4
    # each says over how many cases, and how the one incomplete case counts for it
    assert fp[agg.ALL]["incomplete"] == 1 and fp[agg.ALL]["incomplete_as"] == "failed"
    assert fp["reached_target"]["incomplete_as"] == "failed"
    assert fp["pitch"]["incomplete_as"] == "passed" and fp["pitch"]["failed"] == 2
    assert {k: w["failed"] for k, w in op.items()} == {
        "unsafe": 1, "not_achieved": 1, "failed": 1, "incomplete": 1}
    # Wilson's 95 % score interval of 1 in 5 (Wilson 1927; tabulated: 0.0362 - 0.6245)
    for w in op.values():
        assert w["p"] == 0.2
        assert w["low"] == pytest.approx(0.0362, abs=1e-4)
        assert w["high"] == pytest.approx(0.6245, abs=1e-4)
    # the worst-case ordering still ranks a failing outcome above an incomplete one
    assert [agg.failing(r["results"]["m"]) for r in recs.values()] == [False, False, True, True,
                                                                        True]


def test_all_criteria_is_the_union_of_the_criteria_on_hand_built_results():
    """Case by case, all_criteria fails exactly when some criterion fails."""
    crits = [{"pitch": True, "speed": True, "reached_target": True},
             {"pitch": False, "speed": True, "reached_target": True},
             {"pitch": True, "speed": False, "reached_target": True},
             {"pitch": True, "speed": True, "reached_target": False},
             {"pitch": False, "speed": False, "reached_target": False},
             {"pitch": True, "speed": True, "reached_target": True}]
    kinds = ["safe", "unsafe", "unsafe", "incomplete", "unsafe", "safe"]
    recs = _records([_result(k, c) for k, c in zip(kinds, crits, strict=True)])
    fp = agg.failure_probability(recs, ["m"])["m"]
    union = sum(not all(c.values()) for c in crits)
    assert union == 4
    assert fp[agg.ALL]["failed"] == union and fp[agg.ALL]["n"] == 6
    assert fp[agg.ALL]["failed"] >= max(fp[c]["failed"] for c in crits[0])
    ds_flags = agg.sensitivity(recs, ["m"], [])["m"]
    assert agg.ALL in ds_flags
    curve = agg.convergence(recs, ["m"])["m"]
    assert curve[agg.ALL][-1][0] == pytest.approx(union / 6)


def test_a_record_from_before_outcomes_reads_from_its_criteria():
    assert agg.outcome_of(_result(None, OK)) == "safe"
    assert agg.outcome_of(_result(None, {"pitch": False, "reached_target": True})) == "unsafe"
    assert agg.outcome_of(_result(None, {"pitch": True, "reached_target": False})) == \
        "not_achieved"


def test_a_sweep_whose_short_runs_end_incomplete_counts_them_apart(tmp_path):
    """A 10 m lift needs ~450 s: the 200 s run ends incomplete, the 2,000 s one is safe."""
    spec = parse_spec({"base": "tanker", "control": ["coordinated"], "set": dict(SHORT),
                       "grid": {"simulation.duration_s": [200, 2000]}})
    res = run_sweep(spec, tmp_path / "o", engine=Serial())
    short, long_ = (res.records[i]["results"]["coordinated"] for i in (0, 1))
    assert short["outcome"] == "incomplete" and long_["outcome"] == "safe"
    assert "the run ended at 200 s" in short["cause"]
    s = res.summary
    assert s["failure_probability"]["all_criteria"]["failed"] == 1  # the union: incomplete too
    assert s["failure_probability"]["all_criteria"]["incomplete"] == 1
    assert s["failure_probability"]["reached_target"]["failed"] == 1
    assert s["outcome_probability"]["incomplete"]["failed"] == 1
    assert s["outcome_probability"]["incomplete"]["n"] == 2
    html = (tmp_path / "o" / "report.html").read_text()
    assert "incomplete: every limit held, the run ended before the target was held" in html
    assert "safe in 1 of 2 cases (1 incomplete)" in html
    assert "the 1 incomplete case(s) count as failing reached target and all criteria" in html
    on_disk = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert on_disk["outcomes_by_control"]["coordinated"]["incomplete"]["failed"] == 1


def test_invalid_values_numerics_and_memory_are_data(monkeypatch):
    """The three failures a case can have are recorded; the sweep goes on."""
    import flexlift.sweep.plants as plants
    from flexlift import load_scenario
    from flexlift.sweep.worker import Task, run_case

    base = load_scenario("tanker").with_changes(**SHORT)

    def no_memory(*a, **k):
        raise MemoryError()

    monkeypatch.setattr(plants, "plant_for", no_memory)
    rec, _ = run_case(Task(0, base, {}, ("coordinated",), False))
    res = rec["results"]["coordinated"]
    assert rec["status"] == "failed" and res["outcome"] == "failed"
    assert res["error"].startswith("out of memory (11 elements, ")
    assert "60,000 time steps of 0.1 s" in res["error"]
    monkeypatch.undo()
    rec, _ = run_case(Task(1, base, {"lift.bag_lift_t": 20}, ("coordinated",), False))
    assert rec["status"] == "failed"
    assert rec["results"]["coordinated"]["error"].startswith("invalid scenario")


def test_a_programming_error_in_a_case_is_not_a_result(monkeypatch):
    import flexlift.sweep.plants as plants
    from flexlift import load_scenario
    from flexlift.sweep.worker import Task, run_case

    def bug(*a, **k):
        return {}["missing"]

    monkeypatch.setattr(plants, "plant_for", bug)
    base = load_scenario("tanker").with_changes(**SHORT)
    with pytest.raises(CaseError) as info:
        run_case(Task(7, base, {}, ("coordinated",), False))
    err = info.value
    assert (err.case, err.mode) == (7, "coordinated")
    assert "Traceback" in err.trace and "KeyError: 'missing'" in err.trace
    assert "case 7 (coordinated control) raised KeyError" in str(err)
    assert "not a result of the lift" in str(err)


@pytest.mark.parametrize("engine", ["serial", "processes", "dask"])
def test_a_case_that_raises_stops_the_sweep_and_keeps_the_finished_cases(engine, tmp_path):
    make = {"serial": Serial, "processes": lambda: Processes(2),
            "dask": lambda: DaskEngine(local_workers=2, processes=False)}[engine]
    spec = parse_spec(mc(samples=6))
    out = tmp_path / "o"
    with pytest.raises(CaseError) as info:
        run_sweep(spec, out, engine=h.Substitute(make(), h.bug_in_case))
    assert info.value.case == h.DIE_CASE and "ZeroDivisionError" in info.value.trace
    kept = sorted(p.name for p in (out / "cases").glob("case_*.json"))
    assert f"case_{h.DIE_CASE:04d}.json" not in kept  # no record claims the lift failed
    if engine == "serial":
        assert kept == ["case_0000.json", "case_0001.json"]
    assert not (out / "summary.json").exists()
    again = run_sweep(spec, out, engine=Serial())  # the rerun runs only what is missing
    assert again.skipped == len(kept) and again.ran == 6 - len(kept)
    assert again.completed == 6


def test_the_cli_stops_with_exit_1_the_traceback_and_the_rerun_command(tmp_path, capsys,
                                                                        monkeypatch):
    import flexlift.sweep.plants as plants

    real = plants.plant_for

    def bug_in_case_2(scenario, mode):  # the third case's scenario: the largest drag
        if scenario.hydro.drag_coefficient == max(drags):
            raise ZeroDivisionError("a bug")
        return real(scenario, mode)

    spec = write_spec(tmp_path / "s.yaml", mc(samples=4))
    from flexlift.sweep import load_spec
    from flexlift.sweep.cases import make_cases

    drags = [c.values["hydro.drag_coefficient"] for c in make_cases(load_spec(spec))]
    monkeypatch.setattr(plants, "plant_for", bug_in_case_2)
    out = tmp_path / "o"
    code = main(["sweep", str(spec), "--workers", "1", "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert code == 1
    assert "Traceback" in err and "ZeroDivisionError: a bug" in err
    bad = drags.index(max(drags))
    assert f"case {bad} (coordinated control) raised ZeroDivisionError" in err
    assert f"flexlift sweep {spec} --out {out}" in err and "to finish the sweep" in err
    assert len(list((out / "cases").glob("case_*.json"))) == bad
    monkeypatch.setattr(plants, "plant_for", real)
    assert main(["sweep", str(spec), "--workers", "1", "--out", str(out), "--quiet"]) == 0


def test_a_headline_that_names_a_bag_is_not_aggregated_as_a_number():
    """The run's headline may name which bag a peak belongs to (daf_pull_bag): the sweep's
    aggregation takes only the numbers, even when a failed case has none of them."""
    import numpy as np

    from flexlift.sweep.aggregate import headline_array, headline_names

    records = {0: {"status": "completed", "results": {"m": {"headline": {"a": 1.0, "b": "bag_1"}}}},
               1: {"status": "completed", "results": {"m": {"headline": {"a": None, "b": None}}}}}
    assert headline_names(records, "m") == ["a"]
    assert np.isnan(headline_array(records, "m", "a")[1])


def test_the_results_dataset_reads_each_modes_criteria_once(monkeypatch):
    """build_dataset is linear in the cases: each mode's criterion names are gathered once
    (they were gathered again for every case: 1.9 s of a 1,000-case sweep's end, growing with
    the square of the cases); the flags are the same."""
    from types import SimpleNamespace

    results = [_result("safe", OK), _result("unsafe", {"pitch": False, "reached_target": True}),
               _result(None, {}, status="failed")] * 20
    recs = _records(results)
    cases = [SimpleNamespace(index=i, values={}, seed=None) for i in recs]
    spec = SimpleNamespace(controls=["m"], keys=[])
    calls = []
    real = agg.criteria_names
    monkeypatch.setattr(agg, "criteria_names", lambda r, m: calls.append(m) or real(r, m))
    ds = agg.build_dataset(spec, cases, {i: f"case_{i:04d}" for i in recs}, recs, {})
    assert len(calls) == 1
    # the failed run fails every criterion
    assert ds["criterion_pitch"].values[:, 0].tolist() == [1, 0, 0] * 20
    assert ds["criterion_reached_target"].values[:, 0].tolist() == [1, 1, 0] * 20
