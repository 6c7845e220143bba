"""The ready uncertainty study, Sobol' indices and the stop at a half-width (issue 28)."""

import json
import math

import numpy as np
import pytest

from flexlift.cli import main
from flexlift.errors import InputError
from flexlift.sweep import aggregate as agg
from flexlift.sweep import parse_spec, run_sweep
from flexlift.sweep.cases import case_scenario, make_cases, uniforms
from flexlift.sweep.executors import Serial
from flexlift.sweep.run import halfwidths
from flexlift.sweep.sobol import indices, saltelli_design
from flexlift.sweep.studies import SOIL, bag_key

#: a short ascent of the tanker (10 m up, 20 s held, a quick breakout)
SHORT = {"control.target_height_m": 10, "simulation.hold_time_s": 20,
         "seabed.breakout_time_s": 40, "simulation.duration_s": 400}


def study(**mc):
    return {"base": "tanker", "control": "coordinated", "set": dict(SHORT), "study": "salvage",
            "monte_carlo": {"samples": 4, "seed": 2, **mc}}


# --------------------------------------------------------------------------- Sobol'
def ishigami(u):
    x = -math.pi + 2 * math.pi * u
    return np.sin(x[:, 0]) + 7 * np.sin(x[:, 1]) ** 2 + 0.1 * x[:, 2] ** 4 * np.sin(x[:, 0])


def test_sobol_indices_of_the_ishigami_function_are_its_closed_form():
    a, b = 7.0, 0.1
    v = a ** 2 / 8 + b * math.pi ** 4 / 5 + b ** 2 * math.pi ** 8 / 18 + 0.5
    v1 = 0.5 * (1 + b * math.pi ** 4 / 5) ** 2
    v2 = a ** 2 / 8
    v13 = b ** 2 * math.pi ** 8 * (1 / 18 - 1 / 50)
    s1 = {"x1": v1 / v, "x2": v2 / v, "x3": 0.0, "x4": 0.0}
    st = {"x1": (v1 + v13) / v, "x2": v2 / v, "x3": v13 / v, "x4": 0.0}
    keys = ["x1", "x2", "x3", "x4"]  # x4 does nothing: never a driver
    groups = {k: [k] for k in keys}
    u = saltelli_design(keys, groups, 2048, seed=5)
    assert u.shape == (2048 * 6, 4) and u.min() >= 0 and u.max() < 1
    res = indices(keys, groups, ishigami(u), seed=5)
    assert res["n_used"] == 2048
    for k in keys:
        g = res["groups"][k]
        assert g["S1"] == pytest.approx(s1[k], abs=0.03), (k, g)
        assert g["ST"] == pytest.approx(st[k], abs=0.03), (k, g)
        assert g["driver"] == (k != "x4"), (k, g)


def test_a_group_moves_together_and_missing_rows_drop_their_base_sample():
    keys = ["a", "b1", "b2"]
    groups = {"a": ["a"], "bags": ["b1", "b2"]}
    u = saltelli_design(keys, groups, 256, seed=1)
    rows = u.reshape(256, 4, 3)  # A, AB_a, AB_bags, B per base sample
    assert np.array_equal(rows[:, 2, 1:], rows[:, 3, 1:])  # the group swapped whole
    assert np.array_equal(rows[:, 2, 0], rows[:, 0, 0])
    y = u[:, 1] + u[:, 2]
    y[5] = np.nan
    res = indices(keys, groups, y, seed=1)
    assert res["n_used"] == 255
    assert res["groups"]["bags"]["ST"] == pytest.approx(1.0, abs=0.05)
    assert not res["groups"]["a"]["driver"]


# --------------------------------------------------------------------------- the study
def test_the_salvage_study_pins_the_plan_and_draws_each_bags_factor():
    spec = parse_spec(study())
    bags = [b.name for b in spec.base.lift.bags]
    assert len(bags) == 7 and all(bag_key(b) in spec.distributions for b in bags)
    assert "seabed.breakout_time_s" not in spec.distributions  # fixed under set: stays fixed
    assert spec.groups["lift.bags.capacity_factor"] == [bag_key(b) for b in bags]
    d = spec.distributions[SOIL]
    assert (d.kind, d.low, d.high) == ("uniform", 0.5, 1.5)
    sources = dict(spec.study.sources)
    assert "R-755" in sources[SOIL] and "25 %" in sources["lift.bags.capacity_factor"]
    cases = make_cases(spec)
    factors = [[c.values[bag_key(b)] for b in bags] for c in cases]
    assert len({round(f, 12) for f in factors[0]}) == 7  # one draw per bag
    # H0 = u x the nominal soil force, whatever the case's weight
    bf0, w0 = spec.study.breakout_factor, spec.study.wet_weight_t
    for c in cases:
        sc = case_scenario(spec, c)
        h0 = (sc.lift.breakout_factor - 1) * sc.hull.submerged_weight_t
        assert h0 == pytest.approx(c.values[SOIL] * (bf0 - 1) * w0, rel=1e-12)
        assert [b.capacity_factor for b in sc.lift.bags] == [c.values[bag_key(b)] for b in bags]
        assert [b.lift_t for b in sc.lift.bags] == pytest.approx([517.0] * 7)


def test_under_the_soil_law_the_study_varies_the_soils_keys():
    """A soil-law base (docs/theory/breakout-soil.md): u scales s_u (H0 = u x the nominal
    soil force, exactly) and the time's law is on c_v, not on the timer's T_b it ignores."""
    from flexlift.ascent.plant import coupled_plant

    spec = parse_spec({"base": "field-grieg-barge", "control": "open-loop", "study": "salvage",
                       "monte_carlo": {"samples": 4, "seed": 2}})
    assert "seabed.breakout_time_s" not in spec.distributions
    cv = spec.base.seabed.consolidation_coefficient_m2_s
    d = spec.distributions["seabed.consolidation_coefficient_m2_s"]
    assert (d.kind, d.low, d.high) == ("loguniform", 0.5 * cv, 2.0 * cv)
    assert "R-755" in dict(spec.study.sources)["seabed.consolidation_coefficient_m2_s"]
    h0 = float(coupled_plant(spec.base).seabed.H0.sum())
    for c in make_cases(spec)[:2]:
        sc = case_scenario(spec, c)
        assert sc.lift.breakout_factor == spec.base.lift.breakout_factor
        assert float(coupled_plant(sc).seabed.H0.sum()) == pytest.approx(c.values[SOIL] * h0,
                                                                          rel=1e-12)


def test_the_user_narrows_and_adds_ranges():
    spec = parse_spec(study(vary={SOIL: {"dist": "uniform", "low": 0.9, "high": 1.1},
                                  "lift.bags.capacity_factor": {"dist": "uniform", "low": 1.0,
                                                                "high": 1.1},
                                  "hydro.drag_coefficient": {"dist": "uniform", "low": 1.0,
                                                             "high": 1.4}}))
    assert spec.distributions[SOIL].high == 1.1
    assert spec.distributions[bag_key("bag_3")].high == 1.1
    assert "hydro.drag_coefficient" in spec.distributions
    sources = dict(spec.study.sources)
    assert sources[SOIL].startswith("NCEL R-755") and sources[SOIL].endswith("given in the SPEC")
    assert sources["hydro.drag_coefficient"] == "the SPEC"
    assert "given in the SPEC" not in sources["gas.fill_rate_max_m3_s"]


def test_a_study_resumed_from_its_folders_spec_is_the_same_sweep(tmp_path):
    from flexlift.sweep import load_spec

    spec = parse_spec(study(samples=2))
    run_sweep(spec, tmp_path / "o", engine=Serial())
    again = load_spec(tmp_path / "o" / "spec.yaml")
    assert again.checksum() == spec.checksum() and again.study.sources == spec.study.sources
    assert run_sweep(again, tmp_path / "o", engine=Serial()).ran == 0


@pytest.mark.parametrize("change, needles", [
    ({"study": "volcano"}, ["unknown study 'volcano'", "salvage"]),
    ({"monte_carlo": {"samples": 4, "vary": {SOIL: {"dist": "uniform", "low": -1, "high": 1}}}},
     ["soil.breakout_force_factor", "low -1 is outside", "[0, 4]"]),
    ({"monte_carlo": {"samples": 4, "vary": {"lift.bags.capacity_factor": {
        "dist": "uniform", "low": 0.5, "high": 11}}}}, ["high 11 is outside"]),
    ({"monte_carlo": {"samples": 4, "until_halfwidth": 0}}, ["until_halfwidth", "below 0.5"]),
    ({"monte_carlo": {"samples": 4, "until_halfwidth": 0.5}}, ["until_halfwidth", "below 0.5"]),
    ({"monte_carlo": {"samples": 8, "method": "sobol", "until_halfwidth": 0.1}},
     ["no probabilities"]),
    ({"monte_carlo": {"samples": 1, "method": "sobol"}},
     ["samples (--samples): got 1; Sobol indices need at least 8 base samples"]),
])
def test_bad_study_input_is_one_line(change, needles):
    data = {**study(), **change}
    with pytest.raises(InputError) as exc:
        parse_spec(data)
    msg = str(exc.value)
    assert "\n" not in msg
    for n in needles:
        assert n in msg, msg


def test_the_command_line_refuses_in_one_line_with_exit_2(tmp_path, capsys):
    import yaml

    grid = tmp_path / "grid.yaml"
    grid.write_text(yaml.safe_dump({"base": "tanker", "grid": {"seabed.breakout_time_s": [30]}}))
    for args, needle in ((["sweep", "--study", "volcano", "tanker"], "unknown study"),
                         (["sweep", str(grid), "--method", "sobol"], "Sobol indices need"),
                         (["sweep", "--study", "salvage", "tanker", "--method", "sobol",
                           "--samples", "1"], "at least 8 base samples"),
                         (["sweep", "--study", "salvage", "tanker", "--until-halfwidth", "0.7"],
                          "until_halfwidth")):
        assert main([*args, "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and needle in err[0], err
    assert not (tmp_path / "o").exists()


def test_bad_input_stops_the_workers_fork_server_the_command_started(tmp_path, capsys,
                                                                    monkeypatch):
    """``flexlift sweep`` starts its workers' fork server before it reads its input; when the
    input is refused (exit 2) the server is stopped with the command, not left to finish its
    preload (on a new machine, two minutes compiling the loop) in the background."""
    import os
    from multiprocessing import forkserver

    from flexlift.sweep import executors

    started, real = [], executors.start_forkserver

    def recording():
        ctx = real()
        started.append(forkserver._forkserver._forkserver_pid)
        return ctx

    monkeypatch.setattr(executors, "start_forkserver", recording)
    assert main(["sweep", "--workers", "2", "--study", "volcano", "tanker",
                 "--out", str(tmp_path / "o")]) == 2
    assert "unknown study" in capsys.readouterr().err
    assert started and started[0] is not None and set(started) == {started[0]}  # one server
    assert forkserver._forkserver._forkserver_pid is None
    with pytest.raises(ProcessLookupError):  # gone, and reaped
        os.kill(started[0], 0)


def test_a_study_runs_and_its_report_has_the_sources_and_the_convergence(tmp_path):
    spec = parse_spec(study(samples=3))
    res = run_sweep(spec, tmp_path / "o", engine=Serial())
    assert res.completed == 3
    s = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert s["study"]["name"] == "salvage"
    assert s["convergence"]["coordinated"]["n"][-1] == 3
    html = (tmp_path / "o" / "report.html").read_text()
    assert "R-755" in html and "Convergence" in html and "Wilson" in html


def test_a_study_gives_the_same_results_on_two_workers_as_in_one_process(tmp_path):
    from flexlift.sweep.executors import Processes

    spec = parse_spec(study(samples=4))
    one = run_sweep(spec, tmp_path / "one", engine=Serial())
    two = run_sweep(spec, tmp_path / "two", engine=Processes(2))
    where = ("pid", "host", "elapsed_s", "run_id", "attempts")
    same = [{i: {k: v for k, v in r.items() if k not in where} for i, r in res.records.items()}
            for res in (one, two)]
    assert same[0] == same[1] and len(same[0]) == 4


def test_a_sobol_study_gives_indices_and_no_probability(tmp_path):
    spec = parse_spec(study(samples=8, method="sobol",
                            vary={"disturbance.current_m_s": {"dist": "uniform", "low": 0,
                                                              "high": 0.01}}))
    assert spec.n_cases == 8 * (len(spec.groups) + 2)
    res = run_sweep(spec, tmp_path / "o", engine=Serial())
    s = res.summary
    assert s["failure_probability"] == {} and "sobol" in s
    assert set(s["sobol"]["coordinated"]) >= {"margin_ascent_velocity", "arrival_time_s"}
    assert "Which uncertainty matters" in (tmp_path / "o" / "report.html").read_text()
    again = run_sweep(spec, tmp_path / "o", engine=Serial())  # resumed: nothing to run
    assert again.ran == 0 and again.summary["sobol"] == s["sobol"]


# --------------------------------------------------------------------------- half-width
P_UNSAFE = 0.3


def known_case(task):
    """A case whose outcome is unsafe when its drag coefficient (uniform on [0, 1]) is below
    P_UNSAFE: P(unsafe) = P_UNSAFE exactly."""
    x = task.changes["hydro.drag_coefficient"]
    kind = "unsafe" if x < P_UNSAFE else "safe"
    res = {"status": "completed", "error": None, "outcome": kind, "cause": kind,
           "criteria": {"pitch": kind == "safe", "reached_target": True}, "headline": {},
           "reasons": {}, "events": [], "arrival_s": None, "scenario_checksum": None}
    return {"case": task.index, "values": dict(task.changes), "status": "completed",
            "results": {m: res for m in task.controls}, "warnings": [], "elapsed_s": 0.0}, {}


def halfwidth_spec(h, method="random", samples=5000, block=50):
    return parse_spec({"base": "tanker", "control": "coordinated",
                       "monte_carlo": {"samples": samples, "seed": 4, "method": method,
                                       "until_halfwidth": h, "block": block,
                                       "vary": {"hydro.drag_coefficient": {
                                           "dist": "uniform", "low": 0, "high": 1}}}})


@pytest.mark.parametrize("method", ["random", "lhs"])
def test_the_sweep_stops_at_the_first_block_end_within_the_half_width(method, tmp_path,
                                                                      monkeypatch):
    monkeypatch.setattr("flexlift.sweep.run.run_case", known_case)
    h = 0.05
    res = run_sweep(halfwidth_spec(h, method), tmp_path / "o", engine=Serial())
    n = len(res.records)
    assert n % 50 == 0 and 100 < n < 600  # about z^2 p (1 - p) / h^2 = 323
    assert max(halfwidths(res.records, ["coordinated"]).values()) <= h
    shorter = {i: r for i, r in res.records.items() if i < n - 50}
    assert max(halfwidths(shorter, ["coordinated"]).values()) > h  # the first such block end
    w = res.summary["outcome_probability"]["unsafe"]
    assert w["low"] <= P_UNSAFE <= w["high"] and w["n"] == n
    assert res.summary["stopped_at"] == n == res.summary["cases"]
    # resumable, and a narrower half-width goes on from there
    again = run_sweep(halfwidth_spec(h, method), tmp_path / "o", engine=Serial())
    assert again.ran == 0 and len(again.records) == n
    more = run_sweep(halfwidth_spec(0.03, method), tmp_path / "o", engine=Serial())
    assert more.ran == len(more.records) - n > 0
    assert max(halfwidths(more.records, ["coordinated"]).values()) <= 0.03


def test_the_progress_counts_failed_cases_as_they_come_and_those_resumed(tmp_path,
                                                                        monkeypatch):
    # the count is kept as records arrive (a recount per case was n^2 / 2 in a long sweep)
    statuses = []

    def failing_case(task):  # a failed case where the drag coefficient is below 0.2
        record, ds = known_case(task)
        if task.changes["hydro.drag_coefficient"] < 0.2:
            record["status"] = "failed"
            for res in record["results"].values():
                res.update(status="failed", error="numerics failed", outcome="failed",
                           criteria={k: False for k in res["criteria"]})
        statuses.append(record["status"] != "completed")
        return record, ds

    calls = []
    monkeypatch.setattr("flexlift.sweep.run.run_case", failing_case)
    first = run_sweep(halfwidth_spec(0.1), tmp_path / "o", engine=Serial(),
                      progress=lambda done, total, failed: calls.append((done, failed)))
    assert first.failed > 0
    # first the state it starts from, then a call per case
    assert calls == [(0, 0)] + [(k + 1, sum(statuses[:k + 1])) for k in range(len(statuses))]
    before, n = first.failed, len(first.records)
    statuses.clear(), calls.clear()
    more = run_sweep(halfwidth_spec(0.05), tmp_path / "o", engine=Serial(),
                     progress=lambda done, total, failed: calls.append((done, failed)))
    assert more.ran > 0 and more.failed > before
    assert calls == [(n, before)] + [(n + k + 1, before + sum(statuses[:k + 1]))
                                     for k in range(len(statuses))]
    assert calls[-1][1] == more.failed


def test_each_lhs_block_is_its_own_hypercube():
    spec = halfwidth_spec(0.1, "lhs", samples=120, block=40)
    u = uniforms(spec)
    for b in range(3):
        col = np.sort(u[40 * b:40 * (b + 1), 0])
        assert np.array_equal(np.floor(col * 40), np.arange(40))  # one point per stratum
    assert not np.array_equal(u[:40], u[40:80])  # each block its own draw
    head = uniforms(halfwidth_spec(0.1, "lhs", samples=80, block=40))
    assert np.array_equal(head, u[:80])  # a block does not depend on how many follow


def test_convergence_curve_is_each_probability_after_the_first_n_cases():
    records = {i: {"status": "completed", "values": {},
                   "results": {"m": {"status": "completed", "outcome": "unsafe" if i % 4 == 0
                                     else "safe", "criteria": {}}}} for i in range(40)}
    curve = agg.convergence(records, ["m"])["m"]
    assert curve["n"][0] == 1 and curve["n"][-1] == 40
    j = curve["n"].index(40)
    assert curve["unsafe"][j][0] == pytest.approx(0.25)
    assert curve["all_criteria"][j] == curve["unsafe"][j]
    w = agg.wilson(10, 40)
    assert curve["unsafe"][j][1:] == [w["low"], w["high"]]


# --------------------------------------------------------------------------- cheaper start
def test_the_latin_hypercube_and_the_ranks_are_scipys_without_importing_it():
    from scipy.stats import qmc
    from scipy.stats import rankdata as scipy_ranks

    from flexlift.sweep.aggregate import rankdata
    from flexlift.sweep.cases import _lhs

    for seed, d, n in ((0, 1, 1), (1, 3, 10), (7, 13, 500), (2 ** 40, 4, 7)):
        want = qmc.LatinHypercube(d=d, rng=np.random.default_rng(
            np.random.SeedSequence(seed))).random(n)
        assert np.array_equal(_lhs(d, n, np.random.SeedSequence(seed)), want), (seed, d, n)
    rng = np.random.default_rng(1)
    for _ in range(30):
        a = rng.integers(0, 5, size=int(rng.integers(1, 30))).astype(float)
        assert np.array_equal(rankdata(a), scipy_ranks(a))


def test_a_sweep_starts_its_workers_before_reading_the_spec():
    import subprocess
    import sys

    code = ("import sys, flexlift.cli as c\n"
            "c.build_parser = lambda *a: sys.exit('mods' + str(int('flexlift.ascent' in "
            "sys.modules)))\n"
            "from multiprocessing import forkserver\n"
            "try:\n    c.main(sys.argv[1:])\n"
            "except SystemExit as e:\n"
            "    print(e.code, forkserver._forkserver._forkserver_pid is not None)\n")
    for args, started in ((["sweep", "s.yaml", "--workers", "2"], True),
                          (["sweep", "s.yaml", "--workers", "1"], False),
                          (["sweep", "s.yaml", "--dask-local", "2"], False),
                          (["run", "tanker"], False)):
        out = subprocess.run([sys.executable, "-c", code, *args], capture_output=True,
                             text=True, timeout=120).stdout.split()
        assert out == ["mods0", str(started)], (args, out)


def test_a_study_runs_each_case_until_it_has_an_outcome(tmp_path):
    """Issue 40: a base whose 300 s run is too short for the study's slow breakouts (up to
    2 x 150 s, then a 10 m ascent of ~450 s): the study runs each case with duration_s auto,
    so no case ends incomplete; a duration the SPEC sets is kept."""
    base = tmp_path / "short.yaml"
    base.write_text("name: tanker\nsimulation:\n  duration_s: 300\n")
    fixed = {"control.target_height_m": 10, "simulation.hold_time_s": 20,
             "seabed.breakout_time_s": 150}
    data = {"base": str(base), "control": "coordinated", "set": fixed, "study": "salvage",
            "monte_carlo": {"samples": 3, "seed": 2}}
    spec = parse_spec(data)
    assert spec.base.simulation.duration_s == "auto"
    res = run_sweep(spec, tmp_path / "o", engine=Serial())
    kinds = [r["results"]["coordinated"]["outcome"] for r in res.records.values()]
    assert len(kinds) == 3 and "incomplete" not in kinds, kinds
    assert res.summary["failure_probability"]["all_criteria"]["incomplete"] == 0
    # without auto the same cases would have ended incomplete (the test can fail)
    kept = parse_spec({**data, "set": {**fixed, "simulation.duration_s": 300}})
    assert kept.base.simulation.duration_s == 300
    short = run_sweep(kept, tmp_path / "k", engine=Serial())
    assert all(r["results"]["coordinated"]["outcome"] == "incomplete"
               for r in short.records.values())
