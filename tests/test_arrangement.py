"""The arrangement and rigging checks before the run (ascent/arrangement.py)."""

from pathlib import Path

import pytest

from flexlift import load_scenario
from flexlift.ascent.arrangement import (
    arrangement_checks,
    cluster_check,
    depth_check,
    headroom_check,
    rigging_checks,
)
from flexlift.errors import InputError
from flexlift.loads.liftplan import plan_lift
from flexlift.structure.hull import hull_from_scenario

TRAWLER = Path(__file__).parent / "data" / "trawler.yaml"


def _plan(s):
    return plan_lift(s, hull_from_scenario(s))


def _cluster(x, count, breadth=11.0, diameter=5.0):
    s = load_scenario(TRAWLER).with_changes(**{
        "hull.breadth_m": breadth, "lift.catalogue_bag.diameter_m": diameter,
        "lift.bags": [{"name": "c", "kind": "external", "x_m": x, "count": count}]})
    return s, _plan(s)


def test_the_tanker_passes_every_arrangement_check():
    tanker = load_scenario("tanker")
    checks = arrangement_checks(tanker, _plan(tanker))
    assert [c.message for c in checks if not c.ok] == []
    assert {c.name for c in checks} >= {"clusters", "headroom", "rated_depth", "sling",
                                        "lift_points"}


@pytest.mark.parametrize("x, breadth, need, where", [
    (30.0, 9.0, 85.0, "beyond the hull"),   # one 5 m bag across 9 m: 17 x 5 m of hull
    (10.0, 11.0, 45.0, "beyond the hull"),  # two across: 9 rows, 45 m centred on 10 m
])
def test_seventeen_5_m_bags_at_one_point_of_a_60_m_hull_trip_it(x, breadth, need, where):
    s, plan = _cluster(x, 17, breadth)
    check = cluster_check(s, plan)
    assert not check.ok
    assert f"need {need:.2f} m of hull" in check.message and where in check.message
    assert "larger bag" in check.message


def test_clusters_that_overlap_trip_it():
    s = load_scenario(TRAWLER).with_changes(**{
        "lift.catalogue_bag.diameter_m": 5.0,
        "lift.bags": [{"name": "a", "kind": "external", "x_m": 20.0, "count": 6},
                      {"name": "b", "kind": "external", "x_m": 32.0, "count": 6}]})
    check = cluster_check(s, _plan(s))  # 15 m each, 12 m apart: 3 m of overlap
    assert not check.ok and "overlap by 3.00 m" in check.message


def test_a_cluster_that_fits_is_quiet():
    s, plan = _cluster(30.0, 4)  # 2 rows x 5 m = 10 m at mid-length
    check = cluster_check(s, plan)
    assert check.ok and "needs 10.00 m" in check.message


def test_headroom_and_rated_depth():
    s = load_scenario("tanker").with_changes(**{
        "lift.catalogue_bag": {"model": "open_parachute_50t", "rated_depth_m": 200.0},
        "lift.rigging.sling_length_m": 40.0})
    h = headroom_check(s)  # 5.19 m + 40 m against 350 - 300 - 5.4 = 44.6 m
    assert not h.ok and "45.19 m" in h.message and "44.60 m" in h.message
    d = depth_check(s)
    assert not d.ok and "rated to 200 m" in d.message
    ok = s.with_changes(**{"lift.catalogue_bag.rated_depth_m": 400.0,
                           "lift.rigging.sling_length_m": 5.0})
    assert headroom_check(ok).ok and depth_check(ok).ok
    assert "not given" in depth_check(load_scenario("tanker")).message


def _rig(**rig):
    s = load_scenario("tanker").with_changes(**{f"lift.rigging.{k}": v for k, v in rig.items()})
    return {c.name: c for c in rigging_checks(s, _plan(s))}


def test_a_sling_is_designed_for_its_bags_full_true_lift():
    # the tanker's bag: 565 t rated (517 t modelled); true capacity x 1.25 = 706.25 t
    tanker = load_scenario("tanker").with_changes(**{
        "lift.catalogue_bag.capacity_factor": 1.25, "lift.rigging.sling_wll_t": 700.0})
    c = {c.name: c for c in rigging_checks(tanker, _plan(tanker))}["sling"]
    assert not c.ok and "706.25 t" in c.message
    assert _rig(sling_wll_t=565.0)["sling"].ok
    assert "not given" in _rig()["sling"].message


def test_a_lift_point_carries_the_design_load_times_1_30():
    # one 565 t bag per external point: 565 x 1.30 = 734.5 t
    assert _rig(lift_point_capacity_t=734.5)["lift_points"].ok
    bad = _rig(lift_point_capacity_t=[800.0, 800.0, 734.0, 800.0])["lift_points"]
    assert not bad.ok and "734.50 t" in bad.message and "utilisation 1.00" in bad.message
    assert "not given" in _rig()["lift_points"].message
    assert _rig(cluster_wll_t=500.0)["cluster_gear"].ok is False


def test_a_capacity_list_of_the_wrong_length_is_one_line():
    with pytest.raises(InputError, match="4 external lift point"):
        _rig(lift_point_capacity_t=[800.0, 800.0])


@pytest.mark.parametrize("key", ["sling_wll_t", "cluster_wll_t", "lift_point_capacity_t"])
def test_a_wll_or_capacity_that_is_not_positive_is_refused(key):
    with pytest.raises(InputError, match=key):
        load_scenario("tanker").with_changes(**{f"lift.rigging.{key}": 0})


@pytest.mark.parametrize("kind, excess", [("open_parachute", "spills the rest from its mouth"),
                                          ("closed_parachute", "its relief valve must pass it")])
def test_the_dump_valve_against_the_expansion_at_the_planned_speed(kind, excess):
    """A full bag (the plan's 49 t: 47.8 m3) rising at 0.2 m/s at a target 10 m deep (2.02
    bar) expands at V rho g v / p = 0.476 m3/s, more than its 0.407 m3/s valve: the check trips
    with the speed the valve holds (0.2 x 0.407 / 0.476) and the valve it needs; 30 m deep it
    passes."""
    from flexlift.ascent.arrangement import dump_valve_check

    s = load_scenario(TRAWLER).with_changes(**{
        "lift.catalogue_bag": {"model": f"{kind}_50t"}, "control.target_height_m": 110.0})
    V = 49e3 / 1025.0
    p = 101325.0 + 1025.0 * 9.81 * 10.0
    rate = V * 1025.0 * 9.81 * 0.2 / p
    check = dump_valve_check(s, _plan(s))
    assert not check.ok
    assert f"expands at {rate:.3g} m3/s" in check.message and f"({p / 1e5:.2f} bar)" in check.message
    assert excess in check.message
    assert f"at most {0.2 * 0.407 / rate:.3g} m/s" in check.message
    assert f"dump valve of at least {rate:.3g} m3/s" in check.message
    deep = s.with_changes(**{"control.target_height_m": 90.0})
    assert dump_valve_check(deep, _plan(deep)).ok
