"""``flexlift modes``: JSON summary, files, and one-line errors with exit code 2."""

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from flexlift.cli import main
from flexlift.stages.modes import run_stage
from flexlift.structure.hull import hull_from_scenario
from flexlift.structure.modes import analytic_free_free_hz, compute_modes


def run_json(capsys, *args):
    rc = main(["modes", *args, "--json"])
    out, err = capsys.readouterr()
    assert rc == 0, err
    assert out.count("\n") == 1  # one JSON object
    return json.loads(out)


def test_json_of_the_tanker(capsys, tanker_hull):
    s = run_json(capsys)
    assert s["elements"] == 11
    assert s["rigid_modes"] == 2
    f = np.array(s["frequencies_hz"])
    assert f.size == 24 and np.all(np.diff(f) >= 0)
    np.testing.assert_allclose(f, compute_modes(tanker_hull).frequencies_hz, rtol=1e-12)
    # one numbering: heave, pitch, then flexible modes 1, 2, ... (as lift.layout_flexible_mode)
    assert s["mode_labels"][:5] == ["heave", "pitch", "1", "2", "3"]
    assert len(s["mode_labels"]) == f.size and s["mode_labels"][-1] == "22"
    assert list(s["mode_nodes"]) == ["1", "2", "3", "4", "5"]
    assert s["mode_nodes"]["3"] == [2, 5, 8, 11]  # third flexible mode: the bag nodes
    for k, nodes in s["mode_nodes"].items():
        assert len(nodes) == int(k) + 1  # flexible mode k has k + 1 zero crossings
        assert all(1 <= n <= 12 for n in nodes)
    assert s["mesh_resolved_flexible_modes"] == 5  # 11 elements resolve modes 1..5
    np.testing.assert_allclose(s["analytic_hz"], analytic_free_free_hz(tanker_hull))
    assert s["mass_orthonormality_error"] < 1e-10
    c = s["convergence"]
    assert c["reference"] == "analytic" and 11 in c["elements"]
    np.testing.assert_allclose(c["rates"], -4, atol=0.1)


def test_wet_frequencies_by_hand(capsys, tanker):
    """The tanker is uniform and its added mass too, so every wet frequency is the dry one
    times sqrt(m / (m + a33)), a33 = C_a rho pi B^2 / 4; they are the coupled plant's."""
    from flexlift.ascent.plant import coupled_plant

    s = run_json(capsys)
    m = 3200e3 / 78.02
    a33 = 1.0 * 1025.0 * np.pi * 12.0**2 / 4.0
    assert s["wet_extra_mass_per_length_kg_m"] == pytest.approx(a33, rel=1e-12)
    dry, wet = np.array(s["frequencies_hz"]), np.array(s["wet_frequencies_hz"])
    assert wet[:2].tolist() == [0.0, 0.0]
    np.testing.assert_allclose(wet[2:], dry[2:] * np.sqrt(m / (m + a33)), rtol=1e-9)
    plant = coupled_plant(tanker)
    n = plant.modes.n_modes
    np.testing.assert_allclose(wet[2:n], plant.modes.frequencies_hz[2:n], rtol=1e-9)
    # entrained water counts too
    heavier = tanker.with_changes(**{"hydro.entrained_water_t": 780.2})
    from flexlift.stages.modes import run_stage as modes_stage

    s2 = modes_stage(heavier, convergence=False).summary
    assert s2["wet_extra_mass_per_length_kg_m"] == pytest.approx(a33 + 10e3, rel=1e-12)
    assert s2["wet_frequencies_hz"][2] == pytest.approx(
        dry[2] * np.sqrt(m / (m + a33 + 10e3)), rel=1e-9)


@pytest.mark.parametrize("n", [2, 3, 5, 11, 20, 50])
def test_the_mesh_resolves_the_modes_it_lists(n, tanker_hull):
    """The rule of the modal table: flexible modes 1..N/2 of N elements lie within 1 % of
    the converged frequencies; beyond mode N the mesh is 10 % off or more."""
    from flexlift.stages.modes import mesh_resolved

    ref = compute_modes(tanker_hull.refined(400), n_modes=2 + 2 * n + 2).frequencies_hz[2:]
    modes = compute_modes(tanker_hull.refined(n))
    k = mesh_resolved(modes)
    assert k == n // 2
    err = np.abs(modes.frequencies_hz[2:] / ref[:modes.n_modes - 2] - 1)
    assert err[:k].max() < 0.01
    if modes.n_modes - 2 > n:
        assert err[n:].min() > 0.05


def test_elements_and_modes_options(capsys):
    s = run_json(capsys, "--elements", "40", "--modes", "10")
    assert s["elements"] == 40
    assert len(s["frequencies_hz"]) == 10
    s = run_json(capsys, "--elements", "5000", "--modes", "4")
    assert list(s["mode_nodes"]) == ["1", "2"]  # only the computed flexible modes
    assert s["mesh_resolved_flexible_modes"] == 2
    np.testing.assert_allclose(s["frequencies_hz"][2:], s["analytic_hz"], rtol=1e-10)


def test_human_summary_and_files(capsys, tmp_path):
    out = tmp_path / "o"
    assert main(["modes", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "flexible mode   3: dry      27.0528 Hz  wet    13.8299 Hz" in text
    assert "flexible modes 6 to 22: computed, beyond what 11 elements resolve" in text
    assert "[ok] convergence_rate_h4" in text
    for name in ("modes_shapes", "modes_frequencies", "modes_convergence"):
        png = out / "figures" / f"{name}.png"
        assert png.read_bytes()[:4] == b"\x89PNG"
    rows = list(csv.reader((out / "tables" / "modes_frequencies.csv").open()))
    assert rows[0] == ["mode", "kind", "dry [Hz]", "wet [Hz]", "analytic uniform beam, dry [Hz]",
                       "nodes (1-based)", "resolved by the mesh"]
    assert len(rows) == 1 + 24 and [r[0] for r in rows[1:4]] == ["heave", "pitch", "1"]
    assert rows[5][:2] == ["3", "flexible"] and rows[5][5] == "2 5 8 11"
    assert float(rows[5][2]) == pytest.approx(27.0528, abs=1e-4)
    assert float(rows[5][3]) == pytest.approx(13.8299, abs=1e-4)
    assert [r[6] for r in rows[1:]] == ["True"] * 7 + ["False"] * 17
    conv = list(csv.reader((out / "tables" / "modes_convergence.csv").open()))
    assert conv[0][:3] == ["elements", "flexible mode 1 [Hz]", "flexible mode 2 [Hz]"]


def test_run_stage_contract(tanker, tmp_path, capsys):
    res = run_stage(tanker, tmp_path)
    assert res.name == "modes"
    assert all(res.criteria.values()) and set(res.criteria) >= {"mass_normalised"}
    assert [f.path.name for f in res.figures] == [
        "modes_shapes.png", "modes_frequencies.png", "modes_convergence.png"]
    assert all(Path(f.path).exists() and f.caption for f in res.figures)
    assert len(res.tables) == 3
    page, every, conv = res.tables
    assert page.in_report and not page.csv and not every.in_report and conv.in_report
    assert [r[0] for r in page.rows] == ["heave", "pitch"] + [
        f"flexible mode {k}" for k in range(1, 6)]
    assert "N/2" in page.note and "115,925 kg/m" in page.note
    assert every.csv == "modes_frequencies.csv" and len(every.rows) == 24
    assert conv.csv == "modes_convergence.csv"
    cap = " ".join(f.caption for f in res.figures)
    assert "flexible mode 3" in cap and "mode 5" not in cap
    s = run_json(capsys)
    assert json.loads(json.dumps(res.summary)) == s  # summary is exactly what --json prints


def test_non_uniform_scenario_file(capsys, tmp_path):
    p = tmp_path / "hull.yaml"
    p.write_text(
        "name: stepped\nbased_on: tanker\nhull:\n  elements: 4\n  displacement_t: null\n"
        "  mass_per_length_kg_m: [30000, 40000, 50000, 40000]\n"
        "  bending_stiffness_Nm2: [2.0e12, 3.0e12, 3.0e12, 2.0e12]\n"
        "  point_masses: [{node: 1, mass_t: 50}]\n"
    )
    s = run_json(capsys, str(p))
    assert s["analytic_hz"] is None
    assert s["convergence"]["reference"] == "4096 elements"  # 64 x 16 x 4
    assert s["elements"] == 4 and len(s["frequencies_hz"]) == 10


BAD_YAML = {
    "missing": None,
    "malformed": "hull: [1, 2\n",
    "unknown key": "hull:\n  lenght_m: 10\n",
    "negative length": "hull:\n  length_m: -3\n",
    "zero EI": "hull:\n  bending_stiffness_Nm2: 0\n",
    "negative mass": "hull:\n  displacement_t: -1\n",
    "negative mass per length": (
        "hull:\n  displacement_t: null\n  mass_per_length_kg_m: -5\n"
    ),
    "zero elements": "hull:\n  elements: 0\n",
}


@pytest.mark.parametrize("case", list(BAD_YAML))
def test_bad_scenario_exits_2_with_one_line(case, tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    if BAD_YAML[case] is not None:
        path.write_text(BAD_YAML[case])
    rc = main(["modes", str(path), "--json"])
    out, err = capsys.readouterr()
    assert rc == 2
    assert out == ""
    assert err.count("\n") == 1 and "Traceback" not in err
    assert "bad.yaml" in err or "scenario" in err


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--elements", "0"], "--elements"),
        (["--elements", "ten"], "--elements"),
        (["--modes", "2"], "--modes"),
        (["--modes", "25"], "--modes"),
        (["--modes", "0"], "--modes"),
        (["--elements", "3000", "--solver", "dense"], "dense"),
    ],
)
def test_bad_options_exit_2_with_one_line(args, needle, capsys):
    with pytest.raises(SystemExit) as e:  # argparse errors exit directly
        rc = main(["modes", *args])
        raise SystemExit(rc)
    out, err = capsys.readouterr()
    assert e.value.code == 2
    assert err.count("\n") == 1 and "Traceback" not in err and needle in err


def test_out_is_a_file(tmp_path, capsys):
    f = tmp_path / "taken"
    f.write_text("x")
    assert main(["modes", "--out", str(f)]) == 2
    assert "--out" in capsys.readouterr().err


def test_entry_point_in_a_subprocess(tmp_path):
    exe = Path(sys.executable).with_name("flexlift")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-c",
                                           "import sys; from flexlift.cli import main; "
                                           "sys.exit(main())"]
    ok = subprocess.run([*cmd, "modes", "--json"], capture_output=True, text=True, timeout=120)
    assert ok.returncode == 0
    assert json.loads(ok.stdout)["elements"] == 11
    bad = subprocess.run([*cmd, "modes", str(tmp_path / "nope.yaml")], capture_output=True,
                         text=True, timeout=120)
    assert bad.returncode == 2 and bad.stdout == ""
    assert bad.stderr.count("\n") == 1 and "Traceback" not in bad.stderr


def test_hull_from_scenario_elements_override(tanker):
    assert hull_from_scenario(tanker, elements=22).n_elements == 22
