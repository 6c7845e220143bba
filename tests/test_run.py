"""`flexlift run` end to end on the tanker: every file, every section, atomic on failure."""

import json
from html.parser import HTMLParser

import pytest

from flexlift.cli import main

EXPECTED_SECTIONS = ["particulars", "criteria", "modes", "loads", "reduce", "fuzzy", "simulate"]


class _Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.ids, self.imgs, self.tags = set(), 0, []

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "img":
            assert a["src"].startswith("data:image/png;base64,"), "figures must be embedded"
            self.imgs += 1
        if tag in ("script", "link"):
            raise AssertionError("the report must be self-contained (no scripts or links)")


@pytest.fixture(scope="module")
def tanker_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "tanker"
    rc = main(["run", "--out", str(out), "--quiet"])
    assert rc == 0
    return out


def test_run_writes_every_file(tanker_run):
    out = tanker_run
    for name in ("report.html", "summary.json", "results.nc", "scenario.yaml"):
        assert (out / name).is_file(), name
    assert list((out / "figures").glob("*.png")), "figures/*.png"
    assert list((out / "tables").glob("*.csv")), "tables/*.csv"
    assert not list(out.parent.glob(".tanker.partial-*")), "no temporary folder left behind"


def test_report_parses_and_has_every_section(tanker_run):
    text = (tanker_run / "report.html").read_text()
    p = _Collect()
    p.feed(text)
    for section in EXPECTED_SECTIONS:
        assert section in p.ids, section
    assert p.imgs >= 10
    assert "PASS" in text or "FAIL" in text
    assert "checksum" in text


def test_summary_matches_the_stages_json(tanker_run, capsys):
    summary = json.loads((tanker_run / "summary.json").read_text())
    for stage in ("modes", "loads", "reduce"):
        capsys.readouterr()
        assert main([stage, "--json"]) == 0
        own = json.loads(capsys.readouterr().out)
        assert summary["stages"][stage] == own, stage
    capsys.readouterr()
    assert main(["fuzzy", "--eval", "0.2,-0.1", "--json"]) == 0
    assert set(summary["stages"]["simulate"]) == {"decentralized", "coordinated"}
    for mode, sim in summary["stages"]["simulate"].items():
        assert sim["control"] == mode
        assert set(sim["criteria"]) >= {"ascent_velocity", "pitch", "reached_target"}


def test_scenario_copy_repeats_the_run(tanker_run, tanker):
    from flexlift.scenario import load_scenario

    again = load_scenario(tanker_run / "scenario.yaml")
    assert again.checksum() == tanker.checksum()
    summary = json.loads((tanker_run / "summary.json").read_text())
    assert summary["scenario_checksum"] == tanker.checksum()


def test_interrupted_run_leaves_previous_output_intact(tmp_path, monkeypatch):
    out = tmp_path / "tanker"
    assert main(["run", "--out", str(out), "--quiet", "--stages", "modes"]) == 0
    previous = (out / "report.html").read_text()
    import flexlift.stages.loads as loads_cli

    def boom(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(loads_cli, "run_stage", boom)
    rc = main(["run", "--out", str(out), "--quiet", "--stages", "modes,loads"])
    assert rc == 130
    assert (out / "report.html").read_text() == previous
    assert sorted(p.name for p in tmp_path.iterdir()) == ["tanker"]


def test_bad_input_end_to_end_leaves_output_untouched(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("keep")
    bad = tmp_path / "bad.yaml"
    bad.write_text("hull:\n  elements: 11\n  lenght_m: 3\n")
    rc = main(["run", str(bad), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 2
    assert len(err.strip().splitlines()) == 1 and "lenght_m" in err and "Traceback" not in err
    assert (out / "keep.txt").read_text() == "keep"
    rc = main(["run", "--stages", "modes,nonsense", "--out", str(out)])
    assert rc == 2


def test_stage_subset(tmp_path):
    out = tmp_path / "o"
    assert main(["run", "--out", str(out), "--quiet", "--stages", "modes,loads"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["stages"]) == {"modes", "loads"}
    assert (out / "report.html").is_file()
