"""The documentation site (mkdocs.yml, docs/) builds with warnings as errors, its API examples
run, its scenario reference lists every schema key with its range, and every docs page and
anchor cited in the code exists."""

import doctest
import html
import importlib
import math
import os
import re
import subprocess
import sys
import types
import typing
from pathlib import Path

import annotated_types as at
import pytest
import yaml
from pydantic import BaseModel

from flexlift.scenario import Scenario

pytest.importorskip("mkdocs", reason="mkdocs is not installed: the docs packages come with "
                    "requirements/test.lock (./dev test installs it)")
pytest.importorskip("mkdocstrings", reason="mkdocstrings is not installed (requirements/test.lock)")
pytest.importorskip("material", reason="mkdocs-material is not installed (requirements/test.lock)")

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
#: a citation of a docs page, with an optional anchor: docs/theory/gas.md#boyle
CITATION = re.compile(r"docs/((?:[\w.-]+/)*[\w.-]+\.md)(?:#([\w-]+))?")
BUILD_TIMEOUT_S = 300


@pytest.fixture(scope="module")
def site(tmp_path_factory) -> Path:
    """The site built by ``mkdocs build --strict`` into a temporary folder."""
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1",
               PYTHONPATH=os.pathsep.join(filter(None, [str(ROOT / "src"),
                                                        os.environ.get("PYTHONPATH")])))
    proc = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict",
                           "-f", str(ROOT / "mkdocs.yml"), "-d", str(out)],
                          capture_output=True, text=True, timeout=BUILD_TIMEOUT_S, env=env,
                          cwd=ROOT)
    assert proc.returncode == 0, f"mkdocs build --strict failed:\n{proc.stderr[-4000:]}"
    return out


def _page(site: Path, page: str) -> str:
    """The built HTML of ``page`` (a path under docs/ such as ``theory/gas.md``)."""
    stem = page[:-3]
    target = site / (stem[: -len("index")] if stem.endswith("index") else stem) / "index.html"
    assert target.exists(), f"docs/{page} was not built"
    return target.read_text(encoding="utf-8")


def test_site_builds_strict_with_every_page_in_the_nav(site):
    text = (ROOT / "mkdocs.yml").read_text()
    pages = sorted(p.relative_to(DOCS).as_posix() for p in DOCS.rglob("*.md")
                   if not p.relative_to(DOCS).as_posix().startswith("_"))
    missing = [p for p in pages if f": {p}\n" not in text]
    assert not missing, f"pages not in mkdocs.yml's nav: {missing}"
    assert "\ndocs_dir: docs\n" in text and "\nstrict: true\n" in text
    for page in pages:
        _page(site, page)


# --------------------------------------------------------------------------- API examples
def _api_objects() -> list[str]:
    """The objects the API page documents (its ``::: dotted.name`` lines)."""
    return re.findall(r"^::: ([\w.]+)\s*$", (DOCS / "reference" / "api.md").read_text(), re.M)


def _resolve(dotted: str):
    module, _, name = dotted.rpartition(".")
    return getattr(importlib.import_module(module), name)


def test_api_page_documents_the_entry_points():
    names = _api_objects()
    for entry in ("load_scenario", "simulate", "run_sweep", "plan_lift", "compute_modes"):
        assert any(n.endswith("." + entry) for n in names), f"the API page lacks {entry}"


@pytest.mark.parametrize("dotted", _api_objects())
def test_api_examples_run_as_doctests(dotted):
    obj = _resolve(dotted)
    doc = obj.__doc__ or ""
    assert "Parameters\n" in doc and "Returns\n" in doc, \
        f"{dotted}: numpydoc Parameters / Returns sections"
    tests = [t for t in doctest.DocTestFinder(recurse=False).find(obj, dotted) if t.examples]
    assert tests, f"{dotted} has no example"
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for t in tests:
        runner.run(t)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{dotted}: {result.failed} of {result.attempted} examples failed"


# --------------------------------------------------------------------------- scenario keys
def _bounds(annotation, metadata=()) -> list:
    """Every numeric bound (ge, gt, le, lt) in an annotation, through Annotated and unions."""
    found = []
    for m in metadata:
        for c in getattr(m, "metadata", None) or [m]:
            if isinstance(c, at.Ge | at.Gt | at.Le | at.Lt):
                found.append(c)
    if typing.get_origin(annotation) is typing.Annotated:
        base, *meta = typing.get_args(annotation)
        return found + _bounds(base, meta)
    if typing.get_origin(annotation) in (typing.Union, types.UnionType, list, tuple):
        for a in typing.get_args(annotation):
            if not (isinstance(a, type) and issubclass(a, BaseModel)):
                found += _bounds(a)
    return found


def _choices(annotation) -> list:
    if typing.get_origin(annotation) is typing.Literal:
        return list(typing.get_args(annotation))
    out = []
    for a in typing.get_args(annotation):
        out += _choices(a)
    return out


def _models(annotation) -> list[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    out = []
    for a in typing.get_args(annotation):
        out += _models(a)
    return out


def _is_list(annotation) -> bool:
    origin = typing.get_origin(annotation)
    if origin is list:
        return True
    if origin is typing.Annotated:
        return _is_list(typing.get_args(annotation)[0])
    if origin in (typing.Union, types.UnionType):
        return any(_is_list(a) for a in typing.get_args(annotation))
    return False


def _keys(model: type[BaseModel], prefix: str = ""):
    """(dotted key, field) of every value a scenario file can hold; ``a[].b`` for the items
    of a list."""
    for name, field in model.model_fields.items():
        key, ann = prefix + name, field.annotation
        subs = _models(ann)
        if not subs:
            yield key, field
            continue
        is_list = _is_list(ann)
        if is_list:
            yield key, field
        for sub in subs:
            yield from ((k, f) for k, f in _keys(sub, key + ("[]." if is_list else "."))
                        if not (k.endswith(".kind") and is_list and len(subs) > 1))


def _rows(page_html: str) -> dict[str, list[str]]:
    rows = {}
    for tr in re.findall(r"<tr>(.*?)</tr>", page_html, re.S):
        cells = [html.unescape(re.sub(r"<[^>]+>", "", c)).strip()
                 for c in re.findall(r"<td[^>]*>(.*?)</td>", tr, re.S)]
        if cells:
            rows[cells[0]] = cells
    return rows


def _numbers(text: str) -> list[float]:
    text = text.replace("2⁶³−1", str(2**63 - 1))
    return [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?(?:e-?\d+)?", text)]


def test_scenario_reference_lists_every_key_with_its_range(site):
    rows = _rows(_page(site, "reference/scenario.md"))
    keys = list(dict(_keys(Scenario)).items())
    assert len(keys) > 130  # 143 when written
    problems = []
    for key, field in keys:
        row = rows.get(key)
        if row is None:
            problems.append(f"{key}: no row")
            continue
        allowed = row[2]
        numbers = _numbers(allowed)
        for b in _bounds(field.annotation, field.metadata):
            value = float(next(getattr(b, a) for a in ("ge", "gt", "le", "lt") if hasattr(b, a)))
            if not any(math.isclose(value, n, rel_tol=1e-9, abs_tol=1e-12) for n in numbers):
                problems.append(f"{key}: bound {value} not in '{allowed}'")
        for choice in _choices(field.annotation):
            if f"{choice}" not in allowed:
                problems.append(f"{key}: choice {choice} not in '{allowed}'")
        if not row[3]:
            problems.append(f"{key}: no meaning")
    assert not problems, "\n".join(problems)


def test_scenario_reference_lists_the_catalogues_models(site):
    from flexlift.scenario import catalogue

    html = _page(site, "reference/scenario.md")
    models = catalogue.builtin()
    assert len(models) > 10
    for name in models:
        assert f"<code>{name}</code>" in html, f"scenario reference lacks catalogue model {name}"
    assert "paper_cylinder_565t" in models


def test_sweep_reference_lists_every_spec_key_and_distribution(site):
    from flexlift.sweep import distributions, spec

    rows = _rows(_page(site, "reference/sweep.md"))
    for key in spec.TOP_KEYS:
        assert key in rows, f"sweep reference lacks {key}"
    for key in spec.MC_KEYS:
        assert f"monte_carlo.{key}" in rows, f"sweep reference lacks monte_carlo.{key}"
    for kind, (need, opt) in distributions.PARAMS.items():
        assert kind in rows and all(p in rows[kind][1] for p in need), kind
        assert all(p in rows[kind][2] for p in opt), kind


# --------------------------------------------------------------------------- citations
def _cited() -> list[tuple[str, str, str | None]]:
    """(file, page, anchor) of every docs/...md citation in src/, tests/ and
    docs/citations.yaml's targets."""
    out = []
    for folder in ("src", "tests"):
        for path in sorted((ROOT / folder).rglob("*")):
            if path.suffix not in (".py", ".yaml", ".md") or path.name == Path(__file__).name:
                continue
            for m in CITATION.finditer(path.read_text(encoding="utf-8", errors="replace")):
                out.append((str(path.relative_to(ROOT)), m.group(1), m.group(2)))
    mapping = yaml.safe_load((DOCS / "citations.yaml").read_text())
    targets = list(mapping["citations"].items())
    targets += [(o["at"], o["to"]) for o in mapping["occurrences"]]
    for old, new in targets:
        m = CITATION.fullmatch(new)
        assert m, f"docs/citations.yaml: {old} -> {new} is not docs/PAGE.md#ANCHOR"
        out.append((f"docs/citations.yaml ({old})", m.group(1), m.group(2)))
    return out


def test_every_cited_docs_page_and_anchor_exists(site):
    cited = _cited()
    assert cited, "no docs citations found"
    missing = []
    for where, page, anchor in cited:
        if not (DOCS / page).is_file():
            missing.append(f"{where}: docs/{page} does not exist")
        elif anchor and f'id="{anchor}"' not in _page(site, page):
            missing.append(f"{where}: docs/{page}#{anchor}: no such anchor")
    assert not missing, "\n".join(sorted(set(missing)))
