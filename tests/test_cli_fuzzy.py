"""`flexlift fuzzy`: JSON grid and point evaluation, files, .fis input, bad input."""

import csv
import json
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flexlift.cli import main
from flexlift.fuzzy.fis import write_fis
from flexlift.fuzzy.rulebase import supervisor_fis
from flexlift.stages.fuzzy import run_stage


def _json(capsys, argv):
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1
    return json.loads(out)


def test_grid_json(capsys):
    d = _json(capsys, ["fuzzy", "--grid", "9", "--json"])
    assert set(d) == {"ze", "w", "u"}
    np.testing.assert_allclose(d["ze"], np.linspace(-1, 1, 9))
    np.testing.assert_allclose(d["w"], np.linspace(-1, 1, 9))
    u = np.array(d["u"])
    assert u.shape == (9, 9)
    fis = supervisor_fis()
    assert u[2][7] == pytest.approx(fis([d["ze"][2], d["w"][7]]), abs=1e-15)  # u[i][j] at ze[i], w[j]
    assert u[2][7] == pytest.approx(u[7][2])  # the SPEC table is symmetric in e and edot
    np.testing.assert_allclose(u, -u[::-1, ::-1], atol=1e-12)


def test_eval_json(capsys):
    d = _json(capsys, ["fuzzy", "--eval", "0.3,-0.2", "--json"])
    assert d == {"u": pytest.approx(supervisor_fis()([0.3, -0.2]), abs=1e-15)}
    d = _json(capsys, ["fuzzy", "--eval=-0.3,0.2", "--json"])
    assert d["u"] == pytest.approx(-supervisor_fis()([0.3, -0.2]), abs=1e-15)
    # saturated beyond the universe
    assert _json(capsys, ["fuzzy", "--eval", "4,4", "--json"]) == _json(
        capsys, ["fuzzy", "--eval", "1,1", "--json"])


def test_scenario_operators_are_used(tmp_path, capsys, tanker):
    import yaml

    changed = tanker.with_changes(**{"control.supervisor.defuzzification": "mom"})
    y = tmp_path / "s.yaml"
    y.write_text(yaml.safe_dump(changed.model_dump(mode="json")))
    d = _json(capsys, ["fuzzy", str(y), "--eval", "0.3,-0.2", "--json"])
    assert d["u"] == supervisor_fis(defuzzification="mom")([0.3, -0.2])


def test_summary_files_and_run_stage(tmp_path, capsys, tanker):
    res = run_stage(tanker, tmp_path)
    assert res.name == "fuzzy" and all(res.criteria.values())
    assert res.summary["surface"]["max_error"] < 0.01
    assert res.summary["n_rules"] == 49
    assert res.tables[0].rows[0] == ["PB", "ZE", "PS", "PM", "PB", "PB", "PB", "PB"]
    names = sorted(f.path.name for f in res.figures)
    assert names == ["fuzzy_fill_map.png", "fuzzy_memberships.png", "fuzzy_surface_3d.png",
                     "fuzzy_surface_contour.png"]
    assert all(f.path.stat().st_size > 10_000 for f in res.figures)
    assert (tmp_path / "tables" / "fuzzy_rules.csv").read_text().startswith("e \\ edot,NB,")
    rules, sets = res.tables
    assert rules.in_report and rules.csv == "fuzzy_rules.csv"
    # the 21 membership functions go to their CSV, not the page, with every parameter
    assert not sets.in_report and sets.csv == "fuzzy_sets.csv"
    rows = list(csv.reader((tmp_path / "tables" / "fuzzy_sets.csv").open()))
    assert rows[0] == ["variable", "set", "type", "parameters"] and len(rows) == 1 + 21
    fis = supervisor_fis()
    mf = fis.inputs[0].mfs[3]
    assert rows[4][:3] == [fis.inputs[0].name, mf.name, mf.kind]
    assert [float(p) for p in rows[4][3].split()] == pytest.approx(list(mf.params), rel=1e-5)
    d = _json(capsys, ["fuzzy", "--json"])
    assert d == json.loads(json.dumps(res.summary))


def test_grid_orientation_with_an_asymmetric_fis(tmp_path, capsys):
    from flexlift.fuzzy.system import FIS, Rule

    base = supervisor_fis()
    only_e = FIS("only_e", base.inputs, base.output, tuple(Rule((i, None), i) for i in range(7)))
    path = write_fis(only_e, tmp_path / "e.fis")
    d = _json(capsys, ["fuzzy", "--fis", str(path), "--grid", "5", "--json"])
    u = np.array(d["u"])
    np.testing.assert_allclose(u, np.repeat(u[:, :1], 5, axis=1), atol=1e-15)  # rows vary with ze
    assert np.all(np.diff(u[:, 0]) > 0)


def test_fis_file_input(tmp_path, capsys):
    path = write_fis(supervisor_fis(implication="prod"), tmp_path / "mine.fis")
    d = _json(capsys, ["fuzzy", "--fis", str(path), "--eval", "0.5,0.1", "--json"])
    assert d["u"] == supervisor_fis(implication="prod")([0.5, 0.1])
    d = _json(capsys, ["fuzzy", "--fis", str(path), "--json"])
    assert d["operators"]["implication"] == "prod" and d["source"].endswith("mine.fis")


@pytest.mark.parametrize(
    "argv",
    [["--eval", "nan,0.1"], ["--eval", "0.1"], ["--eval", "a,b"], ["--eval", "0.1,0.2,0.3"],
     ["--grid", "0"], ["--grid", "1"], ["--grid", "3", "--eval", "0,0"],
     ["--fis", "missing.fis"], ["--fis", "BAD", "--eval", "0,0"]],
)
def test_bad_input_one_line_exit_2(argv, tmp_path, capsys):
    argv = [str(tmp_path / "bad.fis") if a == "BAD" else a for a in argv]
    (tmp_path / "bad.fis").write_text("[System]\nType='sugeno'\n")
    try:
        code = main(["fuzzy", *argv])
    except SystemExit as exc:  # argparse errors
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and "Traceback" not in err


def test_entry_point_subprocess():
    flexlift = Path(sys.executable).with_name("flexlift")
    exe = [str(flexlift), "fuzzy", "--eval", "0.3,nan", "--json"]
    r = subprocess.run(exe, capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and r.stdout == "" and r.stderr.count("\n") == 1


CORPUS = Path(__file__).parent / "data" / "fis"


def test_any_real_fis_file(tmp_path, capsys):
    tipper = str(CORPUS / "matlab" / "tipper.fis")  # MATLAB's file as shipped, comment first
    assert _json(capsys, ["fuzzy", "--fis", tipper, "--eval", "2,1", "--json"])["u"] == \
        pytest.approx(7.0169, abs=5e-5)
    two = str(CORPUS / "matlab" / "shower.fis")  # two outputs
    d = _json(capsys, ["fuzzy", "--fis", two, "--eval=-5,0.2", "--json"])
    assert len(d["u"]) == 2
    g = _json(capsys, ["fuzzy", "--fis", two, "--grid", "3", "--json"])
    assert np.array(g["u"]).shape == (3, 3, 2)  # u[i][j] at (ze[i], w[j]), both outputs
    assert g["u"][2][0] == pytest.approx(
        _json(capsys, ["fuzzy", "--fis", two, "--eval", "20,-1", "--json"])["u"], rel=1e-14)
    s = _json(capsys, ["fuzzy", "--fis", two, "--json"])
    assert [o["name"] for o in s["outputs"]] == ["cold", "hot"] and "surface" not in s
    seven = str(CORPUS / "matlab" / "slcpp1.fis")  # Sugeno, seven inputs
    d = _json(capsys, ["fuzzy", "--fis", seven, "--eval", "0,0,0,0,0,0,1", "--json"])
    from flexlift.fuzzy.fis import read_fis
    assert d["u"] == read_fis(seven)([0, 0, 0, 0, 0, 0, 1])
    assert main(["fuzzy", "--fis", seven, "--out", str(tmp_path / "o")]) == 0
    assert "sugeno, 7 inputs, 1 output" in capsys.readouterr().out
    assert sorted(f.name for f in (tmp_path / "o" / "figures").iterdir()) == ["fuzzy_memberships.png"]
    assert read_fis(tmp_path / "o" / "fuzzy_supervisor.fis") == read_fis(seven)
    assert (tmp_path / "o" / "tables" / "fuzzy_rules.csv").read_text().count("\n") == 12


def test_extrapolate_as_matlab(tmp_path, capsys):
    path = tmp_path / "narrow.fis"
    path.write_text("[System]\nName='n'\nType='mamdani'\nNumInputs=1\nNumOutputs=1\n"
                    "[Input1]\nName='x'\nRange=[0 1]\nNumMFs=1\nMF1='top':'trimf',[0.5 1 1]\n"
                    "[Output1]\nName='y'\nRange=[0 4]\nNumMFs=1\nMF1='hi':'trimf',[2 4 4]\n"
                    "[Rules]\n1, 1 (1) : 1\n")
    clipped = _json(capsys, ["fuzzy", "--fis", str(path), "--eval", "1.5", "--json"])["u"]
    matlab = _json(capsys, ["fuzzy", "--fis", str(path), "--eval", "1.5", "--json",
                            "--extrapolate"])["u"]
    assert matlab == 2.0 and clipped > 3.0  # MATLAB: no rule fires beyond the set, mid-range


@pytest.mark.parametrize(
    "name, argv, match",
    [("octave/investment_portfolio.fis", [], "investment_portfolio.fis line 32: .*einstein_product"),
     ("fuzzylite/mamdani/Laundry.fis", ["--eval", "1,1"], "Laundry.fis line 20: .*discretemf"),
     ("matlab/slcpp1.fis", ["--eval", "1,2"], "7 comma-separated numbers, one per input"),
     ("matlab/mam22.fis", ["--grid", "4", "--eval", "1,1"], "not allowed with")],
)
def test_files_flexlift_cannot_use_exit_2_with_one_line(name, argv, match, capsys):
    try:
        code = main(["fuzzy", "--fis", str(CORPUS / name), *argv])
    except SystemExit as exc:
        code = exc.code
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and "Traceback" not in err
    assert re.search(match, err), err


def test_a_grid_needs_two_inputs(capsys):
    code = main(["fuzzy", "--fis", str(CORPUS / "matlab" / "slcpp1.fis"), "--grid", "3"])
    assert code == 2 and "needs a two-input system; this one has 7" in capsys.readouterr().err
