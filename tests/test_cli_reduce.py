"""``flexlift reduce``: JSON summary, output files, and one-line errors with exit code 2."""

import csv as _csv
import json

import pytest

from flexlift.cli import main
from flexlift.dynamics.reduce import METHODS
from flexlift.stages.reduce import run_stage


def _json(capsys, argv):
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert out.count("\n") == 1
    return json.loads(out)


def test_json_every_external_bag(capsys):
    s = _json(capsys, ["reduce", "--json"])
    assert s["states_full"] == 48 and s["states_reduced"] == 4 and s["order"] == 2
    labels = ["heave", "pitch"] + [str(k) for k in range(1, 23)]
    assert s["mode_labels"] == labels and sorted(s["gain_order"]) == sorted(labels)
    assert set(s["methods"]) == set(METHODS)
    for m in s["methods"].values():
        assert {"dc_error_pct", "peak_error_pct"} <= set(m)
        assert m["modes"] == ["heave", "pitch"]
    assert list(s["bags"]) == ["bag_1", "bag_2", "bag_3", "bag_4"]
    # the top level describes the first bag
    assert s["bag"] == "bag_1" and s["methods"] == s["bags"]["bag_1"]["methods"]
    assert s["omega_lo_hz"] == pytest.approx(0.1 * 5.003, rel=1e-3)
    for b in s["bags"].values():
        assert b["most_accurate"] == "unsorted_mdc"
        assert b["methods"]["unsorted_mdc"]["flexible_static_gain_m_per_N"] == pytest.approx(
            b["flexible_static_gain_m_per_N"], rel=1e-12)
        assert "mdc" in b["conclusion"] and "exactly" in b["conclusion"]
    # the hull is symmetric and so are the bag positions: bag_1 mirrors bag_4
    a, d = s["bags"]["bag_1"]["methods"], s["bags"]["bag_4"]["methods"]
    for m in METHODS:
        assert a[m]["dc_error_pct"] == pytest.approx(d[m]["dc_error_pct"], rel=1e-6)


def test_json_one_bag_higher_order(capsys):
    s = _json(capsys, ["reduce", "--bag", "bag_2", "--order", "5", "--json"])
    assert list(s["bags"]) == ["bag_2"] and s["bag"] == "bag_2"
    assert s["states_reduced"] == 10
    assert s["kept_modes"]["unsorted"] == ["heave", "pitch", "1", "2", "3"]
    # bag_2 sits on a node of flexible mode 3 (lift.layout_flexible_mode): no gain there
    assert "3" not in s["kept_modes"]["sorted"] and "4" in s["kept_modes"]["sorted"]
    assert s["gain_order"][:4] == ["heave", "pitch", "1", "2"]
    assert s["bags"]["bag_2"]["methods"]["sorted_mdc"]["modes"] == s["kept_modes"]["sorted"]


def test_internal_bag_and_other_output(capsys):
    s = _json(capsys, ["reduce", "--bag", "bag_6", "--output", "w_node_6", "--json"])
    assert s["input"] == "f_bag_6" and s["output"] == "w_node_6"


def test_run_stage_writes_figures_and_tables(tmp_path, tanker):
    res = run_stage(tanker, tmp_path, bag="bag_1", order=3)
    assert res.name == "reduce" and res.criteria == {"mdc_static_gain_exact": True}
    names = sorted(f.path.name for f in res.figures)
    assert names == ["reduce_bode.png", "reduce_gains.png", "reduce_time.png"]
    for f in res.figures:
        assert f.path.stat().st_size > 10_000 and f.caption
    csv = (tmp_path / "tables" / "reduce_comparison.csv").read_text().splitlines()
    assert len(csv) == 1 + len(METHODS)
    assert "heave, pitch; flexible 1" in csv[1] and csv[1].startswith("bag_1,")
    worst = (tmp_path / "tables" / "reduce_worst.csv").read_text().splitlines()
    assert len(worst) == 1 + len(METHODS)
    gains = list(_csv.reader((tmp_path / "tables" / "reduce_gains.csv").open()))
    assert gains[0] == ["mode", "kind", "frequency [Hz]", "bag_1 [m/N]"]
    assert len(gains) == 25 and [r[0] for r in gains[1:4]] == ["heave", "pitch", "1"]
    assert [r[1] for r in gains[1:4]] == ["rigid", "rigid", "flexible"]
    assert [float(r[3]) for r in gains[1:]] == pytest.approx(res.summary["gains_m_per_N"])
    worst, comparison, per_mode = res.tables
    assert worst.in_report and worst.csv == "reduce_worst.csv"
    assert not comparison.in_report and comparison.csv == "reduce_comparison.csv"
    assert not per_mode.in_report and per_mode.csv == "reduce_gains.csv"
    assert "ω_lo" in res.tables[0].note and "most accurate" in res.summary["conclusion"]


@pytest.mark.parametrize(
    "argv, needle",
    [
        (["--order", "1"], "order: got 1"),
        (["--order", "25"], "order: got 25"),
        (["--order", "0"], "--order must be at least 1"),
        (["--bag", "bag_9"], "bag: got 'bag_9'"),
        (["--output", "x_node_1"], "output: got 'x_node_1'"),
        (["--output", "w_bag_12"], "known bags"),
    ],
)
def test_bad_input_one_line_exit_2(capsys, argv, needle):
    try:
        code = main(["reduce", *argv, "--json"])
    except SystemExit as exc:  # argparse errors, if the dispatcher lets them through
        code = exc.code
    assert code == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    err = captured.err
    assert err.count("\n") == 1 and needle in err and "Traceback" not in err


def test_entry_point_subprocess():
    import subprocess
    import sys
    from pathlib import Path

    exe = Path(sys.executable).parent / "flexlift"  # the installed console script
    r = subprocess.run([str(exe), "reduce", "--order", "30"], capture_output=True, text=True,
                       timeout=120)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
