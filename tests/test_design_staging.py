"""The designer and a staged lift (issue 41; docs/theory/design.md#staging): the staging is a
choice of the search (the scenario's own control.sequence, or every bag at once), and a
search without a plan leads with the candidates that climbed highest and names the criteria
they broke. The pipeline's finding pinned: its own stages of four bags, kept on a layout of
44 points, make the nominal ascent run away; the same layout lifted at once is safe."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from flexlift import load_scenario
from flexlift.cli import main
from flexlift.design import report
from flexlift.design.dynamic import nominal
from flexlift.design.space import Candidate, candidate_changes, make_space
from flexlift.structure.hull import hull_from_scenario

TOY = str(Path(__file__).parent / "data" / "design_beam.yaml")


@pytest.fixture(scope="module")
def pipe():
    return load_scenario("pipeline")


def _pipe_candidate(sequence: str, points: int = 44) -> Candidate:
    return Candidate(model="enclosed_10t", points=points, count=1, extra=0,
                     mode="decentralized", ascent_speed_m_s=0.2, breakout_pull_t=20.0,
                     dump_valve_factor=1.0, sequence=sequence)


def test_the_staging_is_searched_on_a_staged_lift_only(pipe):
    """A staged lift (the pipeline) offers its own stages and none; an unstaged one (the toy)
    keeps its own, not asked; given, the choice is as given."""
    assert make_space(pipe, models=["enclosed_10t"]).sequences == ("own", "none")
    toy = load_scenario(TOY)
    space = make_space(toy, models=["open_parachute_5t"])
    assert space.sequences == ("own",) and space.fixed()["sequence"] == "own"
    assert make_space(pipe, models=["enclosed_10t"], sequences=["none"]).fixed()[
        "sequence"] == "none"


def test_a_candidate_lifted_at_once_drops_the_sequence(pipe):
    space = make_space(pipe, models=["enclosed_10t"])
    hull = hull_from_scenario(pipe)
    own = pipe.with_changes(**candidate_changes(_pipe_candidate("own"), space, hull, pipe))
    once = pipe.with_changes(**candidate_changes(_pipe_candidate("none"), space, hull, pipe))
    assert own.control.sequence.group_size == 4 and once.control.sequence is None
    assert _pipe_candidate("own").key() != _pipe_candidate("none").key()


def test_the_pipelines_own_stages_run_away_on_another_layout(pipe):
    """44 points of one enclosed 10 t bag: with the scenario's stages of four bags the
    nominal ascent breaks its speed limit (a bag rising at over 1 m/s, the limit 0.6 m/s;
    measured 1.21 m/s); lifted at once it is safe (docs/theory/design.md#staging)."""
    space = make_space(pipe, models=["enclosed_10t"])
    hull = hull_from_scenario(pipe)
    runs = nominal([pipe.with_changes(**candidate_changes(_pipe_candidate(s), space, hull,
                                                           pipe)) for s in ("own", "none")])
    assert runs[0]["outcome"] == "unsafe" and "ascent velocity" in runs[0]["why"]
    assert runs[1]["outcome"] == "safe", runs[1]["why"]


def _row(bags, rung, why, kind=None, phase=None):
    r = {"bags": bags, "passed": False, "reached": rung, "candidate_key": f"k{bags}",
         "candidate": {"model": "enclosed_10t", "points": bags, "mode": "decentralized"},
         "rejected": {"rung": rung, "check": "unsafe" if rung != "statics" else "strength",
                      "why": why}}
    if rung == "contingency":
        r["contingency"] = {"first": {"kind": kind, "phase": phase, "outcome": "unsafe"}}
    return r


def test_no_plan_leads_with_the_highest_climbers_and_names_what_broke(pipe):
    rows = [_row(9, "statics", "hull girder utilisation 16.15"),
            _row(30, "nominal", "ascent velocity: p8 rose faster; bending utilisation: ..."),
            _row(35, "nominal", "ascent velocity: p16 rose faster; descent velocity: ..."),
            _row(40, "contingency", "unsafe on bag_rupture", "bag_rupture", "pull")]
    space = make_space(pipe, models=["enclosed_10t"], sequences=["own"])
    np_ = report.no_plan(rows, space)
    assert [b["bags"] for b in np_["best_candidates"]] == [40, 30, 35, 9]
    assert np_["criteria"]["nominal"] == {"ascent velocity": 2, "bending utilisation": 1,
                                          "descent velocity": 1}
    assert np_["criteria"]["contingency"] == {"bag_rupture at pull (unsafe)": 1}
    hints = " ".join(np_["what_would_change_it"])
    assert "--sequence own,none" in hints and "bag_rupture at pull (unsafe): 1" in hints
    # with the staging already searched the hint does not ask for it again
    both = report.no_plan(rows, make_space(pipe, models=["enclosed_10t"]))
    assert "--sequence" not in " ".join(both["what_would_change_it"])


def test_bad_sequence_exit_2(tmp_path, capsys):
    code = main(["design", "pipeline", "--sequence", "sometimes", "--out",
                 str(tmp_path / "o"), "--up-to", "statics"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "--sequence" in err
    assert not (tmp_path / "o").exists()


def test_the_summary_lists_the_staging(tmp_path, capsys):
    code = main(["design", "pipeline", "--up-to", "statics", "--budget", "12", "--out",
                 str(tmp_path / "o"), "--json", "--no-compare"])
    s = json.loads(capsys.readouterr().out)
    assert code == 0 and s["space"]["sequences"] == ["own", "none"]
    assert "sequence" in (tmp_path / "o" / "candidates.csv").read_text().splitlines()[0]


def test_the_benchmark_merges_rows_by_case():
    """benchmarks/design.py run on one case replaces that case's row and keeps the others
    (it overwrote the whole file before)."""
    import importlib.util

    path = Path(__file__).parents[1] / "benchmarks" / "design.py"
    spec = importlib.util.spec_from_file_location("bench_design", path)
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    old = {"budget": 24, "cases": [{"case": "tanker", "wall_s": 96.5},
                                   {"case": "pipeline", "wall_s": 985.3},
                                   {"case": "heavy", "wall_s": 431.3}]}
    new = bench.merge(old, [{"case": "pipeline", "wall_s": 300.0}, {"case": "toy"}])
    assert [(r["case"], r.get("wall_s")) for r in new["cases"]] == [
        ("tanker", 96.5), ("pipeline", 300.0), ("heavy", 431.3), ("toy", None)]
    assert new["budget"] == 24 and old["cases"][1]["wall_s"] == 985.3


def test_a_single_failure_hint_asks_only_for_what_was_not_searched(pipe):
    """The words for no plan stopped by single failures: an option the space already
    varied (here the dump valve and the modes) is named as searched, not asked for again;
    an incomplete case is told apart from an unsafe one."""
    rows = [_row(40, "contingency", "unsafe on bag_rupture", "bag_rupture", "breakout"),
            _row(41, "contingency", "incomplete on bag_rupture", "bag_rupture", "pull")]
    rows[1]["contingency"]["first"]["outcome"] = "incomplete"
    fixed = report.no_plan(rows, make_space(pipe, models=["enclosed_10t"]))
    hint = " ".join(fixed["what_would_change_it"])
    assert "a larger dump valve (--dump-valve)" in hint and "other control modes" in hint
    assert "(incomplete)" in hint and "incomplete: the run ended" in hint
    wide = report.no_plan(rows, make_space(pipe, models=["enclosed_10t"],
                                           dump_factors=[1.0, 4.0],
                                           modes=["decentralized", "coordinated"]))
    hint = " ".join(wide["what_would_change_it"])
    assert "--dump-valve" not in hint and "--modes" not in hint
    assert "searched without a plan: " in hint and "dump valves up to 4 x" in hint
    assert "another bag than enclosed_10t (--bags)" in hint


def _asked(hint: str, option: str) -> list[float]:
    """The values a hint suggests for ``option`` (``e.g. --speeds 0.1``)."""
    import re

    return [float(v) for v in re.findall(rf"e\.g\. {option} ([0-9.]+)", hint)]


def test_a_nominal_hint_does_not_ask_for_speeds_or_valves_already_searched(pipe):
    """No plan stopped by the nominal ascent: the hint names the planned ascent speeds and
    dump valves searched, as tried, and suggests only a speed below the slowest and a valve
    above the largest of them (before: 'a slower planned ascent (--speeds)' beside a search
    of 0.2 m/s alone, nothing named; or nothing at all once two speeds were searched)."""
    rows = [_row(30, "nominal", "ascent velocity: p8 rose faster")]
    fixed = " ".join(report.no_plan(rows, make_space(pipe, models=["enclosed_10t"]))
                     ["what_would_change_it"])
    assert pipe.control.ascent_speed_m_s == 0.2  # the space's one speed, the scenario's
    assert "tried: planned ascent speed 0.2 m/s and dump valve 1 x" in fixed
    assert _asked(fixed, "--speeds") == [0.1] and _asked(fixed, "--dump-valve") == [2.0]
    wide = " ".join(report.no_plan(rows, make_space(pipe, models=["enclosed_10t"],
                                                    speeds=[0.2, 0.1, 0.3],
                                                    dump_factors=[1.0, 2.0]))
                    ["what_would_change_it"])
    assert "planned ascent speeds 0.1, 0.2, 0.3 m/s and dump valves 1, 2 x" in wide
    assert "searched did not stop it" in wide
    speeds, dumps = _asked(wide, "--speeds"), _asked(wide, "--dump-valve")
    assert speeds and all(v < 0.1 for v in speeds), speeds  # none searched, all outside
    assert dumps and all(f > 2.0 for f in dumps), dumps
    assert "slower than 0.1 m/s" in wide and "larger than 2 x" in wide
    assert "slower than 0.2" not in wide and "slower than 0.3" not in wide


def test_a_hint_suggests_nothing_past_what_a_scenario_allows(pipe, tmp_path):
    """The slowest speed a scenario takes (0.001 m/s) and the largest valve factor (100)
    searched: nothing slower or larger is suggested, and it says so; a scenario whose own
    purge valve replaces the catalogue's is asked for a larger one of its own (--dump-valve
    is refused there), as is the salvage study's hint, which names the speeds and margin
    searched and asks for neither again."""
    from flexlift.design.space import DUMP_FACTOR_MAX

    rows = [_row(30, "nominal", "ascent velocity: p8 rose faster"),
            _row(31, "salvage", "P(unsafe) 0.05")]
    edge = report.no_plan(rows, make_space(pipe, models=["enclosed_10t"],
                                           speeds=[0.001, 0.2],
                                           dump_factors=[1.0, DUMP_FACTOR_MAX]))
    nominal, salvage = edge["what_would_change_it"]
    assert not _asked(nominal, "--speeds") and not _asked(nominal, "--dump-valve")
    assert "no slower speed or larger valve is allowed" in nominal
    assert "tried: planned ascent speeds 0.001, 0.2 m/s, up to 12 bags over" in salvage
    assert not _asked(salvage, "--speeds") and "e.g. --over 0..18" in salvage
    own = pipe.with_changes(**{"gas.purge_rate_max_m3_s": 0.5})
    rows.append(_row(40, "contingency", "unsafe on bag_rupture", "bag_rupture", "breakout"))
    hints = report.no_plan(rows, make_space(own, models=["enclosed_10t"]), own)[
        "what_would_change_it"]
    assert "the scenario's purge valve, 0.5 m3/s" in hints[0]
    assert "--dump-valve" not in hints[0] and "larger gas.purge_rate_max_m3_s" in hints[0]
    assert "--dump-valve" not in hints[1] and "(gas.purge_rate_max_m3_s)" in hints[1]
    assert _asked(hints[2], "--speeds") == [0.1]
