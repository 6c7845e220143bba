"""`flexlift fuzzy`: JSON grid and point evaluation, files, .fis input, bad input."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flexlift.cli import main
from flexlift.cli.fuzzy import run_stage
from flexlift.fis import write_fis
from flexlift.rulebase import supervisor_fis


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
    d = _json(capsys, ["fuzzy", "--json"])
    assert d == json.loads(json.dumps(res.summary))


def test_grid_orientation_with_an_asymmetric_fis(tmp_path, capsys):
    from flexlift.fuzzy import FIS, Rule

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
