"""`flexlift run` end to end on the tanker: every file, every section, atomic on failure."""

import json
from html.parser import HTMLParser

import pytest

from flexlift.cli import main

#: the report's sections in the order of a method statement: the decision, the design basis,
#: the plan and its strength, the ascent; the research material in the appendix
EXPECTED_SECTIONS = ["decision", "design-basis", "criteria", "loads", "simulate", "appendix"]
#: the research appendix, a page of its own beside the report (appendix.html)
APPENDIX_SECTIONS = ["modes", "reduce", "fuzzy"]


class _Collect(HTMLParser):
    def __init__(self):
        super().__init__()
        self.ids, self.imgs, self.tags = set(), 0, []
        self.order, self.headings, self._heading = [], [], None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        if "id" in a:
            self.ids.add(a["id"])
            self.order.append(a["id"])
        if tag in ("h1", "h2", "h3", "h4"):
            self._heading = ""
        if tag == "img":
            assert a["src"].startswith("data:image/png;base64,"), "figures must be embedded"
            self.imgs += 1
        if tag in ("script", "link"):
            raise AssertionError("the report must be self-contained (no scripts or links)")

    def handle_data(self, data):
        if self._heading is not None:
            self._heading += data

    def handle_endtag(self, tag):
        if tag in ("h1", "h2", "h3", "h4") and self._heading is not None:
            self.headings.append(self._heading.strip())
            self._heading = None


@pytest.fixture(scope="module")
def tanker_run(tanker_run_folder):
    """The tanker's ``flexlift run`` (conftest's, shared with test_figures; read only)."""
    out, rc, _ = tanker_run_folder
    assert rc == 0
    return out


def test_run_writes_every_file(tanker_run):
    out = tanker_run
    for name in ("report.html", "appendix.html", "summary.json", "results.nc", "scenario.yaml"):
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
    where = [p.order.index(s) for s in EXPECTED_SECTIONS]
    assert where == sorted(where), "the sections are out of a method statement's order"
    doubled = sorted({h for h in p.headings if p.headings.count(h) > 1})
    assert not doubled, doubled
    assert "SPEC" not in text and "DESIGN.md" not in text  # no document outside the project
    assert "The ascent against its limits" in text
    assert 'href="appendix.html"' in text
    appendix = (tanker_run / "appendix.html").read_text()
    q = _Collect()
    q.feed(appendix)
    where = [q.order.index(s) for s in APPENDIX_SECTIONS]
    assert where == sorted(where) and q.imgs >= 5
    assert not (set(APPENDIX_SECTIONS) & p.ids)  # not repeated in the client's report
    assert p.imgs >= 8  # the plan, the strength and the ascent figures (the rest: appendix.html)
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
    from flexlift import load_scenario

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


# ----------------------------------------------------------------------------- the report
def _visible_text(html_text: str) -> str:
    import html
    import re

    body = re.sub(r"<style>.*?</style>", " ", html_text, flags=re.S)
    body = re.sub(r'src="data:[^"]*"', "", body)
    return html.unescape(re.sub(r"<[^>]+>", " ", body))


def test_long_tables_are_linked_csv_files_not_on_the_page(tanker_run):
    import csv
    import re

    text = (tanker_run / "appendix.html").read_text()  # the research tables' page
    links = re.findall(r'<a href="([^"#][^"]*)"', text)
    assert {"tables/reduce_gains.csv", "tables/fuzzy_sets.csv",
            "tables/modes_frequencies.csv"} <= set(links)
    report_links = re.findall(r'<a href="([^"#][^"]*)"', (tanker_run / "report.html").read_text())
    for href in links + report_links:  # every link points into its own output folder
        assert (tanker_run / href).is_file(), href
    headers = re.findall(r"<thead>(.*?)</thead>", text)
    assert not any("bag_1 [m/N]" in h or ">parameters<" in h for h in headers)
    gains = list(csv.reader((tanker_run / "tables/reduce_gains.csv").open()))
    assert len(gains) == 1 + 24 and len(gains[0]) == 3 + 4  # 24 modes x 4 external bags
    sets = list(csv.reader((tanker_run / "tables/fuzzy_sets.csv").open()))
    assert len(sets) == 1 + 21
    assert "24 rows × 7 columns" in _visible_text(text)
    assert "21 rows × 4 columns" in _visible_text(text)


def test_print_css_keeps_headings_with_what_follows(tanker_run):
    import re

    text = (tanker_run / "report.html").read_text()
    css = re.search(r"<style>(.*?)</style>", text, flags=re.S).group(1)
    rules: dict[str, str] = {}
    for sels, body in re.findall(r"([^{}]+)\{([^}]*)\}", css):
        for sel in sels.split(","):
            rules[sel.strip()] = rules.get(sel.strip(), "") + body
    for h in ("h1", "h2", "h3"):
        assert "break-after: avoid" in rules[h] and "page-break-after: avoid" in rules[h]
    for block in ("figure", "table", ".keep"):
        assert "break-inside: avoid" in rules[block]
    # every table title travels with its table
    for title in re.findall(r"<h3>[^<]*</h3><table>", text):
        assert f'<div class="keep">{title}' in text


def test_one_mode_numbering_and_one_time_unit(tanker_run):
    import re

    text = " ".join(_visible_text((tanker_run / page).read_text())
                    for page in ("report.html", "appendix.html"))
    numbered = re.findall(r"(\w+ )mode (\d+)", text)
    assert numbered and all(word == "flexible " for word, _ in numbered), numbered
    assert "flexible mode 3" in text and "(lift.layout_flexible_mode)" in text
    # modes listed only up to those 11 elements resolve (1..5), the rule stated
    assert "flexible mode 5" in text and "flexible mode 6" not in text and "N/2" in text
    assert "[min]" not in text and "minute" not in text
    assert re.search(r"60 s before the first separation", text)


def test_the_heap_is_frozen_and_figures_drawn_beside_during_flexlift_run(monkeypatch, tmp_path):
    """`flexlift run` (the command, not the library) freezes the objects from before the run
    for the collector (its full collections walked the imports' few hundred thousand
    objects) and draws the figures in figure processes while the stages compute; both are
    released after the stages, and :func:`run_all` alone does neither. An outer freeze is
    left to its owner."""
    import gc

    import flexlift.cli.run as cli_run
    import flexlift.stages.run as run_mod
    from flexlift.output.plots import _style

    seen = []

    def stages(*a):
        seen.append((gc.get_freeze_count(), _style._BACKGROUND.get()))
        return []

    monkeypatch.setattr(run_mod, "_run_stages", stages)
    monkeypatch.setenv(_style.PROCESSES_ENV, "2")
    assert gc.get_freeze_count() == 0
    run_mod.run_all(None, tmp_path)
    assert seen.pop() == (0, None)
    assert main(["run", "--quiet", "--out", str(tmp_path / "out")]) == 0
    frozen, pool = seen.pop()
    assert frozen > 1000 and isinstance(pool, _style._Background)
    assert gc.get_freeze_count() == 0 and _style._BACKGROUND.get() is None
    assert cli_run.run_all is run_mod.run_all
    with pytest.raises(RuntimeError):
        with run_mod.heap_frozen():
            raise RuntimeError
    assert gc.get_freeze_count() == 0
    gc.freeze()
    try:
        frozen = gc.get_freeze_count()
        with run_mod.heap_frozen():
            pass
        assert gc.get_freeze_count() == frozen  # not released by the inner block
    finally:
        gc.unfreeze()


def test_summary_leads_with_the_decision(tanker_run):
    summary = json.loads((tanker_run / "summary.json").read_text())
    assert summary["outcome"] == "safe"
    assert summary["outcomes"] == {"decentralized": "safe", "coordinated": "safe"}
