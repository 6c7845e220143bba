"""A user's hull without a bag choice gets the largest standard bag <= 50 t whose clusters fit
(scenario/defaults.py, loads/clusters.py, loads/scenario.py)."""

import argparse
import math

import yaml

from flexlift import load_scenario
from flexlift.cli._common import scenario_from
from flexlift.loads import scenario as loading
from flexlift.loads.clusters import cluster_faults, default_bag
from flexlift.scenario.defaults import assumed_summary
from flexlift.scenario.schema import parse_scenario

HULL = {"name": "barge", "environment": {"water_depth_m": 80.0},
        "control": {"target_height_m": 50.0},
        "hull": {"length_m": 60.0, "breadth_m": 6.5, "depth_m": 4.0, "elements": 20,
                 "displacement_t": 800.0, "bending_stiffness_Nm2": 4.0e11}}


class _OnePoint:
    """A plan with every bag at mid-length, as many as 1,000 t needs of the scenario's bag."""

    def __init__(self, s):
        self.n = math.ceil(1000.0 / s.lift.catalogue_bag.lift_t)

    def lift_points(self):
        return [(30.0, [f"b{k}" for k in range(self.n)])]


def test_a_users_hull_without_a_bag_gets_the_50_t_parachute_bag_derived():
    s = parse_scenario(HULL)
    assert s.lift.catalogue_bag.model == "open_parachute_50t"
    assert s.defaulted["lift.catalogue_bag"] == "derived"
    assert any(n.startswith("lift.catalogue_bag = open_parachute_50t (derived: the largest")
               for n in assumed_summary(s))
    assert "lift.catalogue_bag" not in parse_scenario(
        {**HULL, "lift": {"catalogue_bag": {"model": "enclosed_20t"}}}).defaulted
    assert load_scenario("tanker").lift.catalogue_bag.model == "paper_cylinder_565t"
    assert load_scenario("pipeline").lift.catalogue_bag.lift_t == 10.0  # a pipe's own


def test_the_largest_size_whose_cluster_fits_is_chosen():
    s = parse_scenario(HULL)
    # 50 t: D 3.46 m, one across 6.5 m, 20 bags = 69.2 m > 60 m; 35 t: D 3.08 m, two
    # across, 29 bags = 15 rows = 46.2 m: fits
    assert cluster_faults(_OnePoint(s).lift_points(), 3.46, 6.5, 60.0)
    chosen = default_bag(s, _OnePoint)
    assert chosen.lift.catalogue_bag.model == "open_parachute_35t"
    assert chosen.defaulted["lift.catalogue_bag"] == "derived"
    wide = parse_scenario({**HULL, "hull": {**HULL["hull"], "breadth_m": 11.0}})
    assert default_bag(wide, _OnePoint).lift.catalogue_bag.model == "open_parachute_50t"


def test_none_fits_keeps_the_largest_and_a_chosen_bag_is_never_changed():
    short = parse_scenario({**HULL, "hull": {**HULL["hull"], "length_m": 10.0,
                                             "displacement_t": 150.0}})
    assert default_bag(short, _OnePoint).lift.catalogue_bag.model == "open_parachute_50t"
    mine = parse_scenario({**HULL, "lift": {"catalogue_bag": {"model": "enclosed_20t"}}})
    assert default_bag(mine, _OnePoint) is mine


def test_the_command_line_chooses_it(tmp_path, monkeypatch):
    f = tmp_path / "barge.yaml"
    f.write_text(yaml.safe_dump(HULL))
    s = scenario_from(argparse.Namespace(scenario=str(f)))
    assert s.lift.catalogue_bag.model.startswith("open_parachute_")
    assert s.lift.catalogue_bag.lift_t <= 50.0
    # the command line's scenario is the chooser's, with the real lift plan
    monkeypatch.setattr(loading, "default_bag", lambda sc, plan_of: ("chosen", plan_of(sc)))
    chosen, plan = scenario_from(argparse.Namespace(scenario=str(f)))
    assert chosen == "chosen" and plan.bag_count == math.ceil(
        1.3 * 800.0 * (1 - 1025 / 7850) / 50.0)


def test_a_sweeps_base_gets_it_too(tmp_path, monkeypatch):
    from flexlift.sweep.spec import parse_spec

    f = tmp_path / "barge.yaml"
    f.write_text(yaml.safe_dump(HULL))
    seen = []
    real = loading.default_bag
    monkeypatch.setattr(loading, "default_bag",
                        lambda sc, plan_of: seen.append(sc.name) or real(sc, plan_of))
    spec = parse_spec({"base": str(f), "control": ["coordinated"],
                       "grid": {"seabed.breakout_time_s": [30, 60]}})
    assert seen == ["barge"]
    assert spec.base.lift.catalogue_bag.model.startswith("open_parachute_")


def test_the_library_loads_what_the_command_line_runs(tmp_path):
    """One function for every way in: the library's load_scenario of a user's hull chooses its
    bag on the real lift plan as the command line does (50 t bags crowd the barge: 35 t)."""
    f = tmp_path / "barge.yaml"
    f.write_text(yaml.safe_dump(HULL))
    lib = load_scenario(f)
    assert lib.lift.catalogue_bag.model == "open_parachute_35t"
    assert lib.defaulted["lift.catalogue_bag"] == "derived"
    assert scenario_from(argparse.Namespace(scenario=str(f))) == lib
    assert parse_scenario(HULL).lift.catalogue_bag.model == "open_parachute_50t"  # first tried


def test_no_size_fits_and_the_small_ones_are_too_many(tmp_path):
    """A short, narrow, heavy hull: no size's clusters fit and below some size the bags are
    more than the cost limits allow; the largest is kept (the arrangement check says so), not
    a refusal of the file."""
    f = tmp_path / "pontoon.yaml"
    f.write_text(yaml.safe_dump({**HULL, "hull": {**HULL["hull"], "length_m": 30.0,
                                                   "breadth_m": 3.0}}))
    assert load_scenario(f).lift.catalogue_bag.model == "open_parachute_50t"


def test_the_scenario_floor_reads_the_file_as_written(tmp_path):
    """No up-call: the scenario floor's reader leaves the first size tried, marked derived;
    the loads floor's load_scenario chooses (the barge: 35 t, 50 t bags crowd it)."""
    from flexlift.scenario import read_scenario

    f = tmp_path / "barge.yaml"
    f.write_text(yaml.safe_dump(HULL))
    written = read_scenario(f)
    assert written.lift.catalogue_bag.model == "open_parachute_50t"
    assert written.defaulted["lift.catalogue_bag"] == "derived"
    assert load_scenario(f).lift.catalogue_bag.model == "open_parachute_35t"
