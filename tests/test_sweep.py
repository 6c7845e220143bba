"""flexlift sweep (issue 15): grids and Monte Carlo of short tanker ascents, the same case by
case on every engine, resumable, with failure probabilities and a report."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from flexlift.cli import main
from flexlift.output.folders import read_marker
from flexlift.plumbing.marker import JOURNAL
from flexlift.sweep import load_spec, parse_spec, run_sweep
from flexlift.sweep.cases import case_sequence, make_cases, uniforms
from flexlift.sweep.executors import DaskEngine, Processes, Serial

#: a short ascent of the tanker (10 m up, 20 s held, a quick breakout): ~0.06 s a case
SHORT = {"control.target_height_m": 10, "simulation.hold_time_s": 20,
         "seabed.breakout_time_s": 40}
#: the varied keys of the Monte Carlo (the breakout factor stays within the 7-bag plan)
VARY = {"lift.breakout_factor": {"dist": "uniform", "low": 1.28, "high": 1.32},
        "hydro.drag_coefficient": {"dist": "normal", "mean": 1.2, "std": 0.1, "low": 0.8},
        "disturbance.current_m_s": {"dist": "triangular", "low": -0.02, "mode": 0.0,
                                    "high": 0.02}}
#: what differs between runs of the same case (where and when it ran), never its results
WHERE = ("pid", "host", "elapsed_s", "run_id", "attempts")


def mc(samples=6, seed=3, method="lhs", vary=VARY, fixed=SHORT, control=("coordinated",)):
    return {"base": "tanker", "control": list(control), "set": dict(fixed),
            "monte_carlo": {"samples": samples, "seed": seed, "method": method,
                            "vary": dict(vary)}}


def grid(values=None, fixed=None, control=("coordinated", "decentralized")):
    fixed = dict(SHORT) if fixed is None else fixed
    fixed.pop("seabed.breakout_time_s", None)
    return {"base": "tanker", "control": list(control), "set": fixed,
            "grid": values or {"seabed.breakout_time_s": [30, 60],
                               "control.breakout_pull_t": [150]}}


def results(res) -> dict:
    """Every case's record without where and when it ran."""
    return {i: {k: v for k, v in r.items() if k not in WHERE} for i, r in res.records.items()}


def one_line(capsys, *needles) -> str:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]


def write_spec(path: Path, data: dict) -> Path:
    import yaml

    path.write_text(yaml.safe_dump(data, sort_keys=False))
    return path


# --------------------------------------------------------------------------- engines agree
@pytest.mark.parametrize("kind", ["grid", "monte_carlo"])
def test_same_results_case_by_case_serially_on_processes_and_on_dask(kind, tmp_path):
    spec = parse_spec(grid() if kind == "grid" else mc())
    serial = run_sweep(spec, tmp_path / "serial", engine=Serial())
    procs = run_sweep(spec, tmp_path / "procs", engine=Processes(2))
    dask = run_sweep(spec, tmp_path / "dask", engine=DaskEngine(local_workers=2,
                                                                 processes=False))
    assert serial.completed == spec.n_cases == (2 if kind == "grid" else 6)
    assert results(serial) == results(procs) == results(dask)
    assert {r["pid"] for r in procs.records.values()} - {os.getpid()}  # really elsewhere
    assert (serial.engine, procs.engine, dask.engine) == ("serial", "processes", "dask")
    # the cases differ from each other: the keys really reached the simulation
    heads = [json.dumps(r["results"]["coordinated"]["headline"]) for r in serial.records.values()]
    assert len(set(heads)) == len(heads)
    a = xr.open_dataset(tmp_path / "serial" / "results.nc", engine="scipy").load()
    b = xr.open_dataset(tmp_path / "dask" / "results.nc", engine="scipy").load()
    for v in a.data_vars:
        if v != "elapsed_s":
            np.testing.assert_array_equal(a[v].values, b[v].values, err_msg=v)


def test_a_case_runs_as_flexlift_simulate_runs_it(tmp_path):
    """The sweep's worker (with its reused plants) gives what a plain simulate gives."""
    from flexlift.ascent import simulate
    from flexlift.sweep.cases import case_scenario

    spec = parse_spec(mc(samples=3))
    res = run_sweep(spec, tmp_path / "o", engine=Serial())
    for case in make_cases(spec):
        plain = simulate(case_scenario(spec, case), control="coordinated")
        got = res.records[case.index]["results"]["coordinated"]
        assert got["headline"] == plain.headline and got["criteria"] == plain.criteria


def _same_records(a, b):
    """Two plants' loop records equal array for array."""
    for name, record in a.records._asdict().items():
        for f in record._fields:
            assert np.array_equal(np.asarray(getattr(record, f)),
                                  np.asarray(getattr(getattr(b, name), f))), (name, f)


def test_reused_plants_are_the_plants_a_fresh_build_gives(tanker):
    from flexlift.ascent.paper import paper_plant
    from flexlift.ascent.plant import coupled_plant
    from flexlift.sweep import plants

    before = plants.stats()["plants"]["hits"]
    for change in ({}, {"disturbance.current_m_s": 0.05}, {"control.breakout_pull_t": 120},
                   {"seabed.breakout_time_s": 300}, {"hydro.drag_coefficient": 1.0},
                   {"lift.breakout_factor": 1.31}, {"hull.modal_damping": 0.03}, {}):
        s = tanker.with_changes(**change)
        _same_records(plants.plant_for(s, "coordinated"), coupled_plant(s))
    _same_records(plants.plant_for(tanker, "paper"), paper_plant(tanker))
    assert plants.stats()["plants"]["hits"] >= before + 3  # {} twice, current, pull
    # a plant of a pipeline (read from keys of its pipe section), then a tanker (no pipe)
    from flexlift import load_scenario

    line = load_scenario("pipeline").with_changes(**{"pipe.elements": 40})
    memo = plants.ReadMemo()

    def build(view):
        return coupled_plant(view), ()

    pl, keys = memo.get(line, build)
    assert any(k.startswith("pipe.") for k in keys)
    _same_records(pl, coupled_plant(line))
    _same_records(memo.get(tanker, build)[0], coupled_plant(tanker))
    assert memo.get(line, build)[0] is pl and memo.hits == 1


def test_a_kept_results_key_tells_apart_what_a_build_could_tell_apart(tanker):
    """The plant caches compare each key's value exactly: a section or list of bags by its
    values' pickle, so one bag's float changed in its last bit, -0.0 for 0.0, 1 for 1.0 and
    None for a value are other keys; the same values are the same key."""
    from flexlift.sweep.plants import _canonical, _value

    bags = [{"name": f"p{i}", "kind": "external", "x_m": x, "lift_t": 600.0}
            for i, x in enumerate((10.0, 30.0))]
    base = tanker.with_changes(**{"lift.bags": bags})
    key = _value(base, "lift.bags")
    assert key == _value(tanker.with_changes(**{"lift.bags": [dict(b) for b in bags]}),
                         "lift.bags")
    nudged = [bags[0], {**bags[1], "x_m": float(np.nextafter(30.0, 31.0))}]
    for other in (nudged, [bags[0], {**bags[1], "lift_t": None}]):
        assert _value(tanker.with_changes(**{"lift.bags": other}), "lift.bags") != key
    assert _canonical(-0.0) != _canonical(0.0) and _canonical(1) != _canonical(1.0)
    assert _value(base, "lift") != _value(base.with_changes(
        **{"lift.breakout_factor": float(np.nextafter(base.lift.breakout_factor, 2.0))}), "lift")


def test_a_kept_geometry_serves_the_cases_that_change_the_gas_the_hold_or_the_factor(tanker):
    """A case that changes the breakout factor (a new plan: its required lift), the valves or
    the breakout time gets a plant built on the kept geometry, equal array for array to a
    fresh build; one that changes what the geometry reads (the damping, the pinned bags'
    points) gets a new geometry; and the geometry reads of the plan only what the reuse
    compares (GEOMETRY_READS)."""
    from flexlift.ascent.plant import GEOMETRY_READS, coupled_plant, plant_geometry
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario
    from flexlift.sweep import plants

    bags = [{"name": f"p{i}", "kind": "external", "x_m": x, "lift_t": 600.0}
            for i, x in enumerate((10.0, 30.0, 50.0, 68.0))]
    base = tanker.with_changes(**{"lift.bags": bags})
    plants.plant_for(base, "coordinated")
    for change, reused in (({"lift.breakout_factor": 1.31}, True),
                           ({"gas.purge_rate_max_m3_s": 1.7, "seabed.breakout_time_s": 250.0},
                            True),
                           ({"lift.breakout_factor": 1.2, "gas.fill_rate_max_m3_s": 0.45}, True),
                           ({"hull.modal_damping": 0.03}, False),
                           ({"lift.bags": [{**b, "x_m": b["x_m"] + 1.0} for b in bags]}, False)):
        s = base.with_changes(**change)
        before = plants.stats()["geometry"]
        _same_records(plants.plant_for(s, "coordinated"), coupled_plant(s))
        after = plants.stats()["geometry"]
        assert (after["hits"] - before["hits"], after["misses"] - before["misses"]) == (
            (1, 0) if reused else (0, 1)), change
    read = set()
    plan = plan_lift(base, hull_from_scenario(base))

    class Recording:
        def __getattr__(self, name):
            read.add(name)
            return getattr(plan, name)

    plant_geometry(base, hull_from_scenario(base), Recording())
    assert read == set(GEOMETRY_READS)


def test_reused_modes_are_the_modes_of_the_same_beam(tanker_hull):
    from flexlift.structure.beam import assemble
    from flexlift.structure.modes import compute_modes, reusing_modes

    store = {}
    wet = assemble(tanker_hull, extra_mass_per_length=1000.0)
    with reusing_modes(store):
        a, b = compute_modes(tanker_hull), compute_modes(tanker_hull)
        c = compute_modes(wet, n_modes=8)
        d = compute_modes(assemble(tanker_hull, extra_mass_per_length=1000.0), n_modes=8)
    assert a is b and c is d and len(store) == 2
    fresh = compute_modes(tanker_hull)  # outside the block: solved again, the same numbers
    assert fresh is not a
    np.testing.assert_array_equal(fresh.omega, a.omega)
    np.testing.assert_array_equal(fresh.phi, a.phi)
    assert not np.array_equal(compute_modes(wet, n_modes=8).omega, compute_modes(
        assemble(tanker_hull), n_modes=8).omega)  # a different beam: other modes


def test_a_grid_is_the_product_of_its_lists_the_last_key_fastest():
    spec = parse_spec(grid({"seabed.breakout_time_s": [30, 60],
                            "control.breakout_pull_t": {"low": 100, "high": 200, "num": 3},
                            "hull.elements": {"low": 10, "high": 40, "num": 3, "scale": "log"}}))
    values = [tuple(c.values.values()) for c in make_cases(spec)]
    assert len(values) == spec.n_cases == 18
    assert values[:4] == [(30, 100.0, 10), (30, 100.0, 20), (30, 100.0, 40), (30, 150.0, 10)]
    assert values[-1] == (60, 200.0, 40) and all(c.seed is None for c in make_cases(spec))


# --------------------------------------------------------------------------- seeds
def test_seeds_reproduce_and_each_case_has_its_own_stream():
    for method in ("lhs", "random"):
        a, b = parse_spec(mc(samples=20, method=method)), parse_spec(mc(samples=20, method=method))
        assert np.array_equal(uniforms(a), uniforms(b))
        assert [c.values for c in make_cases(a)] == [c.values for c in make_cases(b)]
        other = parse_spec(mc(samples=20, seed=4, method=method))
        assert not np.array_equal(uniforms(a), uniforms(other))
    # case i's stream is SeedSequence(seed).spawn(N)[i], and does not depend on N (plain MC)
    kids = np.random.SeedSequence(3).spawn(20)
    for i in (0, 7, 19):
        assert case_sequence(3, i).generate_state(4).tolist() == kids[i].generate_state(4).tolist()
    small, big = parse_spec(mc(samples=5, method="random")), parse_spec(mc(samples=50, method="random"))
    assert [c.values for c in make_cases(small)] == [c.values for c in make_cases(big)][:5]
    assert len({c.seed for c in make_cases(big)}) == 50  # each case its own noise seed


def test_latin_hypercube_stratifies_and_distributions_keep_their_bounds():
    n = 200
    spec = parse_spec(mc(samples=n, fixed={}, vary={
        "seabed.breakout_time_s": {"dist": "lognormal", "median": 400, "sigma": 0.3,
                                   "high": 600},
        "hydro.drag_coefficient": {"dist": "normal", "mean": 1.2, "std": 0.1, "low": 1.1},
        "lift.breakout_factor": {"dist": "uniform", "low": 1.2, "high": 1.5},
        "control.mode": {"dist": "choice", "values": ["coordinated", "decentralized"],
                         "weights": [3, 1]},
        "hull.elements": {"dist": "uniform", "low": 10, "high": 20}}))
    u = uniforms(spec)
    for j in range(u.shape[1]):  # one sample in each of the n strata of every key
        assert sorted(np.floor(u[:, j] * n).astype(int).tolist()) == list(range(n))
    cases = make_cases(spec)
    tb = np.array([c.values["seabed.breakout_time_s"] for c in cases])
    cd = np.array([c.values["hydro.drag_coefficient"] for c in cases])
    assert tb.max() <= 600 and abs(np.median(tb[tb < 550]) - 390) < 40
    assert cd.min() >= 1.1
    modes = [c.values["control.mode"] for c in cases]
    assert abs(modes.count("coordinated") / n - 0.75) < 0.02
    assert all(isinstance(c.values["hull.elements"], int) for c in cases)


# --------------------------------------------------------------------------- resumable
def test_killed_midway_and_rerun_loses_no_case_and_runs_none_twice(tmp_path):
    n = 20
    spec_file = write_spec(tmp_path / "s.yaml", mc(samples=n))
    out = tmp_path / "out"
    proc = subprocess.Popen([sys.executable, "-m", "flexlift", "sweep", str(spec_file),
                             "--workers", "2", "--out", str(out), "--quiet"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and len(list(out.glob("cases/case_*.json"))) < 3:
        assert proc.poll() is None
        time.sleep(0.01)
    helpers = _descendants(proc.pid)  # the fork server and the workers
    proc.send_signal(signal.SIGKILL)
    proc.wait(30)
    deadline = time.monotonic() + 30  # orphaned, the workers end themselves
    while time.monotonic() < deadline and [p for p in helpers if _running(p)]:
        time.sleep(0.1)
    assert len(helpers) >= 3 and not [p for p in helpers if _running(p)]
    first = {p.name: p.read_bytes() for p in out.glob("cases/case_*.json")}
    assert 3 <= len(first) < n, len(first)
    assert read_marker(out)["complete"] is False
    spec = load_spec(spec_file)
    res = run_sweep(spec, out, engine=Serial())
    assert res.skipped == len(first) and res.ran == n - len(first)
    assert res.completed == n
    by_run = {}
    for r in res.records.values():
        by_run.setdefault(r["run_id"], set()).add(r["case"])
    assert len(by_run) == 2 and sum(map(len, by_run.values())) == n  # each case once
    for name, data in first.items():  # the first run's cases are kept as they were
        assert (out / "cases" / name).read_bytes() == data
    assert read_marker(out)["complete"] is True
    assert not [p for p in out.rglob(".*") if p.name != ".flexlift-output"]  # no leftovers
    # the same results as a sweep run in one go
    whole = run_sweep(spec, tmp_path / "whole", engine=Serial())
    assert results(whole) == results(res)


def _descendants(pid: int) -> list[int]:
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        try:
            kids = Path(f"/proc/{p}/task/{p}/children").read_text().split()
        except OSError:
            continue
        out += [int(k) for k in kids]
        todo += [int(k) for k in kids]
    return out


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state not in ("Z", "X")


def test_interrupted_rerun_of_a_finished_sweep_runs_nothing(tmp_path):
    spec = parse_spec(mc(samples=3))
    run_sweep(spec, tmp_path / "o", engine=Serial())
    again = run_sweep(spec, tmp_path / "o", engine=Serial())
    assert again.skipped == 3 and again.ran == 0


def test_a_dead_worker_is_retried_once_then_its_case_is_lost(tmp_path):
    import sweep_helpers as h

    spec = parse_spec(mc(samples=5, fixed={**SHORT, "description": str(tmp_path / "died")}))
    once = run_sweep(spec, tmp_path / "once", engine=h.Substitute(Processes(1), h.dies_once))
    assert (tmp_path / "died").exists()
    assert once.completed == 5 and once.records[h.DIE_CASE]["attempts"] == 2
    always = run_sweep(spec, tmp_path / "always", engine=h.Substitute(Processes(1), h.dies_always))
    lost = always.records[h.DIE_CASE]
    assert lost["status"] == "lost" and "worker died twice" in lost["error"]
    assert always.completed == 4 and always.summary["lost"] == 1
    assert results(once)[0] == results(always)[0]  # the others were not disturbed
    # a rerun tries the lost case again (it is not finished)
    again = run_sweep(spec, tmp_path / "always", engine=Serial())
    assert again.ran == 1 and again.completed == 5


# --------------------------------------------------------------------------- outcomes
def test_a_plan_built_to_fail_fails_with_probability_one_and_the_nominal_tanker_almost_never(
        tmp_path):
    bad = parse_spec(mc(samples=8, fixed={**SHORT, "limits.ascent_velocity_m_s": 0.1}))
    res = run_sweep(bad, tmp_path / "bad", engine=Serial())
    fp = res.summary["failure_probability"]
    assert res.completed == 8
    assert fp["ascent_velocity"]["p"] == 1.0 and fp["all_criteria"]["p"] == 1.0
    assert fp["ascent_velocity"]["low"] == pytest.approx(0.6756, abs=1e-4)  # Wilson, 8 of 8
    assert fp["pitch"]["p"] == 0.0
    nominal = run_sweep(parse_spec(mc(samples=8)), tmp_path / "nominal", engine=Serial())
    fp = nominal.summary["failure_probability"]
    assert fp["all_criteria"]["p"] == 0.0 and fp["all_criteria"]["high"] < 0.35


def test_every_case_failing_is_exit_1_with_the_most_common_failure(tmp_path, capsys):
    # 20 t bags cannot hold the tanker neutral: every case is an invalid lift
    spec = write_spec(tmp_path / "s.yaml", mc(samples=3, fixed={**SHORT, "lift.bag_lift_t": 20}))
    assert main(["sweep", str(spec), "--workers", "1", "--out", str(tmp_path / "o"),
                 "--quiet"]) == 1
    line = one_line(capsys, "every case failed", "3 of 3", "wet weight")
    assert "Traceback" not in line


def test_numerics_failing_in_one_case_is_recorded_and_the_sweep_goes_on(tmp_path, monkeypatch):
    import flexlift.ascent.loop as loop

    real = loop.kernel.advance  # (in this process: --workers 1)

    def corrupting(loop, k_stop):  # the numerics blow up when the current runs
        if loop.switches.current[0] > 0 and loop.state.counters[0] * loop.settings.dt > 50.0:
            loop.state.q[:] = np.nan
        return real(loop, k_stop)

    monkeypatch.setattr(loop.kernel, "advance", corrupting)
    monkeypatch.setattr(loop, "QUIET_CHUNK_STEPS", loop.CHUNK_STEPS)  # calls every 200 s
    spec = parse_spec(grid({"disturbance.current_m_s": [0.0, 0.01, 0.0]},
                           control=("coordinated",)))
    res = run_sweep(spec, tmp_path / "o", engine=Serial())
    ok, broken = res.records[0], res.records[1]
    assert ok["status"] == res.records[2]["status"] == "completed"
    assert broken["status"] == "failed"
    assert "numerics failed" in broken["results"]["coordinated"]["error"]
    end = broken["results"]["coordinated"]["headline"]["end_time_s"]
    assert end < ok["results"]["coordinated"]["headline"]["end_time_s"]  # partial results
    fp = res.summary["failure_probability"]
    assert fp["all_criteria"]["failed"] == 1 and fp["pitch"]["failed"] == 1  # unknown: failed
    assert res.summary["failures"][0]["case"] == 1


# --------------------------------------------------------------------------- the files
def test_outputs_netcdf_summary_report_and_exact_reruns(tmp_path, capsys):
    spec_file = write_spec(tmp_path / "s.yaml", {**mc(samples=6), "worst": 2})
    out = tmp_path / "o"
    assert main(["sweep", str(spec_file), "--workers", "1", "--out", str(out), "--json"]) == 0
    j = json.loads(capsys.readouterr().out)
    assert set(j) == {"cases", "completed", "failed", "engine", "failure_probability",
                      "sensitivity", "out"}
    assert (j["cases"], j["completed"], j["failed"], j["engine"]) == (6, 6, 0, "serial")
    assert Path(j["out"]) == out.resolve()
    for crit, w in j["failure_probability"].items():
        assert set(w) == {"p", "low", "high", "n", "incomplete", "incomplete_as"}, crit
        assert 0 <= w["low"] <= w["p"] <= w["high"] <= 1 and w["n"] == 6, crit
    for crit, ranked in j["sensitivity"].items():
        assert all(isinstance(k, str) and -1 <= s <= 1 for k, s in ranked), crit
    ds = xr.open_dataset(out / "results.nc", engine="scipy").load()
    assert ds.sizes["case"] == 6 and list(ds.control.values) == ["coordinated"]
    for key in VARY:
        assert key in ds.coords and ds[key].dims == ("case",)
    assert "criterion_ascent_velocity" in ds and "max_ascent_velocity_ms" in ds
    assert ds["max_ascent_velocity_ms"].attrs["units"] == "m/s"
    assert set(ds["status"].values.tolist()) == {"completed"}
    summary = json.loads((out / "summary.json").read_text())
    assert summary["cases"] == 6 and len(summary["worst"]["coordinated"]) == 2
    html = (out / "report.html").read_text()
    for text in ("Wilson", "Spearman", "Worst cases", "data:image/png;base64",
                 "flexlift run rerun/"):
        assert text in html, text
    # each worst case reruns exactly: the same scenario, the same numbers
    from flexlift import load_scenario
    from flexlift.ascent import simulate

    for w in summary["worst"]["coordinated"]:
        path = out / "rerun" / f"{w['name']}.yaml"
        record = json.loads((out / "cases" / f"{w['name']}.json").read_text())
        scenario = load_scenario(path)
        again = simulate(scenario, control="coordinated")
        assert scenario.checksum() == record["results"]["coordinated"]["scenario_checksum"]
        assert again.headline == record["results"]["coordinated"]["headline"]
    assert main(["run", str(path), "--control", "coordinated", "--stages", "simulate",
                 "--out", str(tmp_path / "rerun"), "--quiet", "--json"]) == 0
    run = json.loads(capsys.readouterr().out)
    assert run["stages"]["simulate"]["coordinated"]["max_ascent_velocity_ms"] == \
        record["results"]["coordinated"]["headline"]["max_ascent_velocity_ms"]


def test_a_users_fis_controller_is_found_beside_the_spec(tmp_path, tanker):
    from flexlift import load_scenario
    from flexlift.fuzzy.fis import to_fis_text
    from flexlift.fuzzy.rulebase import supervisor_fis_from

    fis = tmp_path / "ctl" / "mine.fis"
    fis.parent.mkdir()
    fis.write_text(to_fis_text(supervisor_fis_from(tanker.control.supervisor)))
    spec_file = write_spec(tmp_path / "s.yaml", grid(
        {"control.supervisor.fis_file": [None, "ctl/mine.fis"]}, control=("coordinated",)))
    elsewhere = tmp_path / "cwd"
    elsewhere.mkdir()
    os.chdir(elsewhere)  # the file is found beside the SPEC, not in the working directory
    try:
        res = run_sweep(load_spec(spec_file), tmp_path / "o", engine=Serial())
    finally:
        os.chdir(tmp_path)
    assert res.completed == 2
    built_in, mine = (res.records[i]["results"]["coordinated"]["headline"] for i in (0, 1))
    assert mine["max_ascent_velocity_ms"] == pytest.approx(built_in["max_ascent_velocity_ms"],
                                                           abs=1e-3)
    rerun = load_scenario(tmp_path / "o" / "rerun" / "case_0001.yaml")
    assert rerun.control.supervisor.fis_file == str(fis.resolve())


def test_a_pipeline_sweep_varies_the_keys_of_its_pipe_section(tmp_path):
    spec = parse_spec({"base": "pipeline", "control": ["coordinated"],
                       "set": {"pipe.elements": 50, "pipe.lift_points.spacing_m": 100.0,
                               "simulation.retained_flexible_modes": 4},
                       "grid": {"pipe.coating_thickness_m": [0.05, 0.07]}})
    res = run_sweep(spec, tmp_path / "o", engine=Serial())
    assert res.completed == 2
    gas = [r["results"]["coordinated"]["headline"]["gas_total_free_air_m3"]
           for r in res.records.values()]
    assert gas[1] > gas[0]  # a heavier coat: more gas to lift it


def test_keep_histories_writes_every_cases_time_histories(tmp_path):
    spec = parse_spec({**mc(samples=2), "keep": "histories"})
    res = run_sweep(spec, tmp_path / "o", engine=Serial())
    nc = sorted(p.name for p in (tmp_path / "o" / "cases").glob("*.nc"))
    assert nc == ["case_0000_coordinated.nc", "case_0001_coordinated.nc"]
    ds = xr.open_dataset(tmp_path / "o" / "cases" / nc[0], engine="scipy")
    assert "height" in ds and ds.sizes["time"] > 10
    assert res.records[0]["histories"] == ["case_0000_coordinated.nc"]
    again = run_sweep(spec, tmp_path / "o", engine=Serial())  # recognised as its own
    assert again.skipped == 2


def test_progress_bar_on_stderr_and_quiet(tmp_path, capsys):
    spec = write_spec(tmp_path / "s.yaml", mc(samples=2))
    assert main(["sweep", str(spec), "--workers", "1", "--out", str(tmp_path / "a")]) == 0
    cap = capsys.readouterr()
    assert "2/2" in cap.err and "failed" in cap.err and "report:" in cap.out
    assert main(["sweep", str(spec), "--workers", "1", "--out", str(tmp_path / "b"),
                 "--quiet"]) == 0
    cap = capsys.readouterr()
    assert cap.err == "" and cap.out == ""


# --------------------------------------------------------------------------- the folder
def test_the_folder_is_flexlifts_own_and_a_rerun_knows_it(tmp_path, capsys):
    spec_file = write_spec(tmp_path / "s.yaml", mc(samples=2))
    users = tmp_path / "thesis"
    users.mkdir()
    (users / "draft.tex").write_text("years of work")
    assert main(["sweep", str(spec_file), "--out", str(users), "--workers", "1"]) == 2
    one_line(capsys, "did not write")
    assert os.listdir(users) == ["draft.tex"]
    out = tmp_path / "o"
    assert main(["sweep", str(spec_file), "--out", str(out), "--workers", "1", "--quiet"]) == 0
    # another SPEC into it: refused, nothing touched
    other = write_spec(tmp_path / "t.yaml", mc(samples=3))
    before = sorted(p.relative_to(out).as_posix() for p in out.rglob("*"))
    assert main(["sweep", str(other), "--out", str(out), "--workers", "1"]) == 2
    one_line(capsys, "another `flexlift sweep`")
    # a user's file inside it: refused, kept
    (out / "cases" / "notes.txt").write_text("mine")
    assert main(["sweep", str(spec_file), "--out", str(out), "--workers", "1"]) == 2
    one_line(capsys, "notes.txt", "did not write")
    (out / "cases" / "notes.txt").unlink()
    after = sorted(p.relative_to(out).as_posix() for p in out.rglob("*"))
    assert after == before
    # a user's file named like a case but not one of ours: refused, never overwritten
    fake = out / "cases" / "case_0007.json"
    fake.write_text('{"case": 7}')
    assert main(["sweep", str(spec_file), "--out", str(out), "--workers", "1"]) == 2
    one_line(capsys, "case_0007.json")
    assert fake.read_text() == '{"case": 7}'
    fake.unlink()
    (out / "cases" / "case_0001.json").unlink()
    # a user's file named like a temporary of ours, listed nowhere: refused, never deleted
    look_alike = out / "cases" / ".case_0001.json.notes123.tmp"
    look_alike.write_text("the user's")
    assert main(["sweep", str(spec_file), "--out", str(out), "--workers", "1"]) == 2
    one_line(capsys, ".case_0001.json.notes123.tmp", "did not write")
    assert look_alike.read_text() == "the user's"
    look_alike.unlink()
    # our own temporary leftover (its name journaled before a killed write created it) is
    # removed; the rerun redoes the missing case only
    (out / "cases" / ".case_0001.json.abcd1234.tmp").write_text("half")
    (out / JOURNAL).write_text(json.dumps("cases/.case_0001.json.abcd1234.tmp") + "\n")
    res = run_sweep(load_spec(spec_file), out, engine=Serial())
    assert res.ran == 1 and res.skipped == 1
    assert not (out / "cases" / ".case_0001.json.abcd1234.tmp").exists()
    assert not (out / JOURNAL).exists()
    # the SPEC as run resumes the same sweep
    assert run_sweep(load_spec(out / "spec.yaml"), out, engine=Serial()).skipped == 2


def test_a_sweep_too_large_to_list_is_still_its_own(tmp_path, capsys, monkeypatch):
    import flexlift.output.folders as folders

    monkeypatch.setattr(folders, "MARKER_LISTING_MAX", 100)  # as if 100,000 cases
    spec = parse_spec(mc(samples=3))
    run_sweep(spec, tmp_path / "o", engine=Serial())
    marker = read_marker(tmp_path / "o")
    assert marker["complete"] and "summary.json" in marker["files"]
    assert not [f for f in marker["files"] if f.startswith("cases/")]
    assert run_sweep(spec, tmp_path / "o", engine=Serial()).skipped == 3  # known by content
    assert main(["modes", "--out", str(tmp_path / "o")]) == 2  # not listed: not replaced
    one_line(capsys, "did not write")


def test_other_commands_refuse_an_unfinished_sweep_folder(tmp_path, capsys):
    spec_file = write_spec(tmp_path / "s.yaml", mc(samples=2))
    out = tmp_path / "o"
    run_sweep(load_spec(spec_file), out, engine=Serial())
    marker = json.loads((out / ".flexlift-output").read_text())
    marker["complete"] = False
    (out / ".flexlift-output").write_text(json.dumps(marker))
    assert main(["modes", "--out", str(out)]) == 2
    one_line(capsys, "did not write")
    assert (out / "cases" / "case_0000.json").exists()
    # a folder of another command is not a sweep's
    modes = tmp_path / "modes"
    assert main(["modes", "--out", str(modes), "--json"]) == 0
    capsys.readouterr()
    assert main(["sweep", str(spec_file), "--out", str(modes), "--workers", "1"]) == 2
    one_line(capsys, "flexlift modes")


# --------------------------------------------------------------------------- bad input
@pytest.mark.parametrize("change, needles", [
    ({"grid": {"seabed.brekout_time_s": [1, 2]}},
     ["unknown key 'seabed.brekout_time_s'", "did you mean 'seabed.breakout_time_s'",
      "valid keys of seabed are", "seabed.release_time_s"]),
    ({"grid": {"nosuch.key": [1]}}, ["unknown key 'nosuch.key'", "sections", "hull"]),
    ({"grid": {"seabed.breakout_time_s": []}}, ["non-empty list"]),
    ({"grid": {"seabed.breakout_time_s": [400, -5]}}, ["breakout_time_s", "-5"]),
    ({"monte_carlo": {"samples": 0, "vary": VARY}}, ["samples", "whole number >= 1"]),
    ({"monte_carlo": {"samples": -3, "vary": VARY}}, ["samples"]),
    ({"monte_carlo": {"samples": 200000, "vary": VARY}}, ["200,000", "--yes"]),
    ({"monte_carlo": {"samples": 5, "vary": {"hydro.drag_coefficient": {
        "dist": "normal", "mean": 1.2, "std": 0}}}}, ["std must be > 0"]),
    ({"monte_carlo": {"samples": 5, "vary": {"hydro.drag_coefficient": {
        "dist": "normal", "mean": 0.1, "std": 0.5}}}}, ["lies below 0", "bound it with low"]),
    ({"monte_carlo": {"samples": 5, "vary": {"lift.breakout_factor": {
        "dist": "uniform", "low": 1.5, "high": 1.2}}}}, ["low 1.5 must be below high 1.2"]),
    ({"monte_carlo": {"samples": 5, "vary": {"lift.breakout_factor": {
        "dist": "uniform", "low": 0.5, "high": 1.2}}}}, ["low 0.5 is outside", "[1, 5]"]),
    ({"monte_carlo": {"samples": 5, "vary": {"seabed.breakout_time_s": {
        "dist": "lognormal", "median": -1, "sigma": 0.3}}}}, ["median must be > 0"]),
    ({"monte_carlo": {"samples": 5, "vary": {"disturbance.current_m_s": {
        "dist": "triangular", "low": 0, "mode": 0.2, "high": 0.1}}}}, ["mode 0.2 must lie"]),
    ({"monte_carlo": {"samples": 5, "vary": {"lift.breakout_factor": {
        "dist": "gamma", "k": 2}}}}, ["unknown dist", "normal, lognormal"]),
    ({"monte_carlo": {"samples": 5, "vary": {"lift.breakout_factor": {
        "dist": "uniform", "low": 1.2}}}}, ["missing high"]),
    ({"monte_carlo": {"samples": 5, "vary": {"control.mode": {
        "dist": "choice", "values": ["coordinated", "fast"]}}}}, ["control.mode", "fast"]),
    ({"set": {"simulation.duraton_s": 5}}, ["did you mean 'simulation.duration_s'"]),
    ({"control": ["coordinated", "sideways"]}, ["sideways", "decentralized"]),
    ({"keep": "everything"}, ["keep", "summary", "histories"]),
    ({"bogus": 1}, ["unknown key 'bogus'", "monte_carlo"]),
])
def test_bad_spec_is_one_line_and_exit_2(change, needles, tmp_path, capsys):
    data = {"base": "tanker", **change}
    if "grid" not in data and "monte_carlo" not in data:
        data["grid"] = {"seabed.breakout_time_s": [300]}
    spec = write_spec(tmp_path / "s.yaml", data)
    out = tmp_path / "o"
    assert main(["sweep", str(spec), "--out", str(out)]) == 2
    one_line(capsys, "flexlift sweep: error:", *needles)
    assert not out.exists()


FIS_KEY = "control.supervisor.fis_file"


@pytest.mark.parametrize("where, data, needles", [
    ("a choice", {"monte_carlo": {"samples": 2, "seed": 1, "vary": {FIS_KEY: {
        "dist": "choice", "values": ["good.fis", "missing.fis"]}}}},
     ["monte_carlo.vary.control.supervisor.fis_file", "missing.fis: no such file"]),
    ("a grid", {"grid": {FIS_KEY: ["good.fis", "missing.fis"]}},
     ["grid.control.supervisor.fis_file", "missing.fis: no such file"]),
    ("set", {"set": {FIS_KEY: "missing.fis"}, "grid": {"seabed.breakout_time_s": [300]}},
     ["set: control.supervisor.fis_file", "missing.fis: no such file"]),
    ("a file for the other role", {"set": {"control.fill.fis_file": "good.fis"},
                                   "grid": {"seabed.breakout_time_s": [300]}},
     ["control.fill.fis_file", "a fill .fis has one input"]),
    ("a bad number", {"set": {FIS_KEY: "inf.fis"}, "grid": {"seabed.breakout_time_s": [300]}},
     ["inf.fis line", "NumInputs=inf", "whole number"]),
])
def test_every_fis_file_a_spec_names_is_checked_before_the_first_case(where, data, needles,
                                                                       tmp_path, capsys, tanker):
    from flexlift.fuzzy.fis import to_fis_text
    from flexlift.fuzzy.rulebase import supervisor_fis_from

    good = to_fis_text(supervisor_fis_from(tanker.control.supervisor))
    (tmp_path / "good.fis").write_text(good)
    (tmp_path / "inf.fis").write_text(good.replace("NumInputs=2", "NumInputs=inf"))
    spec = write_spec(tmp_path / "s.yaml", {"base": "tanker", "control": ["coordinated"],
                                            **data})
    out = tmp_path / "o"
    assert main(["sweep", str(spec), "--out", str(out)]) == 2  # not one failed case each
    one_line(capsys, "flexlift sweep: error:", *needles)
    assert not out.exists()


def test_a_large_sweep_needs_yes(tmp_path):
    data = mc(samples=200_000)
    with pytest.raises(Exception, match="--yes"):
        parse_spec(data)
    assert parse_spec(data, yes=True).n_cases == 200_000  # only parsed, never run here


@pytest.mark.parametrize("args, needles", [
    (["--scheduler", "tcp://127.0.0.1:9"], ["--scheduler tcp://127.0.0.1:9", "cannot reach"]),
    (["--scheduler", "nonsense"], ["cannot reach", "tcp://host:8786"]),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:9"], ["--workers 2", "not for Dask"]),
    (["--workers", "0"], ["--workers"]),
])
def test_bad_engine_options_are_one_line_and_exit_2(args, needles, tmp_path, capsys):
    import dask
    import distributed  # noqa: F401 - its defaults first: imported inside config.set, they
    # would leave with the setting (the second case then misses distributed.comm's defaults)

    spec = write_spec(tmp_path / "s.yaml", mc(samples=2))
    with dask.config.set({"distributed.comm.timeouts.connect": "1s"}):
        assert main(["sweep", str(spec), "--out", str(tmp_path / "o"), *args]) == 2
    one_line(capsys, *needles)
