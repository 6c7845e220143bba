"""The README's Quick start, its links and picture, and the Python API guide's example stay
true. (The scenario reference is generated from the schema and checked in tests/test_docs.py.)"""

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()
API_GUIDE = (ROOT / "docs" / "guide" / "python-api.md").read_text()


def _section(text: str, title: str) -> str:
    m = re.search(rf"^## {title}\n(.*?)(?=^## |\Z)", text, flags=re.S | re.M)
    assert m, f"no '## {title}' section"
    return m.group(1)


def _code_blocks(text: str, lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", text, flags=re.S)


def test_quick_start_has_exactly_the_two_commands():
    blocks = _code_blocks(_section(README, "Quick start"), "bash")
    assert len(blocks) == 1
    commands = [ln.split("#")[0].strip() for ln in blocks[0].splitlines() if ln.strip()]
    assert commands == ["./dev run", "./dev test"]
    dev = (ROOT / "dev").read_text()
    assert 'exec "$venv/bin/flexlift" run' in dev  # `./dev run` is `flexlift run`
    ci = (ROOT / ".ci" / "run").read_text()
    assert "\n./dev test 2>&1 | tee" in ci   # CI runs the README's test command first
    # and then the README's run command on a fresh clone with the oldest Python, env -i
    assert '"$fresh/flexlift/dev" run' in ci and "env -i PATH=" in ci


def test_readme_is_short_with_one_picture_and_links_that_exist():
    assert len(README.splitlines()) <= 80, "the README is the front page; the guide is docs/"
    pictures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", README)
    assert len(pictures) == 1 and (ROOT / pictures[0]).is_file()
    links = [t for t in re.findall(r"(?<!!)\[[^\]]*\]\(([^)#]+)(?:#[^)]*)?\)", README)
             if "://" not in t]
    assert any(t.startswith("docs/theory/") for t in links)
    missing = [t for t in links if not (ROOT / t).exists()]
    assert not missing, f"README links to missing files: {missing}"


def test_python_api_example_runs(capsys):
    blocks = _code_blocks(API_GUIDE, "python")
    assert blocks, "the API guide has a python example"
    assert len(blocks[0].strip().splitlines()) <= 14
    exec(compile(blocks[0], "docs/guide/python-api.md", "exec"), {})
    printed = capsys.readouterr().out.split()
    assert printed[0] == "unsorted_mdc"
    assert abs(float(printed[1])) < 0.01  # % gain error of the 4-state mdc model


def test_getting_started_wreck_is_valid_and_sized_as_the_page_says(tmp_path):
    from flexlift import load_scenario
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    page = (ROOT / "docs" / "getting-started.md").read_text()
    blocks = _code_blocks(page, "yaml")
    assert len(blocks) == 1
    path = tmp_path / "my-wreck.yaml"
    path.write_text(blocks[0])
    scenario = load_scenario(path)
    plan = plan_lift(scenario, hull_from_scenario(scenario))
    lifts_t = {round(b.lift / (scenario.environment.gravity_m_s2 * 1000.0)) for b in plan.bags}
    assert (len(plan.bags), lifts_t) == (11, {32})
    assert "eleven 35 t bags, modelled at 32 t each" in " ".join(page.split())
    assert "path/to/flexlift/dev run my-wreck.yaml --out results" in page
