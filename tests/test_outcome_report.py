"""Issue 23: the report's verdict says what happened (the outcome of each control mode) and
every red mark says why, a failed numerical check of the analysis included (a user's .fis
whose interpolated surface is not the file's)."""

from __future__ import annotations

import html
import re
from pathlib import Path

import pytest

from flexlift import load_scenario
from flexlift.output.checktext import EXPLAIN, explain_check
from flexlift.output.report import render_report
from flexlift.output.stage import StageOutput
from flexlift.stages import fuzzy, simulate

FPEAKS = Path(__file__).parent / "data" / "fis" / "matlab" / "fpeaks.fis"
QUICK = {"control.target_height_m": 40.0, "seabed.breakout_time_s": 100.0,
         "simulation.hold_time_s": 60.0, "simulation.duration_s": 1500.0}


def _verdict(page: str) -> str:
    box = re.search(r'<div class="verdict (\w+)">(.*?)</div>', page, re.S)
    assert box, page[:2000]
    text = html.unescape(re.sub(r"<[^>]+>", " ", box.group(2)))
    return box.group(1) + ": " + re.sub(r"\s+([:;,.])", r"\1", re.sub(r"\s+", " ", text)).strip()


@pytest.fixture(scope="module")
def peaks():
    """The fuzzy stage on MATLAB's fpeaks.fis: its 81 x 81 table is 0.036 off exact inference."""
    return fuzzy.run_stage(load_scenario("tanker"), None, fis_file=FPEAKS)


def _safe_stage() -> StageOutput:
    return StageOutput("simulate:coordinated",
                       {"outcome": "safe", "outcome_cause": "every limit held", "reasons": {}},
                       criteria={"pitch": True, "reached_target": True})


def test_a_failed_numerical_check_says_what_it_means_its_number_and_what_to_do(peaks):
    assert peaks.criteria == {"surface_interpolation_error_below_0.01": False}
    err = peaks.summary["surface"]["max_error"]
    page = render_report(load_scenario("tanker"), [peaks, _safe_stage()])
    v = _verdict(page)
    assert v.startswith("bad: Review needed: every lift criterion passed, but 1 numerical "
                        "check(s) of the analysis failed")
    assert "numerical check fuzzy: surface_interpolation_error_below_0.01 failed" in v
    assert f"differs from exact inference by up to {err:.3g} in u" in v
    assert "fpeaks.fis" in v and "81 x 81" in v
    assert "Widen the narrowest sets" in v


def test_every_check_a_stage_sets_has_its_own_sentence():
    """Each criterion a stage sets (found in its source) is explained, with its number."""
    root = Path(fuzzy.__file__).parent
    found = set()
    for f in root.glob("*.py"):
        for m in re.finditer(r'criteria\["([\w.]+)"\]|"([\w.]+)": [^,\n]*[<>]', f.read_text()):
            name = m.group(1) or m.group(2)
            if f.stem != "simulate" and not name.startswith("max_"):
                found.add((f.stem, name))
    assert found <= set(EXPLAIN), found - set(EXPLAIN)
    assert "0.85" in explain_check("loads", "static_stress_within_allowable",
                                   {"static_stress": {"max_utilisation": 0.85}})
    assert "grep -rn 'new_check'" in explain_check("modes", "new_check", {})


def test_an_incomplete_run_is_not_called_unsafe_in_the_verdict(peaks):
    sc = load_scenario("tanker").with_changes(**QUICK)
    stage = simulate.run_stage(sc, None, control="coordinated", duration=100.0)
    assert stage.summary["outcome"] == "incomplete"
    v = _verdict(render_report(sc, [stage]))
    assert v.startswith("partial: Incomplete: every limit held, but the run ended before the "
                        "target was held: no lift was unsafe")
    assert "coordinated control: incomplete" in v
    assert "Unsafe" not in v and "unsafe." not in v
    assert stage.summary["outcome_cause"] in v
    # with the failed check too: still incomplete, and the check explained
    v = _verdict(render_report(sc, [peaks, stage]))
    assert v.startswith("partial: Incomplete")
    assert "surface_interpolation_error_below_0.01 failed: the supervisor" in v


def test_the_cli_says_the_outcome_and_how_much_longer(capsys):
    import json

    from flexlift.cli import main

    assert main(["simulate", "--control", "coordinated", "--duration", "200"]) == 0
    text = capsys.readouterr().out
    assert "\noutcome: incomplete\n" in text
    assert "  reached_target: never separated in the 200 s run: " in text
    assert "every limit held, but the run ended at 200 s, about " in text
    assert main(["simulate", "--control", "coordinated", "--duration", "200", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["outcome"] == "incomplete" and out["needs_more_s"] > 3000.0
    assert out["outcome_cause"] == out["reasons"]["reached_target"]
