"""The designer's added parts (issue 41; docs/theory/design.md): internal bags (the tanks'
room and the weight, by hand on the toy of tests/test_design.py), one catalogue bag per lift
point (each point's own lift in the statics), the compressor's supply, the candidate's key,
the same seed giving the same plan from fresh folders, bad input. Statics only: fast."""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import asdict
from pathlib import Path

import pytest

from flexlift import load_scenario
from flexlift.ascent.checks import weight_centre
from flexlift.cli import main
from flexlift.design.cache import Cache
from flexlift.design.internal import most_internal, room, tank_box_m, tank_check
from flexlift.design.run import run_design
from flexlift.design.search import Options, run_search
from flexlift.design.space import Candidate, candidate_changes, make_space
from flexlift.design.statics import static_checks
from flexlift.loads.liftplan import plan_lift
from flexlift.structure.hull import hull_from_scenario

TOY = str(Path(__file__).parent / "data" / "design_beam.yaml")
WET_T = 40.0 * (1 - 1025.0 / 7850.0)  # W' = 34.78 t
REQUIRED_T = 1.3 * WET_T  # R = 45.21 t
#: the toy's tanks: frames 4..36 of 0.6 m, over the 6 m x 2 m section
SPAN_M = (36 - 4) * 0.6  # 19.2 m


@pytest.fixture(scope="module")
def toy():
    return load_scenario(TOY)


@pytest.fixture(scope="module")
def hull(toy):
    return hull_from_scenario(toy)


def _cand(**kw):
    base = dict(model="open_parachute_5t", points=3, count=3, extra=2, mode="coordinated",
                ascent_speed_m_s=0.1, breakout_pull_t=None, dump_valve_factor=1.0)
    return Candidate(**{**base, **kw})


def test_key_unchanged_for_the_first_parts():
    """A candidate at the new parts' defaults keeps the key its first eight values gave (old
    caches still hit); each new part, set, changes it."""
    c = _cand()
    first = {k: v for k, v in asdict(c).items()
             if k not in ("internal", "point_models", "supply_free_air_m3_min", "sequence")}
    assert c.key() == hashlib.sha256(json.dumps(first, sort_keys=True).encode()
                                     ).hexdigest()[:20]
    keys = {c.key(), _cand(internal=2).key(), _cand(supply_free_air_m3_min=30.0).key(),
            _cand(point_models=("open_parachute_5t", "open_parachute_10t",
                                "open_parachute_5t")).key(),
            _cand(point_models=("open_parachute_10t", "open_parachute_5t",
                                "open_parachute_5t")).key(), _cand(sequence="none").key()}
    assert len(keys) == 6


def test_an_old_cache_still_answers(toy, tmp_path):
    """Lines written before the new parts existed (no internal, point_models, supply in the
    candidate) answer the same search over the earlier space (--internal 0): no re-run."""
    space = make_space(toy, models=["open_parachute_5t"], points=(1, 4), over=(0, 3),
                       internal=(0, 0))
    o = Options(budget=12, population=12, up_to="statics")
    first = run_search(toy, space, o, None, Cache(tmp_path, o.identity(toy, space)))
    path = tmp_path / "evaluations.jsonl"
    old = []
    for line in path.read_text().splitlines():
        row = json.loads(line)
        cand = row["result"]["candidate"]
        for k in ("internal", "point_models", "supply_free_air_m3_min", "sequence"):
            del cand[k]
        # the key as the first designer wrote it: the checksum of the eight values
        row["key"] = hashlib.sha256(json.dumps(cand, sort_keys=True).encode()
                                    ).hexdigest()[:20]
        old.append(json.dumps(row))
    path.write_text("\n".join(old) + "\n")
    again = run_search(toy, space, o, None, Cache(tmp_path, o.identity(toy, space)))
    assert again["calls"]["statics"] == 0 and again["cache_hits"] == 12
    assert [r["bags"] for r in again["rows"]] == [r["bags"] for r in first["rows"]]


def test_internal_bags_the_tanks_hold_by_hand(toy, hull):
    """Room: bodies D x D x L lying in rows in the tank span's box (19.2 x 6 x 2 m);
    weight: k F < W'. 5 t (1.61 x 2.42 m): room 7 x 3 x 1 = 21, weight 6; 10 t (2.03 x
    3.05 m): no row fits the 2 m depth, 0; small tanks (frames 4..12, 4.8 m): 5 t room 3."""
    cat = make_space(toy, models=["open_parachute_5t", "open_parachute_10t"]).entries
    five, ten = cat["open_parachute_5t"], cat["open_parachute_10t"]
    assert tank_box_m(toy) == pytest.approx((SPAN_M, 6.0, 2.0))
    assert room(toy, five) == math.floor(SPAN_M / 2.42) * math.floor(6 / 1.61) * 1 == 21
    assert room(toy, ten) == 0  # floor(2 / 2.03) = 0
    assert most_internal(toy, hull, five) == min(21, math.ceil(WET_T / 5.0) - 1) == 6
    assert most_internal(toy, hull, ten) == 0
    assert tank_check(toy, hull, 6, five) is None
    assert "submerged weight" in tank_check(toy, hull, 7, five)["why"]  # 35 t >= W'
    assert "box" in tank_check(toy, hull, 1, ten)["why"]
    small = toy.with_changes(**{"hull.ballast_tank_frames": [4, 12]})
    assert most_internal(small, hull, five) == 3  # floor(4.8 / 2.42) x 3 x 1
    assert "holds 3" in tank_check(small, hull, 4, five)["why"]
    assert make_space(toy, models=["open_parachute_5t", "open_parachute_10t"]).internal == (0, 6)


def test_internal_bags_in_the_plan_and_the_bound(toy, hull, tmp_path):
    """Two internal bags of the candidate's 5 t lie end to end over the tanks; the lift
    points balance what they leave (holding centroid on the centre of the wet weight, on
    tanks off the middle: 1.4 m off if they did not); the fewest tolerant bags stay the N-1 bound of 11, internal ones
    counted."""
    aft = toy.with_changes(**{"hull.ballast_tank_frames": [4, 20]})  # 2.4 .. 12 m
    c = _cand(internal=2)
    sc = aft.with_changes(**candidate_changes(c, make_space(aft, models=["open_parachute_5t"]),
                                              hull, aft))
    inner = [b for b in sc.lift.bags if b.kind == "internal"]
    assert [tuple(b.span_m) for b in inner] == [(2.4, 7.2), (7.2, 12.0)]
    assert all(b.lift_t == 5.0 for b in inner)
    plan = plan_lift(sc, hull)
    assert plan.bag_count == c.bags == 13
    g = sc.environment.gravity_m_s2
    cg = weight_centre(hull, g, sc.environment.seawater_density_kg_m3,
                       sc.environment.steel_density_kg_m3)
    assert abs(plan.lift_centroid - cg) < 0.01 * hull.length
    from flexlift.ascent import simulate

    res = simulate(sc, duration=5.0)  # the plan runs as it is written
    assert len(res.criteria) > 0
    space = make_space(toy, models=["open_parachute_5t"], points=(1, 6), over=(0, 6),
                       internal=(0, 6))
    o = Options(budget=36, population=12, up_to="statics")
    rows = run_search(toy, space, o, None, Cache(tmp_path, o.identity(toy, space)))["rows"]
    assert {r["candidate"]["internal"] for r in rows} > {0}  # searched
    passed = [r for r in rows if r["passed"]]
    assert min(r["bags"] for r in passed) == 11
    for r in rows:
        if r["bags"] == 10 and r["statics"]["check"] != "tanks":
            assert r["rejected"]["check"] == "lift_n_minus_1"


def _models(sc):
    return [(b.count, b.lift_t) for b in sc.lift.bags if b.kind == "external"]


def test_one_bag_per_lift_point(toy, hull, tmp_path):
    """Each point's bags carry their own lift; the N-1 statics loses the largest: a mixed
    candidate passes exactly when sum - largest >= R (by hand), and one whose small bags
    cannot hold their share through the ascent fails the holding check."""
    names = ["open_parachute_5t", "open_parachute_10t", "open_parachute_20t"]
    space = make_space(toy, models=names, points=(2, 5), over=(0, 4), internal=(0, 0),
                       per_point=True)
    o = Options(budget=36, population=12, up_to="statics")
    found = run_search(toy, space, o, None, Cache(tmp_path, o.identity(toy, space)))
    mixed = [r for r in found["rows"] if r["candidate"]["point_models"]]
    assert mixed
    lift = {m: float(m.split("_")[-1][:-1]) for m in names}
    for r in mixed:
        c = r["candidate"]
        lifts = [lift[m] for m, n in zip(c["point_models"], r["counts"]) for _ in range(n)]
        assert r["candidate"]["model"] == max(c["point_models"], key=lift.get)
        check = r["statics"]["check"]
        if sum(lifts) < REQUIRED_T - 1e-6:
            assert check == "lift"
        elif sum(lifts) - max(lifts) < REQUIRED_T - 1e-6:
            assert check == "lift_n_minus_1"
        else:
            assert check not in ("lift", "lift_n_minus_1")
    # 5 t + 4 x 20 t: 85 - 20 = 65 t >= R, but each holds W' / 5 = 6.96 t > 5 t
    c = _cand(model="open_parachute_20t", points=5, count=1, extra=0,
              point_models=("open_parachute_5t",) + ("open_parachute_20t",) * 4)
    sc = toy.with_changes(**candidate_changes(c, space, hull, toy))
    assert _models(sc) == [(1, 5.0)] + [(1, 20.0)] * 4
    st = static_checks(sc, hull)
    assert st["check"] == "holding" and st["violation"] == pytest.approx(WET_T / 5 / 5 - 1,
                                                                          rel=1e-3)
    assert sc.lift.catalogue_bag.dump_valve_m3_s == pytest.approx(0.0407)  # the 5 t's valve


def test_supply_is_a_choice(toy, tmp_path):
    space = make_space(toy, models=["open_parachute_5t"], points=(2, 4), over=(1, 3),
                       supplies=[None, 30.0])
    o = Options(budget=12, population=12, up_to="statics")
    found = run_search(toy, space, o, None, Cache(tmp_path, o.identity(toy, space)))
    ev = found["evaluator"]
    seen = set()
    for r in found["rows"]:
        c = Candidate(**r["candidate"])
        seen.add(c.supply_free_air_m3_min)
        assert ev.scenario_of(c).gas.supply_free_air_m3_min == c.supply_free_air_m3_min
    assert seen == {None, 30.0}


def test_same_seed_same_plan_in_fresh_folders(toy, tmp_path):
    """Two searches from empty folders, same seed, every new part free: the same trials and
    the same plan; another seed asks other trials."""
    space = make_space(toy, models=["open_parachute_5t", "open_parachute_10t"],
                       points=(1, 5), over=(0, 4), per_point=True, supplies=[None, 20.0],
                       dump_factors=[1.0, 1.5])

    def go(folder, seed):
        return run_design(toy, space, Options(budget=24, population=12, up_to="statics",
                                              seed=seed), tmp_path / folder, compare=False)

    a, b = go("a", 7), go("b", 7)
    go("c", 8)
    assert a["evaluations"]["cache_hits"] == b["evaluations"]["cache_hits"] == 0
    assert a["found"] and a["best"] == b["best"] and a["pareto"] == b["pareto"]
    assert (tmp_path / "a" / "plan.yaml").read_text() == (tmp_path / "b" / "plan.yaml"
                                                          ).read_text()
    trials = [(tmp_path / f / "candidates.csv").read_text() for f in "abc"]
    assert trials[0] == trials[1] != trials[2]


@pytest.mark.parametrize("extra", [["--internal", "3..1"], ["--internal", "50"],
                                   ["--per-point-types", "--bags",
                                    "open_parachute_5t,enclosed_5t"],
                                   ["--supply", "0"], ["--supply", "lots"]])
def test_bad_input_exit_2(extra, tmp_path, capsys):
    code = main(["design", TOY, "--out", str(tmp_path / "o"), "--up-to", "statics", *extra])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "error" in err
    assert not (tmp_path / "o").exists()


def test_internal_refused_without_tanks(tmp_path, capsys):
    code = main(["design", "pipeline", "--internal", "1..2", "--out", str(tmp_path / "o"),
                 "--up-to", "statics"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "--internal" in err


def test_a_dump_valve_factor_acts_on_a_bag_without_a_catalogue_valve(tmp_path, capsys):
    """The paper's cylinder has no catalogue valve: its bags purge through the tanker's
    gas.purge_rate_max_m3_s (2 m3/s). A factor scales that valve (before: nothing, so every
    --dump-valve choice ran the same plan); a scenario that gives the key itself, which
    replaces any catalogue valve, refuses a factor (exit 2)."""
    from flexlift.scenario.valves import external_valve
    from flexlift.structure.hull import hull_from_scenario as hull_of

    tanker = load_scenario("tanker")
    space = make_space(tanker, models=["paper_cylinder_565t"], dump_factors=[1.0, 3.0])
    valves = {}
    for f in (1.0, 3.0):
        c = _cand(model="paper_cylinder_565t", points=4, count=2, extra=0,
                  dump_valve_factor=f)
        sc = tanker.with_changes(**candidate_changes(c, space, hull_of(tanker), tanker))
        valves[f] = external_valve(sc).m3_s
    assert valves == {1.0: pytest.approx(2.0), 3.0: pytest.approx(6.0)}
    own = tmp_path / "own.yaml"
    own.write_text(Path(TOY).read_text() + "gas:\n  purge_rate_max_m3_s: 0.5\n")
    code = main(["design", str(own), "--dump-valve", "1,2", "--out", str(tmp_path / "o"),
                 "--up-to", "statics"])
    err = capsys.readouterr().err.strip()
    assert code == 2 and len(err.splitlines()) == 1 and "gas.purge_rate_max_m3_s" in err
