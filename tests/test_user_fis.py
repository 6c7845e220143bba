"""Issue 13: the user's own .fis controller in the loop (control.supervisor.fis_file and
control.fill.fis_file): the simulation, `flexlift fuzzy` and the report use the file, it is
copied into the output folder with its checksum, and a file that does not fit is one line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import yaml

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.cli import main
from flexlift.control.build import fill_map_of, fuzzy_maps
from flexlift.errors import InputError
from flexlift.fuzzy.fis import to_fis_text
from flexlift.fuzzy.rulebase import fill_fis, supervisor_fis_from

DURATION = 2300.0  # past the separation at ~1880 s: a few hundred seconds of controlled ascent


def _write_scenario(folder: Path, tanker, **changes) -> Path:
    data = tanker.with_changes(**changes).model_dump(mode="json") if changes else \
        tanker.model_dump(mode="json")
    p = folder / "lift.yaml"
    p.write_text(yaml.safe_dump(data), encoding="utf-8")
    return p


def _lazy_supervisor_text(tanker) -> str:
    """The built-in supervisor with every rule's output set to ZE: u = 0 everywhere."""
    fis = supervisor_fis_from(tanker.control.supervisor)
    text = to_fis_text(fis)
    lines = text.splitlines()
    start = lines.index("[Rules]") + 1
    ze = 1 + list(fis.output.labels).index("ZE")
    out = []
    for line in lines[start:]:
        if not line.strip():
            continue
        ante, rest = line.split(",", 1)  # "7 1, 4 (1) : 1": antecedent, consequent (weight)
        out.append(f"{ante}, {ze} {rest.split(None, 1)[1]}")
    return "\n".join(lines[:start] + out) + "\n"


def test_the_built_in_supervisor_as_a_file_gives_the_same_ascent(tmp_path, tanker):
    f = tmp_path / "ctl" / "mine.fis"
    f.parent.mkdir()
    f.write_text(to_fis_text(supervisor_fis_from(tanker.control.supervisor)), encoding="utf-8")
    # a relative path: relative to the scenario file's folder, not the working directory
    sc = load_scenario(_write_scenario(tmp_path, tanker,
                                       **{"control.supervisor.fis_file": "ctl/mine.fis"}))
    assert sc.control.supervisor.fis_file == str(f.resolve())
    a = simulate(tanker, control="coordinated", duration=DURATION)
    b = simulate(sc, control="coordinated", duration=DURATION)
    np.testing.assert_allclose(b.dataset.height.values, a.dataset.height.values, atol=1e-9)


def test_a_users_supervisor_drives_the_ascent(tmp_path, tanker):
    f = tmp_path / "lazy.fis"
    f.write_text(_lazy_supervisor_text(tanker), encoding="utf-8")
    sc = tanker.with_changes(**{"control.supervisor.fis_file": str(f)})
    table = fuzzy_maps(sc)[0]
    assert np.abs(table.values).max() < 1e-9  # u = 0 everywhere: the file, not the rule base
    a = simulate(tanker, control="coordinated", duration=DURATION)
    b = simulate(sc, control="coordinated", duration=DURATION)
    ua, ub = a.dataset.supervisor_output.values, b.dataset.supervisor_output.values
    assert np.nanmax(np.abs(ua)) > 0.05 and np.nanmax(np.abs(ub)) < 1e-9  # nan: internal bags
    assert not np.allclose(a.dataset.height.values, b.dataset.height.values, atol=0.01)


def test_a_supervisor_that_does_not_fit_is_one_line_exit_2(tmp_path, capsys, tanker):
    from flexlift.fuzzy.fis import from_fis_text

    text = to_fis_text(fill_fis().fis)  # one input: not a supervisor
    from_fis_text(text)
    f = tmp_path / "one_input.fis"
    f.write_text(text, encoding="utf-8")
    p = _write_scenario(tmp_path, tanker, **{"control.supervisor.fis_file": str(f)})
    assert main(["simulate", str(p), "--duration", "10"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "one_input.fis" in err and "two inputs" in err, err
    p = _write_scenario(tmp_path, tanker, **{"control.supervisor.fis_file": "missing.fis"})
    assert main(["simulate", str(p), "--duration", "10"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "control.supervisor.fis_file" in err, err
    with pytest.raises(InputError, match="fis_file"):
        tanker.with_changes(**{"control.supervisor.fis_file": "rules.txt"})


FALLING = """[System]
Name='falling'
Type='mamdani'
NumInputs=1
NumOutputs=1
NumRules=2
AndMethod='min'
OrMethod='max'
ImpMethod='min'
AggMethod='max'
DefuzzMethod='centroid'

[Input1]
Name='d'
Range=[0 1]
NumMFs=2
MF1='low':'trimf',[-1 0 1]
MF2='high':'trimf',[0 1 2]

[Output1]
Name='fill'
Range=[0 1]
NumMFs=2
MF1='off':'trimf',[-1 0 1]
MF2='on':'trimf',[0 1 2]

[Rules]
1, 2 (1) : 1
2, 1 (1) : 1
"""


def test_a_users_fill_map_is_used_as_it_is_and_checked(tmp_path, tanker):
    fis = fill_fis().fis
    f = tmp_path / "fill.fis"
    f.write_text(to_fis_text(fis), encoding="utf-8")
    sc = tanker.with_changes(**{"control.fill.fis_file": str(f)})
    d = np.linspace(0.0, 1.0, 4001)
    got = fill_map_of(sc).table.values
    np.testing.assert_allclose(got, np.clip(np.maximum.accumulate(fis(d)), 0, 1), atol=1e-12)
    assert got[-1] < 0.99  # not normalised to 1 as the built-in map is
    # a map that falls as the deficit grows (within [0, 1]) is refused with the field and where
    g = tmp_path / "falling.fis"
    g.write_text(FALLING, encoding="utf-8")
    with pytest.raises(InputError, match="control.fill.fis_file.*must not decrease"):
        fill_map_of(tanker.with_changes(**{"control.fill.fis_file": str(g)}))


def test_run_copies_the_file_with_its_checksum_and_reruns_the_same(tmp_path, tanker):
    import hashlib

    f = tmp_path / "mine.fis"
    text = to_fis_text(supervisor_fis_from(tanker.control.supervisor))
    f.write_text(text, encoding="utf-8")
    p = _write_scenario(tmp_path, tanker, **{"control.supervisor.fis_file": "mine.fis",
                                             "simulation.duration_s": 30.0})
    out = tmp_path / "out"
    assert main(["run", str(p), "--out", str(out), "--quiet", "--stages", "fuzzy,simulate"]) == 0
    copy = out / "controllers" / "supervisor_mine.fis"
    digest = hashlib.sha256(text.encode()).hexdigest()
    assert copy.read_text(encoding="utf-8") == text
    assert (out / "controllers" / "supervisor_mine.fis.sha256").read_text().split()[0] == digest
    summary = json.loads((out / "summary.json").read_text())
    assert summary["controller_files"][0]["sha256"] == digest
    again = load_scenario(out / "scenario.yaml")
    assert again.control.supervisor.fis_file == str(copy.resolve())
    assert again.checksum() == load_scenario(p).checksum()  # by content, not by path
    html = (out / "report.html").read_text(encoding="utf-8")
    assert f"mine.fis, SHA-256 {digest}" in html
    assert summary["stages"]["fuzzy"]["source"] == str(f.resolve())  # the report's surface
    assert summary["scenario_checksum"] == again.checksum()
