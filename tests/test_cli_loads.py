"""``flexlift loads``: JSON summary, files, warnings and the error paths."""

from __future__ import annotations

import csv
import json

import pytest
import yaml

from flexlift import constants as C
from flexlift.cli import main
from flexlift.stages.loads import run_stage

KEYS = {
    "wet_weight_t",
    "required_lift_t",
    "bag_count",
    "bag_lift_t",
    "external_bag_nodes",
    "internal_bag_span_m",
    "max_shear_MN",
    "max_moment_MNm",
    "closing_shear_MN",
    "closing_moment_MNm",
}


def _scenario(tmp_path, lift: dict, name: str = "case") -> str:
    path = tmp_path / f"{name}.yaml"
    path.write_text(yaml.safe_dump({"name": name, "lift": lift}))
    return str(path)


@pytest.fixture(scope="module")
def tanker_json():
    import io
    import sys

    buf, old = io.StringIO(), sys.stdout
    sys.stdout = buf
    try:
        code = main(["loads", "--json"])
    finally:
        sys.stdout = old
    assert code == 0
    lines = buf.getvalue().strip().splitlines()
    assert len(lines) == 1  # one JSON object
    return json.loads(lines[0])


def test_json_tanker(tanker_json):
    s = tanker_json
    assert KEYS <= set(s)
    assert s["wet_weight_t"] == pytest.approx(2782.17, abs=0.01)
    assert s["required_lift_t"] == pytest.approx(3616.82, abs=0.01)
    assert s["bag_count"] == 7 and s["bag_lift_t"] == 517.0
    assert s["external_bag_nodes"] == [2, 5, 8, 11]
    assert s["internal_bag_span_m"] == pytest.approx([14.19, 63.83], abs=0.01)
    assert [b["name"] for b in s["bags"]] == [f"bag_{k}" for k in range(1, 8)]
    assert [b["node"] for b in s["bags"][:4]] == [2, 5, 8, 11]
    assert s["warnings"] == [] and s["shortfall_t"] == 0.0
    for key in ("max_shear_MN", "max_moment_MNm"):
        assert set(s[key]) == {"value", "x_m", "node", "case"}
    # the paper's still-water table, as the paper computes it (not closed), pinned as before
    p = s["paper_still_water"]
    assert p["max_moment_MNm"]["node"] == 5
    assert p["max_moment_MNm"]["x_m"] == pytest.approx(28.37, abs=0.01)
    assert p["max_moment_MNm"]["value"] == pytest.approx(-44.27, abs=0.01)
    assert abs(p["max_shear_MN"]["value"]) == pytest.approx(3.505, abs=0.001)
    assert p["max_shear_MN"]["node"] == 8
    # closing values = the excess of the bags over 1.3 W', at midship by symmetry
    excess_MN = (s["total_lift_t"] - s["required_lift_t"]) * C.TONNE * 9.81 / 1e6
    assert p["closing_shear_MN"] == pytest.approx(excess_MN, rel=1e-6) == pytest.approx(0.0214, abs=1e-4)
    assert p["closing_moment_MNm"] == pytest.approx(excess_MN * 78.02 / 2, rel=1e-6)
    assert p["closing_moment_MNm"] == pytest.approx(0.836, abs=1e-3)
    # the closed design cases: the full-lift envelope is the paper's case closed (44.4 MN m)
    d = s["design_cases"]
    assert list(d) == ["holding", "breakout", "full_lift"]
    assert d["full_lift"]["max_moment_MNm"]["value"] == pytest.approx(-44.385, abs=1e-3)
    assert d["full_lift"]["max_moment_MNm"]["node"] == 5
    assert d["full_lift"]["scale_factor"] == pytest.approx(
        (s["required_lift_t"] - 3 * 517.0) / (4 * 517.0), rel=1e-9)
    assert d["breakout"]["max_moment_MNm"]["value"] == pytest.approx(-44.393, abs=1e-3)
    assert d["holding"]["max_moment_MNm"]["value"] == pytest.approx(-45.705, abs=1e-3)
    assert d["holding"]["max_moment_MNm"]["node"] == 8
    assert d["holding"]["scale_factor"] == pytest.approx(1.0, rel=1e-12)
    assert s["max_moment_MNm"]["case"] == "holding"
    assert s["max_moment_MNm"]["value"] == pytest.approx(-45.705, abs=1e-3)
    for c in d.values():
        peak = abs(c["max_moment_MNm"]["value"])
        assert abs(c["residual_moment_MNm"]) <= 1e-6 * peak
        assert abs(c["residual_shear_MN"]) <= 1e-6 * abs(c["max_shear_MN"]["value"])
    assert abs(s["closing_moment_MNm"]) <= 1e-6 * 45.7


def test_human_output_and_files(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["loads", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "7 bags of 517 t" in text and "max |M| = 44.271 MN m at node 5" in text
    assert "peak |M| = 45.705 MN m (holding case)" in text
    for f in ("figures/loads_diagram.png", "figures/loads_shear_moment.png"):
        assert (out / f).stat().st_size > 10_000
    rows = list(csv.reader((out / "tables" / "loads_bags.csv").open()))
    assert rows[0][0] == "bag" and len(rows) == 8
    rows = list(csv.reader((out / "tables" / "loads_paper_still_water.csv").open()))
    assert rows[1][0] == "V at the largest |V| (signed)"  # the number is signed, not |V|
    assert float(rows[1][1]) == pytest.approx(3.505, abs=0.001)
    rows = list(csv.reader((out / "tables" / "loads_strength.csv").open()))
    assert rows[0] == ["quantity", "unit", "holding", "breakout", "full-lift"]
    assert rows[1][0] == "lift scale factor" and float(rows[1][4]) == pytest.approx(0.9989, abs=1e-4)


def test_run_stage_contract(tmp_path, tanker):
    res = run_stage(tanker, tmp_path)
    assert res.name == "loads"
    assert [f.path.name for f in res.figures] == ["loads_diagram.png", "loads_shear_moment.png"]
    assert all(f.path.is_file() and f.caption for f in res.figures)
    assert [t.title.split(" (")[0] for t in res.tables] == [
        "Lift bags", "Longitudinal strength", "Checks before the run",
        "Appendix: the paper's still-water case"]
    assert len(res.tables[0].rows) == 7
    assert res.warnings == []
    # without a folder: the same summary, nothing written
    res2 = run_stage(tanker, None)
    assert res2.figures == [] and res2.summary == res.summary


def test_shortfall_is_a_warning_not_an_error(tmp_path, capsys):
    path = _scenario(tmp_path, {"bag_lift_t": 400.0})
    assert main(["loads", path, "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["shortfall_t"] == pytest.approx(816.8, abs=0.1)
    assert len(s["warnings"]) == 1 and "817 t short" in s["warnings"][0]
    # the bags at full lift cannot carry W' + H0: the full-lift case scales them up to it
    full = s["design_cases"]["full_lift"]
    assert full["scale_factor"] == pytest.approx((s["required_lift_t"] - 3 * 400) / (4 * 400))
    assert full["lift_t"] == pytest.approx(s["required_lift_t"])
    assert main(["loads", path]) == 0
    assert "WARNING: lift shortfall" in capsys.readouterr().out


def test_explicit_layout_json(tmp_path, capsys):
    bags = [
        {"name": "stern", "kind": "external", "x_m": 5.0},
        {"name": "bow", "kind": "external", "node": 11},
        {"name": "tank", "kind": "internal", "span_m": [20.0, 60.0], "lift_t": 1800.0},
    ]
    assert main(["loads", _scenario(tmp_path, {"bags": bags, "bag_lift_t": 910.0}), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["bag_count"] == 3 and s["layout"].startswith("explicit")
    assert s["external_bag_nodes"] == [2, 11]  # nearest nodes; x_m = 5.0 is off-node
    assert s["bags"][0]["node"] is None and s["bags"][0]["x_m"] == 5.0
    assert s["internal_bag_span_m"] == [20.0, 60.0]
    assert s["total_lift_t"] == pytest.approx(910 + 910 + 1800)


@pytest.mark.parametrize(
    "lift, match",
    [
        ({"bags": [{"name": "b", "kind": "external", "x_m": 90.0}]}, "lift.bags.b.x_m"),
        ({"bags": [{"name": "b", "kind": "internal", "span_m": [60.0, 80.0]}]}, "span_m"),
        (
            {
                "bags": [
                    {"name": "p", "kind": "internal", "span_m": [10.0, 30.0]},
                    {"name": "q", "kind": "internal", "span_m": [20.0, 40.0]},
                ]
            },
            "must not overlap",
        ),
        ({"bag_lift_t": 0}, "bag_lift_t"),
        ({"bags": [{"name": "b", "kind": "external", "node": 3, "lift_t": -5}]}, "lift_t"),
        ({"layout": "mode_nodes", "layout_flexible_mode": 40}, "lift.layout_flexible_mode"),
    ],
)
def test_bad_input_exit_2_one_line(tmp_path, capsys, lift, match):
    assert main(["loads", _scenario(tmp_path, lift), "--json"]) == 2
    cap = capsys.readouterr()
    assert cap.out == ""
    lines = cap.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in cap.err
    assert lines[0].startswith("flexlift loads: error:") and match in lines[0]


def test_missing_scenario_and_bad_out(tmp_path, capsys):
    assert main(["loads", str(tmp_path / "nope.yaml")]) == 2
    assert "no such file" in capsys.readouterr().err
    f = tmp_path / "afile"
    f.write_text("x")
    assert main(["loads", "--out", str(f)]) == 2
    assert "--out" in capsys.readouterr().err


def test_report_puts_the_papers_table_in_the_appendix(tanker):
    """The loads section shows the closed design cases; the paper's still-water table is in
    the appendix at the end, labelled as the paper's, with its closing values."""
    from pathlib import Path

    from flexlift import load_scenario
    from flexlift.output.report import render_report

    html = render_report(tanker, [run_stage(tanker)])
    loads, appendix = html.index('id="loads"'), html.index('id="appendix"')
    assert loads < appendix
    design = html.index("Longitudinal strength (design cases, each closed)")
    paper = html.index("Appendix: the paper&#x27;s still-water case")
    assert loads < design < appendix < paper
    assert "<td>0.8361</td>" in html[paper:] and "<td>-44.3</td>" in html[paper:]
    assert "<td>0.02143</td>" in html[paper:]
    trawler = load_scenario(Path(__file__).parent / "data" / "trawler.yaml")
    assert "still-water case" not in render_report(trawler, [run_stage(trawler)])  # no paper table
