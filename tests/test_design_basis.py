"""The design basis (scenario/basis.py): every factor, limit and assumed value with its source,
in the report's Design basis section and summary.json."""

import html
import json
import math
import re
from pathlib import Path

import pytest

from flexlift import load_scenario
from flexlift.output.report import render_report
from flexlift.output.stage import StageOutput
from flexlift.scenario.basis import design_basis, in_air_daf
from flexlift.stages.run import summary_of

TRAWLER = Path(__file__).parent / "data" / "trawler.yaml"


def _rows(s):
    return {r["item"]: r for r in design_basis(s)}


@pytest.mark.parametrize("t, daf", [(50.0, None), (100.0, 1.25), (300.0, 1.25), (301.0, 1.20),
                                    (1000.0, 1.20), (2500.0, 1.15), (2501.0, 1.10)])
def test_the_in_air_daf_table(t, daf):
    assert in_air_daf(t) == daf


def test_the_tankers_basis_names_the_paper_and_the_guideline():
    rows = _rows(load_scenario("tanker"))
    assert rows["tilt limit"]["value"] == "15 deg" and rows["tilt limit"]["source"] == "paper"
    assert rows["breakout factor (required lift / submerged weight)"]["source"] == "paper"
    bag = rows["lift bag (catalogue entry)"]
    assert "paper_cylinder_565t" in bag["source"] and "kept as published" in bag["note"]
    assert "31.8 m3" in bag["note"] and "551 m3" in bag["note"]
    assert rows["skew load factor"]["value"] == "not applicable"
    assert "its own buoyancy" in rows["skew load factor"]["note"]
    assert rows["weight contingency"]["value"] == "none given"
    assert "the wreck's 350 m that is ~18 m3/s of free air" in rows["gas supply per bag"]["note"]
    lp = rows["consequence factor, lift points and their attachments"]
    assert (lp["value"], lp["source"]) == (1.30, "0027/ND Table 11-1")
    daf = rows["dynamic amplification, in air (comparison only)"]
    assert daf["value"] == 1.10 and "comparison" in daf["item"] and "3,200 t" in daf["note"]
    assert rows["lift point structural capacity"]["value"] == "not given"


def test_a_users_hull_has_the_guidelines_tilt_and_its_assumed_values():
    s = load_scenario(TRAWLER).with_changes(**{"lift.weight_contingency": 1.1,
                                               "lift.rigging.sling_wll_t": 55.0})
    rows = _rows(s)
    assert rows["tilt limit"]["value"] == "2 deg"
    assert rows["tilt limit"]["source"] == "0027/ND 5.3.2 (lifted object, by analogy)"
    assert rows["weight contingency"]["value"] == 1.1
    assert rows["sling and shackle working load limit (per bag)"]["value"] == "55 t"
    assert rows["hydro.drag_coefficient"]["source"] == "assumed"  # every assumed value
    assert rows["gas supply per bag"]["source"] == "assumed"
    # its free air at this wreck's depth (0.5 m3/s x 13.08 bar / 1.013 bar), not the tanker's
    assert "the wreck's 120 m that is ~6.5 m3/s of free air" in rows["gas supply per bag"]["note"]
    assert rows["ascent velocity limit"]["source"] == "default"


def test_a_pipe_has_no_tilt_limit_in_its_basis():
    rows = _rows(load_scenario("pipeline"))
    assert rows["tilt limit"]["value"].startswith("none") and rows["tilt limit"]["source"] == "derived"


def _text(page):
    return html.unescape(re.sub(r"\s+", " ", re.sub(r"<[^>]+>", " ", page)))


def test_the_report_and_summary_json_carry_it():
    tanker = load_scenario("tanker")
    stage = StageOutput("simulate:coordinated",
                        {"outcome": "safe", "outcome_cause": "every limit held", "reasons": {}},
                        criteria={"pitch": True, "reached_target": True})
    page = render_report(tanker, [stage])
    basis = page[page.index('id="design-basis"'):]
    plan = basis.index("Factors, limits and their sources")
    assert plan < len(basis)
    text = _text(basis)
    assert "skew load factor not applicable 0027/ND 5.6.12" in text
    assert "tilt limit 15 deg paper" in text
    summary = summary_of(tanker, [stage], 1.0)
    json.dumps(summary)
    assert {r["item"] for r in summary["design_basis"]} == set(_rows(tanker))


def test_a_weight_contingency_is_the_users_and_scales_the_lift_to_provide():
    from flexlift import constants as C
    from flexlift.errors import InputError
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    tanker = load_scenario("tanker").with_changes(**{"lift.layout": "balanced"})
    s = tanker.with_changes(**{"lift.weight_contingency": 1.1})
    base, plan = (plan_lift(x, hull_from_scenario(x)) for x in (tanker, s))
    assert plan.required_lift == pytest.approx(1.1 * base.required_lift, rel=1e-12)
    assert plan.bag_count == math.ceil(1.1 * base.required_lift / (C.TONNE * 9.81) / 565.0)
    assert plan.wet_weight == base.wet_weight  # the physics keeps the structure's weight
    with pytest.raises(InputError, match="weight_contingency"):
        tanker.with_changes(**{"lift.weight_contingency": 0.9})  # a factor below 1


def test_a_packaged_catalogue_bag_is_not_called_the_users():
    """The default bag of a user's hull comes from flexlift's own catalogue, and says so."""
    from flexlift.scenario.basis import _catalogue_rows
    from flexlift.scenario.schema import parse_scenario

    s = parse_scenario({"based_on": "tanker",
                        "lift": {"catalogue_bag": {"model": "open_parachute_20t"}}})
    src = _catalogue_rows(s)[0]["source"]
    assert "flexlift's catalogue" in src and "your catalogue file" not in src


def test_a_bag_flexlift_chose_says_so():
    from flexlift.scenario.basis import _catalogue_rows
    from flexlift.scenario.schema import parse_scenario

    s = parse_scenario({"based_on": "tanker", "defaulted": {"lift.catalogue_bag": "derived"},
                        "lift": {"catalogue_bag": {"model": "open_parachute_20t"}}})
    assert _catalogue_rows(s)[0]["note"].startswith("chosen by flexlift")


def test_a_bag_given_by_its_lift_alone_is_called_the_papers_cylinder_not_sized_for_it():
    """``lift.catalogue_bag: {lift_t: 10}`` keeps the rest of the bag at the paper's 565 t
    cylinder (1.5 m x 18 m, 2.8 bar): the design basis says so and how to give a real bag;
    a bag given with its body, or named from the catalogue, or the tanker's own, does not."""
    from flexlift.scenario.basis import _catalogue_rows
    from flexlift.scenario.schema import parse_scenario

    def note(bag):
        s = parse_scenario({"based_on": "tanker", "lift": {"catalogue_bag": bag}})
        return _catalogue_rows(s)[0]["note"]

    alone = note({"lift_t": 10.0})
    assert ("only its lift given" in alone and "1.5 m x 18 m, 2.8 bar" in alone
            and "not sized for 10 t" in alone and "lift.catalogue_bag.model" in alone), alone
    for given in ({"lift_t": 10.0, "type": "open_parachute", "diameter_m": 2.2,
                   "length_m": 3.3}, {"model": "open_parachute_20t"}, {"lift_t": 565.0}):
        assert "only its lift given" not in note(given), given
    assert "only its lift given" not in _catalogue_rows(load_scenario("tanker"))[0]["note"]
