"""The bag catalogue (scenario/catalogue.py, flexlift/data/bags.yaml) and the true capacity."""

import math
import subprocess
import sys

import pytest

from flexlift import constants as C
from flexlift import load_scenario
from flexlift.errors import InputError
from flexlift.loads.liftplan import plan_lift
from flexlift.scenario import catalogue
from flexlift.structure.hull import hull_from_scenario


def test_every_generic_entry_is_its_rule_and_holds_its_volume():
    cat = catalogue.builtin()
    for kind in ("open_parachute", "closed_parachute", "enclosed"):
        for t in catalogue.SIZES_T:
            entry = cat[f"{kind}_{t}t"]
            rule = catalogue.generic_entry(kind, t)
            rule.pop("source")
            assert entry == rule
            V = t * 1000 / 1025
            assert catalogue.body_volume(entry) >= V
            assert catalogue.body_volume(entry) < 1.05 * V  # rounded up by a centimetre only
    # hand values: 50 t open parachute bag, V = 48.78 m3, D = (4 V / 1.5 pi)^(1/3) = 3.459 m
    big = cat["open_parachute_50t"]
    assert (big["diameter_m"], big["length_m"], big["relief_bar"]) == (3.46, 5.19, None)
    assert cat["closed_parachute_10t"]["relief_bar"] == 0.1


def test_the_papers_cylinder_is_kept_as_published():
    paper = catalogue.builtin()["paper_cylinder_565t"]
    assert (paper["lift_t"], paper["diameter_m"], paper["length_m"],
            paper["working_pressure_bar"]) == (565.0, 1.5, 18.0, 2.8)
    assert paper["as_published"] is True


def test_the_tanker_keeps_its_517_t_bags_and_capacity():
    tanker = load_scenario("tanker")
    bag = tanker.lift.catalogue_bag
    assert (bag.model, bag.lift_t, bag.diameter_m, bag.capacity_factor) == (
        "paper_cylinder_565t", 565.0, 1.5, 1.0)
    plan = plan_lift(tanker, hull_from_scenario(tanker))
    assert plan.bag_count == 7
    assert plan.bag_lift / (C.TONNE * 9.81) == pytest.approx(517.0)
    assert plan.bags[0].capacity == pytest.approx(517.0 * 1000 / 1025)


def test_a_model_fills_the_fields_and_explicit_fields_override_it():
    tanker = load_scenario("tanker")
    s = tanker.with_changes(**{"lift.catalogue_bag": {"model": "open_parachute_35t",
                                                      "rated_depth_m": 400.0}})
    bag = s.lift.catalogue_bag
    assert (bag.type, bag.lift_t, bag.diameter_m, bag.rated_depth_m) == (
        "open_parachute", 35.0, 3.08, 400.0)
    assert bag.working_pressure_bar is None


def test_capacity_factor_scales_the_gas_capacity_not_the_count():
    tanker = load_scenario("tanker")
    base = plan_lift(tanker, hull_from_scenario(tanker))
    s = tanker.with_changes(**{"lift.catalogue_bag.capacity_factor": 1.25})
    plan = plan_lift(s, hull_from_scenario(s))
    assert plan.bag_count == base.bag_count and plan.bag_lift == base.bag_lift
    for a, b in zip(plan.bags, base.bags):
        assert a.capacity == pytest.approx(1.25 * b.capacity, rel=1e-12)


@pytest.mark.parametrize("value", [0, -1.0])
def test_capacity_factor_must_be_positive(value):
    with pytest.raises(InputError, match="capacity_factor"):
        load_scenario("tanker").with_changes(**{"lift.catalogue_bag.capacity_factor": value})


def test_an_unknown_model_names_the_near_ones():
    with pytest.raises(InputError, match="near: open_parachute_50t") as err:
        load_scenario("tanker").with_changes(**{"lift.catalogue_bag.model": "open_parachut_50"})
    assert "\n" not in str(err.value)


def test_an_unknown_model_exits_2_with_one_line(tmp_path):
    f = tmp_path / "s.yaml"
    f.write_text("name: t\nbased_on: tanker\nlift:\n  catalogue_bag: {model: enclosd_10t}\n")
    r = subprocess.run([sys.executable, "-m", "flexlift", "loads", str(f), "--out",
                        str(tmp_path / "o")], capture_output=True, text=True, timeout=300)
    assert r.returncode == 2
    assert "enclosed_10t" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def _user(tmp_path, body):
    (tmp_path / "mine.yaml").write_text(body)
    f = tmp_path / "s.yaml"
    f.write_text("name: t\nbased_on: tanker\nlift:\n  catalogue_file: mine.yaml\n"
                 "  catalogue_bag: {model: my_bag}\n")
    return f


def test_a_users_catalogue_file_extends_the_packaged_one(tmp_path):
    f = _user(tmp_path, "bags:\n  my_bag: {type: closed_parachute, lift_t: 12.0, "
                        "diameter_m: 2.5, length_m: 3.0, rated_depth_m: 150}\n")
    bag = load_scenario(f).lift.catalogue_bag
    assert (bag.model, bag.lift_t, bag.rated_depth_m) == ("my_bag", 12.0, 150.0)


@pytest.mark.parametrize("entry, match", [
    ("{type: enclosed, lift_t: 0, diameter_m: 2, length_m: 3}", "lift_t = 0 must be a positive"),
    ("{type: enclosed, diameter_m: 2, length_m: 3}", "lift_t is missing"),
    ("{type: enclosed, lift_t: 50, diameter_m: 1, length_m: 2}", "holds 1.57 m3, less than"),
    ("{type: balloon, lift_t: 5, diameter_m: 3, length_m: 3}", "type balloon is not one of"),
    ("{type: open_parachute, lift_t: 5, diameter_m: 2, length_m: 3, cone_top_m: 3}",
     "cone_top_m = 3 m is the conical top"),
    ("{type: enclosed, lift_t: 5, diameter_m: 2, length_m: 3, cone_top_m: 1}",
     "of an upright \\(parachute\\) bag"),
])
def test_a_bad_catalogue_entry_is_one_line(tmp_path, entry, match):
    f = _user(tmp_path, f"bags:\n  my_bag: {entry}\n")
    with pytest.raises(InputError, match=match) as err:
        load_scenario(f)
    assert "\n" not in str(err.value) and "my_bag" in str(err.value)


def test_volume_rule_by_hand():
    e = catalogue.generic_entry("enclosed", 10)
    D = (4 * (10000 / 1025) / (3 * math.pi)) ** (1 / 3)
    assert e["diameter_m"] == math.ceil(D * 100) / 100 and e["length_m"] >= 3 * D
