import pytest

from flexlift import load_scenario
from flexlift.errors import InputError
from flexlift.scenario import builtin_names, parse_scenario


def test_tanker_is_builtin_and_matches_spec(tanker):
    assert "tanker" in builtin_names()
    assert tanker.hull.length_m == 78.02
    assert tanker.hull.elements == 11
    assert tanker.hull.displacement_t == 3200
    assert tanker.hull.bending_stiffness_Nm2 == 3.0e12
    assert tanker.environment.water_depth_m == 350
    assert tanker.control.target_height_m == 300


def test_unknown_key_lists_valid_ones():
    with pytest.raises(InputError) as e:
        parse_scenario({"hull": {"lenght_m": 10}})
    msg = str(e.value)
    assert "lenght_m" in msg and "length_m" in msg and "\n" not in msg


def test_unknown_top_level_key():
    with pytest.raises(InputError, match="valid keys here are: name"):
        parse_scenario({"hul": {}})


@pytest.mark.parametrize(
    "data, field",
    [
        ({"hull": {"length_m": -1}}, "hull.length_m"),
        ({"hull": {"bending_stiffness_Nm2": 0}}, "hull.bending_stiffness_Nm2"),
        ({"hull": {"elements": 0}}, "hull.elements"),
        ({"hull": {"displacement_t": -5}}, "hull.displacement_t"),
        ({"hull": {"elements": 3, "bending_stiffness_Nm2": [1.0, 2.0]}}, "hull"),
        ({"control": {"target_height_m": 400}}, "scenario"),
    ],
)
def test_bad_values_name_the_field(data, field):
    with pytest.raises(InputError) as e:
        parse_scenario(data)
    assert field in str(e.value)


def test_missing_file_and_malformed_yaml(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_scenario(tmp_path / "nope.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_text("hull: [1, 2\n")
    with pytest.raises(InputError, match="malformed YAML at line"):
        load_scenario(bad)


def test_round_trip_and_checksum(tanker, tmp_path):
    p = tmp_path / "again.yaml"
    p.write_text(tanker.to_yaml())
    again = load_scenario(p)
    assert again == tanker
    assert again.checksum() == tanker.checksum()
    changed = tanker.with_changes(**{"hull.elements": 20})
    assert changed.hull.elements == 20 and changed.checksum() != tanker.checksum()


@pytest.mark.parametrize("name", ["tanker", "pipeline"])
def test_the_checksum_is_the_sha256_of_the_whole_yaml_dumped_by_sections(name):
    """The checksum dumps each top-level section alone and keeps it (a sweep's cases share
    most of them): the same text as dumping the whole scenario, before and after a change,
    and a changed value reaches the hash, also one -0.0 from 0.0 or 1 from 1.0 apart."""
    import hashlib

    from flexlift.scenario.file import dump_sections, dump_yaml

    base = load_scenario(name)
    for sc in (base, base.with_changes(**{"seabed.breakout_time_s": 321.5}), base,
               base.with_changes(**{"disturbance.current_m_s": -0.0}),
               base.with_changes(**{"disturbance.current_m_s": 0.0})):
        data = sc.model_dump(mode="json")
        assert dump_sections(data) == dump_yaml(data)
        assert sc.checksum() == hashlib.sha256(sc.to_yaml().encode()).hexdigest()
    assert (base.with_changes(**{"disturbance.current_m_s": -0.0}).checksum()
            != base.with_changes(**{"disturbance.current_m_s": 0.0}).checksum())


def test_dump_sections_falls_back_to_the_whole_dump_where_text_could_differ():
    from flexlift.scenario.file import dump_sections, dump_yaml

    shared = [1.0, 2.0]
    for data in ({}, {"a": shared, "b": shared}, {"a": {"x": 1}, "b": (1, 2)},
                 {"a": 1, "b": 1.0, "c": True, "d": "1"}):
        assert dump_sections(data) == dump_yaml(data)
