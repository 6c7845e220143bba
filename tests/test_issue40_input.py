"""Hostile input of issue 40 through the CLI: one line on stderr naming the field, the value
and what is allowed, exit code 2, no traceback; and the papercuts' printed output."""

import pytest

from flexlift.cli import main


def _one_line(capsys, *needles):
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert "Traceback" not in err
    for n in needles:
        assert n in lines[0], lines[0]
    return lines[0]


@pytest.mark.parametrize("flag, shown", [("'no'", "no"), ("true", "True"), ("false", "False"),
                                         ("1", "1")])
def test_a_users_catalogue_may_not_give_as_published(tmp_path, capsys, flag, shown):
    (tmp_path / "mine.yaml").write_text(
        "bags:\n  my_bag: {type: enclosed, lift_t: 50, diameter_m: 0.05, length_m: 0.05, "
        f"as_published: {flag}}}\n")
    f = tmp_path / "s.yaml"
    f.write_text("name: t\nbased_on: tanker\nlift:\n  catalogue_file: mine.yaml\n"
                 "  catalogue_bag: {model: my_bag}\n")
    assert main(["loads", str(f)]) == 2
    _one_line(capsys, "my_bag", "as_published", f"as_published = {shown}", "packaged catalogue only")


def test_the_packaged_flag_is_strictly_boolean():
    from flexlift.errors import InputError
    from flexlift.scenario import catalogue

    entry = {"type": "enclosed", "lift_t": 50, "diameter_m": 0.05, "length_m": 0.05,
             "as_published": "no"}
    with pytest.raises(InputError, match="as_published = no must be true or false"):
        catalogue.check_entry("b", entry, "x", packaged=True)
    assert catalogue.check_entry("b", dict(entry, as_published=True), "x", packaged=True)
    with pytest.raises(InputError, match="less than"):
        catalogue.check_entry("b", dict(entry, as_published=False), "x", packaged=True)


@pytest.mark.parametrize("command", ["modes", "loads", "reduce", "fuzzy", "simulate", "run"])
@pytest.mark.parametrize("name, needle", [
    ("a" * 5000, "at most 3000 bytes are allowed"),
    ("b" * 300, "at most 200 bytes per name are allowed"),
])
def test_an_overlong_out_is_one_line(tmp_path, capsys, command, name, needle):
    out = tmp_path / name
    assert main([command, "tanker", "--out", str(out)]) == 2
    _one_line(capsys, "--out", str(tmp_path)[:40], needle)


def _scenario(tmp_path, text, name="s.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return str(p)


@pytest.mark.parametrize("text, needles", [
    ("based_on: tanker\nlift:\n  rigging: {sling_length_m: 1000}\n",
     ("lift.rigging.sling_length_m 1000 m", "less than 344.6 m", "water_depth_m 350 m")),
    ("based_on: tanker\nlift:\n  rigging: {sling_length_m: 344.6}\n",
     ("lift.rigging.sling_length_m 344.6 m",)),
    ("based_on: tanker\nhull:\n  point_masses:\n    - {x_m: -5, mass_t: 10}\n",
     ("point_masses[0].x_m = -5 m", "allowed [0, 78.02] m")),
    ("based_on: tanker\nhull:\n  point_masses:\n    - {x_m: 78.1, mass_t: 10}\n",
     ("point_masses[0].x_m = 78.1 m", "allowed [0, 78.02] m")),
    ("based_on: tanker\nhull:\n  point_masses:\n    - {mass_t: 10}\n",
     ("point_masses[0]", "exactly one of node", "x_m")),
])
def test_refused_at_load(tmp_path, capsys, text, needles):
    assert main(["loads", _scenario(tmp_path, text)]) == 2
    _one_line(capsys, *needles)


def test_a_pipes_point_mass_off_the_line(tmp_path, capsys):
    from pathlib import Path

    text = (Path(__file__).parents[1] / "scenarios" / "pipeline.yaml").read_text()
    text = text.replace("pipe:\n", "pipe:\n  point_masses: [{x_m: -5, mass_t: 10}]\n", 1)
    assert main(["modes", _scenario(tmp_path, text, "p.yaml")]) == 2
    _one_line(capsys, "point_masses[0].x_m = -5 m", "allowed [0, 1000] m")


def test_a_point_mass_at_x_m_sits_at_the_nearest_node():
    from flexlift.scenario import parse_scenario

    by_x = parse_scenario({"based_on": "tanker",
                           "hull": {"point_masses": [{"x_m": 78.02, "mass_t": 10}]}})
    by_node = parse_scenario({"based_on": "tanker",
                              "hull": {"point_masses": [{"node": 12, "mass_t": 10}]}})
    pm = by_x.hull.point_masses[0]
    assert pm.node_on(by_x.hull.length_m, by_x.hull.elements) == 12
    assert by_x.hull_mass_t() == by_node.hull_mass_t()


def test_a_fault_naming_an_unknown_bag_is_refused_before_any_stage(tmp_path, capsys):
    path = _scenario(tmp_path, "based_on: tanker\nfaults:\n"
                               "  - {kind: sling_break, bag: B01, time_s: 1}\n")
    assert main(["run", path, "--out", str(tmp_path / "o")]) == 2
    line = _one_line(capsys, "faults[0].bag", "'B01'", "bag_1, bag_2", "bag_7")
    assert "[1/" not in line
    assert not (tmp_path / "o").exists()


def test_the_runs_warnings_are_printed_once_with_where_the_rest_are(tmp_path, capsys,
                                                                     monkeypatch):
    import flexlift.cli.run as cli_run

    real = cli_run.summary_of

    def more(*a, **k):
        s = real(*a, **k)
        s["warnings"] = s["warnings"] + [f"extra warning {i}" for i in range(4)]
        return s

    monkeypatch.setattr(cli_run, "summary_of", more)
    path = _scenario(tmp_path, "lift:\n  bag_lift_t: 450\n")
    out = tmp_path / "o"
    assert main(["run", path, "--stages", "modes,loads", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "5 warning(s)" in err
    assert err.count("467 t short") == 1  # the library logged it too: printed once
    assert "extra warning 0" in err and "extra warning 1" in err
    assert "extra warning 2" not in err
    assert f"... and 2 more warning(s): {out / 'summary.json'}" in err


def test_a_pipes_fault_names_its_bags_briefly(tmp_path, capsys):
    from pathlib import Path

    text = (Path(__file__).parents[1] / "scenarios" / "pipeline.yaml").read_text()
    text += "\nfaults:\n  - {kind: sling_break, bag: bag_1, time_s: 1}\n"
    assert main(["modes", _scenario(tmp_path, text, "p.yaml")]) == 2
    _one_line(capsys, "faults[0].bag: got 'bag_1'", "B01, B02, B03, B04, ..., B39, B40 (40 bags)")


def test_an_overlong_contingency_out_is_one_line_before_any_run(tmp_path, capsys):
    """Refused before the fault-free run and its "N cases" line (which came first before)."""
    assert main(["contingency", "tanker", "--out", str(tmp_path / ("c" * 5000))]) == 2
    _one_line(capsys, "flexlift contingency: error: --out", "at most 3000 bytes are allowed")
