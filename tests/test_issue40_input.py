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
