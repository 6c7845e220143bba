"""A user's structure is not silently given the tanker's values (scenario/defaults.py): each
tanker default is required, derived by a named rule, or assumed and listed."""

import pytest

from flexlift import constants as C
from flexlift import load_scenario
from flexlift.cli import main
from flexlift.errors import InputError
from flexlift.scenario.defaults import E_STEEL, LAW_OF, POLICY
from flexlift.scenario.schema import parse_scenario
from flexlift.structure.hull import hull_from_scenario

#: a 60 m trawler, 900 t, engine aft: what its engineer knows
TRAWLER = {
    "name": "trawler",
    "environment": {"water_depth_m": 80.0},
    "control": {"target_height_m": 50.0},
    "hull": {"length_m": 60.0, "breadth_m": 11.0, "depth_m": 5.0, "elements": 20,
             "displacement_t": 800.0, "point_masses": [{"node": 4, "mass_t": 100.0}],
             "bending_stiffness_Nm2": 1.2e12},
}


def _with(data, **changes):
    out = {k: (dict(v) if isinstance(v, dict) else v) for k, v in data.items()}
    for dotted, value in changes.items():
        section, key = dotted.split(".")
        out[section] = {**out.get(section, {}), key: value}
        if value is None:
            del out[section][key]
    return out


def test_a_users_hull_is_never_given_the_tankers_section_modulus():
    s = parse_scenario(TRAWLER)
    assert s.hull.section_modulus_m3 != 0.85
    assert s.hull.section_modulus_m3 == pytest.approx(2 * 1.2e12 / (E_STEEL * 5.0), rel=1e-12)
    assert s.defaulted["hull.section_modulus_m3"] == "derived"
    # and the tanker's other particulars are not there either
    assert s.lift.internal_bags == 0 and s.seabed.holding_shape == "uniform"
    assert s.defaulted["lift.internal_bags"] == "derived"


def test_the_stiffness_is_derived_from_the_section_modulus():
    s = parse_scenario(_with(TRAWLER, **{"hull.bending_stiffness_Nm2": None,
                                         "hull.section_modulus_m3": 0.5}))
    assert s.hull.bending_stiffness_Nm2 == pytest.approx(E_STEEL * 0.5 * 5.0 / 2, rel=1e-12)
    assert s.defaulted["hull.bending_stiffness_Nm2"] == "derived"


@pytest.mark.parametrize("missing, named", [
    ("environment.water_depth_m", "environment.water_depth_m"),
    ("control.target_height_m", "control.target_height_m"),
    ("hull.length_m", "hull.length_m"),
    ("hull.breadth_m", "hull.breadth_m"),
    ("hull.depth_m", "hull.depth_m"),
    ("hull.displacement_t", "hull.displacement_t or hull.mass_per_length_kg_m"),
    ("hull.bending_stiffness_Nm2", "hull.bending_stiffness_Nm2 or hull.section_modulus_m3"),
])
def test_a_required_particular_missing_is_one_line_naming_it(missing, named):
    with pytest.raises(InputError) as e:
        parse_scenario(_with(TRAWLER, **{missing: None}))
    assert f"{named} is missing" in str(e.value) and "based_on: tanker" in str(e.value)
    assert "\n" not in str(e.value)


def test_internal_bags_need_their_frames():
    with pytest.raises(InputError, match="hull.frame_spacing_m is missing"):
        parse_scenario(_with(TRAWLER, **{"lift.internal_bags": 2}))
    s = parse_scenario(_with(_with(TRAWLER, **{"lift.internal_bags": 2}),
                             **{"hull.frame_spacing_m": 0.6, "hull.ballast_tank_frames": [10, 80]}))
    assert s.lift.internal_bags == 2


def test_the_cli_refuses_an_old_file_that_relied_on_the_tanker(tmp_path, capsys):
    f = tmp_path / "wreck.yaml"
    f.write_text("name: wreck\nhull:\n  length_m: 40\n  breadth_m: 8\n  depth_m: 4\n"
                 "  displacement_t: 300\n  bending_stiffness_Nm2: 5e11\n")
    assert main(["modes", str(f)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "environment.water_depth_m is missing" in err[0]


def test_based_on_tanker_keeps_the_tankers_values():
    s = parse_scenario({"based_on": "tanker", "hull": {"bending_stiffness_Nm2": 2e12}})
    assert s.hull.section_modulus_m3 == 0.85 and s.environment.water_depth_m == 350.0
    assert s.lift.internal_bags == 3 and s.defaulted == {}


def test_a_scenario_without_a_structure_is_the_tanker_with_overrides():
    s = parse_scenario({"control": {"ascent_speed_m_s": 0.1}, "hull": {"elements": 22}})
    assert s.hull.length_m == 78.02 and s.defaulted == {}


def test_the_built_in_scenarios_assume_nothing():
    assert load_scenario("tanker").defaulted == {}
    pipeline = load_scenario("pipeline")
    assert "environment.water_depth_m" not in pipeline.defaulted


def test_every_assumed_value_is_listed_with_its_value_and_reason():
    s = parse_scenario(TRAWLER)
    assumed = {k for k, how in s.defaulted.items() if how == "assumed"}
    expected = {k for k, (p, _) in POLICY.items()
                if p == "assumed" and LAW_OF.get(k, "timer") == "timer"}  # the default law
    assert assumed == expected
    notes = " ".join(s.notes())
    assert "hull.allowable_stress_MPa = 175 (assumed:" in notes
    assert "control.breakout_pull_t = none (assumed: 18 % of the suction" in notes


def test_a_rerun_of_the_written_scenario_keeps_what_was_assumed():
    s = parse_scenario(TRAWLER)
    again = load_scenario_text(s.to_yaml())
    assert again.defaulted == s.defaulted and again.checksum() == s.checksum()


def load_scenario_text(text):
    from flexlift.scenario.file import load_yaml

    return parse_scenario(load_yaml(text, "s"))


# --------------------------------------------------------------------------- plausibility
def test_a_mass_above_a_solid_steel_block_is_refused_naming_the_key():
    with pytest.raises(InputError) as e:  # 800 t typed in kilograms ... clipped to the range
        parse_scenario(_with(TRAWLER, **{"hull.displacement_t": 900_000}))
    msg = str(e.value)
    assert "hull.displacement_t" in msg and "solid steel block" in msg and "catalogue" not in msg
    # the block: 60 x 11 x 5 m of steel = 25,905 t; the point mass (100 t) counts
    with pytest.raises(InputError, match="25,905 t"):
        parse_scenario(_with(TRAWLER, **{"hull.displacement_t": 25_810}))
    s = parse_scenario(_with(TRAWLER, **{"hull.displacement_t": 25_800}))
    assert any("more than half" in n for n in s.notes())


@pytest.mark.parametrize("mass, words", [(15_000, "more than half"), (20, "less than 1 %")])
def test_an_unlikely_mass_is_warned(mass, words):
    s = parse_scenario(_with(TRAWLER, **{"hull.displacement_t": mass}))
    assert any(words in n and "hull.displacement_t" in n for n in s.notes())
    assert not any("solid steel" in n for n in parse_scenario(TRAWLER).notes())


# --------------------------------------------------------------------------- submerged weight
def test_the_submerged_weight_can_be_given_directly():
    s = parse_scenario(_with(TRAWLER, **{"hull.submerged_weight_t": 650.0}))
    env = s.environment
    hull = hull_from_scenario(s)
    W = hull.total_wet_weight(env.gravity_m_s2, env.seawater_density_kg_m3,
                              env.steel_density_kg_m3)
    assert W / env.gravity_m_s2 / C.TONNE == pytest.approx(650.0, rel=1e-12)
    steel = hull_from_scenario(parse_scenario(TRAWLER))
    assert steel.total_wet_weight(env.gravity_m_s2, env.seawater_density_kg_m3,
                                  env.steel_density_kg_m3) / env.gravity_m_s2 / C.TONNE \
        == pytest.approx(900 * (1 - 1025 / 7850), rel=1e-12)


def test_a_submerged_weight_above_the_mass_is_refused():
    with pytest.raises(InputError, match="submerged_weight_t"):
        parse_scenario(_with(TRAWLER, **{"hull.submerged_weight_t": 950.0}))


def test_the_scenario_reference_lists_every_rule():
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "reference" / "scenario.md").read_text()
    for key, (policy, _) in POLICY.items():
        row = re.search(rf"^\| `{re.escape(key.replace('|', '` or `'))}` \| [^|]* \| {policy} \|",
                        text, flags=re.M)
        assert row, key


@pytest.mark.parametrize("defaulted", [[0.0], [[0.0, None]], {1: "assumed"}, "all", 3])
def test_a_hostile_defaulted_is_one_line_not_a_crash(defaulted):
    """Found by hypothesis: `defaulted` that is not a mapping of keys reached dict()."""
    with pytest.raises(InputError) as e:
        parse_scenario({**TRAWLER, "defaulted": defaulted})
    assert "defaulted" in str(e.value) and "\n" not in str(e.value)


def test_the_soil_laws_inputs_are_assumed_only_under_that_law():
    """A user's hull on the soil breakout law lists the soil's values it was not given as
    assumed, and not the timer's breakout time it does not read; on the timer, the reverse."""
    soil = parse_scenario({**TRAWLER, "seabed": {"breakout_law": "soil", "embedment_m": 2.0}})
    assert soil.defaulted["seabed.shear_strength_kPa"] == "assumed"
    assert soil.defaulted["seabed.consolidation_coefficient_m2_s"] == "assumed"
    assert "seabed.embedment_m" not in soil.defaulted  # given
    assert "seabed.breakout_time_s" not in soil.defaulted
    timer = parse_scenario(TRAWLER)
    assert timer.defaulted["seabed.breakout_time_s"] == "assumed"
    assert "seabed.shear_strength_kPa" not in timer.defaulted
