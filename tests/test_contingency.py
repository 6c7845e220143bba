"""The single-failure study (issue 26, flexlift.sweep.contingency): the representative rule,
the cases against the same faults run one by one, tolerance bought by one more bag per lift
point, the margin's bisection, and bad input."""

import json
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.errors import InputError
from flexlift.sweep.contingency.cases import check_kinds
from flexlift.sweep.contingency.margin import CAP, MAX_RUNS, Bisection, bisect_margin
from flexlift.sweep.contingency.run import run_contingency
from flexlift.sweep.executors import Serial

#: the tanker's four external lift points [m]
X = [7.09272727, 28.37090909, 49.64909091, 70.92727273]
TANKER = load_scenario("tanker")


def clusters(n: int, lift_t: float = 267.0):
    """The tanker lifted by ``n`` identical external bags of ``lift_t`` at each of its four
    lift points (no internal bags)."""
    return TANKER.with_changes(**{"lift.breakout_factor": 1.1, "lift.bags": [
        {"name": f"p{k + 1}", "kind": "external", "count": n, "x_m": x, "lift_t": lift_t}
        for k, x in enumerate(X)]})


def study(scenario, out, **kw):
    kw.setdefault("engine", Serial())
    return run_contingency(scenario, out, **kw).summary


def test_a_clusters_members_give_their_representatives_outcome_without_noise(tmp_path):
    """Six bags per lift point, each lost at mid-ascent: --all runs all 24; every member of
    a cluster gives the outcome (and the numbers) of the one the representative rule runs."""
    sc = clusters(6)
    reps = study(sc, tmp_path / "reps", kinds=["bag_rupture"], phases=["mid"], margins=False)
    every = study(sc, tmp_path / "all", kinds=["bag_rupture"], phases=["mid"], margins=False,
                  all_bags=True)
    assert reps["representatives"] and not every["representatives"]
    assert reps["n_cases"] == 4 and every["n_cases"] == 24
    by_rep = {c["bag"]: c["answer"] for c in reps["cases"]}
    members = {m: c["bag"] for c in reps["cases"] for m in c["represents"]}
    assert len(members) == 24
    outcomes = set()
    for c in every["cases"]:
        rep = by_rep[members[c["bag"]]]
        assert c["answer"]["outcome"] == rep["outcome"], c["bag"]
        for k in ("up_ms", "pitch_deg", "sling_ratio"):  # None: beyond validity in both
            assert (c["answer"][k] is None) == (rep[k] is None), (c["bag"], k)
            if rep[k] is not None:
                assert c["answer"][k] == pytest.approx(rep[k], rel=1e-6), (c["bag"], k)
        outcomes.add(c["answer"]["outcome"])
    assert outcomes == {"safe", "unsafe"}  # the end points fail, the inner ones hold


def test_the_cases_are_the_same_faults_run_one_by_one_from_their_rerun_files(tmp_path):
    """A small plan's matrix on two local worker processes: each case's numbers are those of
    ``simulate`` on its rerun file, exactly."""
    from flexlift.sweep.executors import make_engine

    out = tmp_path / "study"
    s = study(clusters(6), out, kinds=["bag_rupture", "sensor_stuck"], phases=["mid"],
              margins=False, engine=make_engine(2))
    assert s["n_cases"] == 8
    within = beyond = 0
    for c in s["cases"]:
        sc = load_scenario(out / c["rerun"])
        assert [f.model_dump() for f in sc.faults] == [c["fault"]]
        r = simulate(sc)
        a = c["answer"]
        if a["validity_end_s"] is not None:  # the slope passed its validity: unsafe, and the
            beyond += 1  # peaks after it are not numbers
            assert a["outcome"] == "unsafe" and "beyond the model's validity" in a["reason"]
            assert a["up_ms_beyond"] and a["up_ms"] is not None  # its peak up to then
            continue
        assert a["outcome"] == r.outcome["kind"]
        assert a["up_ms"] == r.headline["max_ascent_velocity_ms"]
        assert a["down_ms"] == r.headline["max_descent_velocity_ms"]
        assert a["pitch_deg"] == r.headline["max_pitch_deg"]
        assert a["utilisation"] == r.headline["max_utilisation"]
        peak = r.dataset.sling_force.max().item() / (sc.environment.gravity_m_s2 * 1000.0)
        assert a["sling_peak_t"] == pytest.approx(peak, abs=0.06)
        within += 1
    assert within >= 4 and beyond >= 1


def test_one_more_bag_per_lift_point_makes_the_plan_tolerant(tmp_path):
    """Losing any one bag at mid-ascent: six bags of 267 t per lift point are not enough (an
    end point's loss pitches the hull past its limit), seven are."""
    six = study(clusters(6), tmp_path / "six", kinds=["bag_rupture"], phases=["mid"],
                margins=False)
    seven = study(clusters(7), tmp_path / "seven", kinds=["bag_rupture"], phases=["mid"],
                  margins=False)
    assert not six["tolerant"] and six["verdict"].startswith("not single-failure tolerant")
    assert {c["bag"] for c in six["cases"] if c["index"] in six["failures"]} == {"p1_1", "p4_1"}
    assert seven["tolerant"] and seven["verdict"] == "single-failure tolerant"
    assert seven["failures"] == []


def test_the_margins_bisection_finds_a_known_threshold_within_its_runs():
    """A case that survives from a scale of 1.237 on: found to within 1 % in at most six runs,
    bracketing the threshold; one that never survives is "> x1.5" after one run."""
    runs = []

    def survives(s):
        runs.append(s)
        return s >= 1.237

    m = bisect_margin(survives, 1.5)
    assert len(runs) <= MAX_RUNS and runs[0] == 1.5
    lo, hi = m["bracket"]
    assert lo < 1.237 <= hi and m["scale"] == hi
    assert (hi - lo) <= 0.0157  # 0.5 / 2^5 after five halvings
    never = bisect_margin(lambda s: False, 1.5)
    assert never["scale"] is None and never["text"] == "> x1.5" and never["runs"] == 1
    # the default cap: within 1 % of the scale in the six runs
    cap = CAP["capacity"]
    m = bisect_margin(lambda s: s >= 1.111, cap)
    lo, hi = m["bracket"]
    assert lo < 1.111 <= hi and hi - lo <= 0.01 * hi and m["runs"] <= MAX_RUNS
    # the 1 t tolerance: a plan of 100 t per unit of scale stops at 0.01 (1 t) or earlier
    b = Bisection(1.5, unit_t=100.0)
    while (s := b.next_scale()) is not None:
        b.tell(s, s >= 1.2)
    assert b.result()["bracket"][1] - b.result()["bracket"][0] <= 0.0157


def test_a_failing_case_gets_its_margin_from_the_runs(tmp_path):
    """The six-bag plan's end-point loss at mid-ascent, with margins: each failing case has
    one, from at most six extra runs, and the surviving inner points none."""
    s = study(clusters(6), tmp_path / "m", kinds=["bag_rupture"], phases=["mid"])
    for c in s["cases"]:
        if c["index"] in s["failures"]:
            m = c["margin"]
            assert 1 <= m["runs"] <= MAX_RUNS and m["text"].startswith(("x", "> x"))
        else:
            assert c["margin"] is None


def test_the_margin_scales_the_survivors_only_and_the_pinned_plan_is_the_plan():
    """The capacity margin multiplies every bag's true capacity but the failed one's (the
    plan pinned in lift.bags); at scale 1 the pinned plan is the plan itself (same bags, same
    ascent)."""
    from flexlift.sweep.contingency.margin import pinned_bags, scale_changes
    from flexlift.sweep.plants import plant_for

    sc = TANKER
    pinned = pinned_bags(sc)
    scaled = sc.with_changes(**scale_changes("capacity", 1.2, sc, "bag_2", pinned))
    same = sc.with_changes(**scale_changes("capacity", 1.0, sc, "bag_2", pinned))
    P0, P1, P2 = (plant_for(s, "decentralized") for s in (sc, scaled, same))
    assert P0.names == P1.names == P2.names
    ratio = dict(zip(P0.names, P1.bags.capacity / P0.bags.capacity))
    assert ratio.pop("bag_2") == 1.0
    assert np.allclose(list(ratio.values()), 1.2, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(P2.bags.capacity, P0.bags.capacity)
    a, b = simulate(sc, "decentralized"), simulate(same, "decentralized")
    np.testing.assert_allclose(b.dataset["height"], a.dataset["height"], rtol=0, atol=1e-9)
    assert a.events == b.events
    assert scale_changes("capacity", 1.2, load_scenario("pipeline"), "x", None) == {
        "lift.catalogue_bag.capacity_factor": 1.2}


def test_a_study_over_the_time_limit_is_refused_in_one_line_naming_yes(tmp_path):
    """The trawler's whole set (324 cases: 9 kinds) on one worker is estimated over 10 min: refused
    before any case runs, one line with the way on, exit 2, nothing written for the cases."""
    data = Path(__file__).parent / "data" / "trawler.yaml"
    p = subprocess.run([sys.executable, "-m", "flexlift", "contingency", str(data), "--workers",
                        "1", "--out", str(tmp_path / "o")], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 2, p.stderr
    line = p.stderr.strip()
    assert len(line.splitlines()) == 1 and "Traceback" not in line
    assert line.startswith("flexlift contingency: error: 324 cases, about ")
    assert "give --yes to run it, or choose fewer --kinds or --phases" in line
    assert not (tmp_path / "o" / "cases").exists()


@pytest.mark.parametrize("args, needle", [
    (["--phases", "pul"], "--phases: got 'pul'; use pull, breakout, mid, near_target"),
    (["--kinds", "valve_stuck"], "--kinds: got 'valve_stuck'; use bag_rupture, sling_break"),
    (["--phases", "99999"], "--phases: got '99999'; a time in seconds from 0 to 6000 s"),
    (["--phases", "1e30"], "--phases: got '1e30'; a time in seconds from 0 to 6000 s"),
    (["--phases", ""], "argument --phases: got ''; name at least one: pull, breakout"),
    (["--kinds", ""], "argument --kinds: got ''; name at least one: bag_rupture, sling_break"),
    (["--kinds", ",,,"], "argument --kinds: got ',,,'; name at least one: bag_rupture"),
])
def test_bad_input_is_one_line_and_exit_2(args, needle, tmp_path):
    p = subprocess.run([sys.executable, "-m", "flexlift", "contingency", "--workers", "1",
                        "--out", str(tmp_path / "o"), *args], capture_output=True, text=True,
                       timeout=300)
    assert p.returncode == 2, p.stderr
    assert needle in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert "Traceback" not in p.stderr


def test_a_kind_the_plan_has_no_part_for_and_too_many_cases_are_refused(tmp_path):
    """A plan of internal cylinders only (as the parts see it: such a plan has nothing to
    control, so the ascent refuses it later) has no dump valve, sling, supply or sensor."""
    internal_only = types.SimpleNamespace(external=np.array([False, False, False]))
    with pytest.raises(InputError, match="no bag with a dump valve of its own"):
        check_kinds(["bag_rupture", "dump_valve_stuck_closed"], internal_only)
    assert check_kinds(["bag_rupture"], internal_only) == ("bag_rupture",)
    with pytest.raises(InputError, match="--all: every bag.*drop --all"):
        run_contingency(clusters(60, 27.0), tmp_path / "y", all_bags=True, engine=Serial())


def test_the_command_prints_the_count_writes_json_and_the_report(tmp_path):
    out = tmp_path / "cli"
    p = subprocess.run([sys.executable, "-m", "flexlift", "contingency", "--workers", "1",
                        "--kinds", "sling_break", "--phases", "breakout", "--out", str(out),
                        "--no-margin"], capture_output=True, text=True, timeout=300)
    assert p.returncode in (0, 1), p.stderr
    assert "4 cases: 4 bags (one representative per lift point and type)" in p.stderr
    s = json.loads((out / "contingency.json").read_text())
    assert s["n_cases"] == 4 and len(list((out / "rerun").iterdir())) == 4
    html = (out / "report.html").read_text()
    assert "Kind x phase, per lift point" in html and "sling broken" in html
    # a rerun of the same command runs nothing again
    p2 = subprocess.run([sys.executable, "-m", "flexlift", "contingency", "--workers", "1",
                         "--kinds", "sling_break", "--phases", "breakout", "--out", str(out),
                         "--no-margin", "--json"], capture_output=True, text=True, timeout=300)
    assert p2.returncode == p.returncode
    assert json.loads(p2.stdout)["cases"] == s["cases"]


def test_flexlift_run_has_a_contingency_stage(tmp_path):
    """``flexlift run --stages loads,contingency``: the study in contingency/, its verdict in
    the run's summary and report, its failures' table as CSV."""
    from flexlift.output.folders import output_folder
    from flexlift.sweep.contingency.stage import run_stage

    with output_folder(tmp_path / "run", "run") as tmp:
        o = run_stage(clusters(6), tmp, engine=Serial(), kinds=["bag_rupture"],
                      phases=["mid"], margins=False)
    assert o.name == "contingency" and o.criteria == {"single_failure_tolerant": False}
    assert o.summary["n_cases"] == len(list((tmp_path / "run" / "contingency" / "rerun").iterdir()))
    csv = (tmp_path / "run" / "tables" / "contingency_failures.csv").read_text()
    assert csv.count("\n") == min(len(o.summary["failures"]), 20) + 1


def test_the_same_answers_on_dask_and_a_resumed_study_runs_nothing_again(tmp_path):
    """The tanker's sling breaks at breakout, with margins: in this process and on a Dask
    cluster, the same answers and margins; run again into its folder, nothing runs again."""
    from flexlift.sweep.executors import DaskEngine

    kw = {"kinds": ["sling_break"], "phases": ["breakout"]}
    serial = study(TANKER, tmp_path / "serial", **kw)
    dask = study(TANKER, tmp_path / "dask", engine=DaskEngine(local_workers=2, processes=False),
                 **kw)

    def answers(s):
        return [(c["bag"], c["answer"], c["margin"]) for c in s["cases"]]

    assert serial["engine"] == "serial" and dask["engine"] == "dask"
    assert answers(serial) == answers(dask)

    class Refuse:
        name, workers, window = "refuse", 1, 1

        def submit(self, fn, *args):
            raise AssertionError("a finished case ran again")

        def close(self, cancel=False):
            pass

    again = study(TANKER, tmp_path / "serial", engine=Refuse(), **kw)
    assert answers(again) == answers(serial)


def test_noise_runs_every_bag_and_the_parts_decide_the_kinds():
    """Without noise one representative per lift point and type; with force or measurement
    noise every bag; an internal cylinder can only be lost."""
    from flexlift.sweep.contingency.cases import KINDS, groups, kinds_of, make_cases, noisy
    from flexlift.sweep.contingency.phases import Phase
    from flexlift.sweep.plants import plant_for

    sc = clusters(3)
    plant = plant_for(sc, "decentralized")
    assert not noisy(sc) and len(groups(plant, False)) == 4 and len(groups(plant, True)) == 12
    assert noisy(sc.with_changes(**{"disturbance.force_noise_N_m": 100.0}))
    assert noisy(sc.with_changes(**{"control.height_noise_m": 0.05}))
    phases = [Phase("mid", 100.0, ""), Phase("pull", None, "not reached")]
    cases, _ = make_cases(plant, phases, KINDS, all_bags=False)
    assert len(cases) == 4 * len(KINDS)  # the unreached phase is not run
    tanker = plant_for(TANKER, "decentralized")
    cases, _ = make_cases(tanker, phases[:1])
    assert len(cases) == 4 * len(KINDS) + 3  # 4 external bags, 3 internal ones only lost
    assert kinds_of(False) == ("bag_rupture",)


def test_a_fill_valve_stuck_closed_is_a_kind_of_the_study_run_as_its_fault(tmp_path):
    """The commoner field failure is in the default kinds (an external bag's, after the stuck-
    open fill valve), and a study of it runs each case as that fault: its rerun file holds it
    and its answer is simulate's on that file."""
    from flexlift.sweep.contingency.cases import KIND_TEXT, KINDS, PART, kinds_of

    kind = "fill_valve_stuck_closed"
    assert kind in KINDS and kind in kinds_of(True) and kind not in kinds_of(False)
    assert KINDS.index(kind) == KINDS.index("fill_valve_stuck_open") + 1
    assert KIND_TEXT[kind] == "fill valve stuck closed" and PART[kind] == "fill valve"
    out = tmp_path / "closed"
    s = study(clusters(6), out, kinds=[kind], phases=["mid"], margins=False)
    assert s["n_cases"] == 4
    for c in s["cases"]:
        assert c["fault"]["kind"] == kind
        sc = load_scenario(out / c["rerun"])
        assert [f.model_dump() for f in sc.faults] == [c["fault"]]
        r = simulate(sc)
        if c["answer"]["validity_end_s"] is None:
            assert c["answer"]["outcome"] == r.outcome["kind"]
            assert c["answer"]["up_ms"] == r.headline["max_ascent_velocity_ms"]


def test_a_case_stopped_beyond_validity_has_the_answer_of_the_whole_run():
    """The tanker losing bag_2's sling at the near_target phase passes the slope's validity:
    the run stopped there (``stop_beyond``, as every case runs) is shorter and its answer is
    that of the run to its end, field by field."""
    from flexlift.sweep.contingency.answer import case_answer

    sc = load_scenario("tanker").with_changes(
        faults=[{"kind": "sling_break", "bag": "bag_2", "time_s": 3278.0}])
    answers, ends = [], []
    for stop in (False, True):
        r = simulate(sc, stop_beyond=stop)
        res = {"events": r.events, "outcome": r.outcome["kind"], "cause": r.outcome["cause"],
               "headline": r.headline}
        answers.append(case_answer(res, r.dataset, sc, sc.control.mode))
        ends.append(float(r.dataset.time.values[-1]))
    whole, stopped = answers
    assert whole["validity_end_s"] is not None and whole["outcome"] == "unsafe"
    assert ends[1] < ends[0] - 1000.0  # the stopped run is much shorter
    assert stopped == whole
    assert whole["up_ms_beyond"] and whole["up_ms"] is not None


#: the tanker run too short to break out: its fault-free run never separates (incomplete)
NEVER_SEPARATES = TANKER.with_changes(**{"simulation.duration_s": 30})


def test_a_study_with_no_case_or_an_incomplete_baseline_gives_no_verdict(tmp_path):
    """Issue 40: no phase reached, so no case: not "tolerant" beside an incomplete baseline."""
    s = study(NEVER_SEPARATES, tmp_path / "o", kinds=["bag_rupture"], margins=False)
    assert s["n_cases"] == 0 and s["baseline"]["outcome"] == "incomplete"
    assert s["tolerant"] is None and s["verdict"].startswith("no verdict: ")
    with pytest.raises(InputError, match="--kinds: got ''; name at least one kind"):
        study(NEVER_SEPARATES, tmp_path / "k", kinds=[])
    with pytest.raises(InputError, match="--phases: got ''; name at least one phase"):
        study(NEVER_SEPARATES, tmp_path / "p", phases=(), times=())


def test_no_verdict_is_exit_1_and_a_folder_of_another_study_names_the_command(tmp_path):
    path = tmp_path / "short.yaml"
    path.write_text(NEVER_SEPARATES.to_yaml())
    out = tmp_path / "o"
    cmd = [sys.executable, "-m", "flexlift", "contingency", str(path), "--workers", "1",
           "--kinds", "bag_rupture", "--no-margin", "--out", str(out), "--json"]
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert p.returncode == 1, p.stderr
    assert json.loads(p.stdout)["tolerant"] is None
    path.write_text(NEVER_SEPARATES.with_changes(**{"simulation.duration_s": 31}).to_yaml())
    p = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert p.returncode == 2, p.stderr
    assert "holds another `flexlift contingency` (its input differs)" in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and "Traceback" not in p.stderr
