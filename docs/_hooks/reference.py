"""MkDocs hook: the scenario and sweep SPEC references, generated from the code at build time.

A page holding the marker ``<!-- generated: scenario-keys -->`` gets one table per section of
the scenario, walked from the pydantic models of :mod:`flexlift.scenario` (key, default,
allowed range, meaning); ``<!-- generated: bag-catalogue -->`` gets the packaged bag catalogue's models (the names
``lift.catalogue_bag.model`` may give), from :mod:`flexlift.scenario.catalogue`;
``<!-- generated: sweep-spec -->`` gets the SPEC file's keys and the
distributions, from :mod:`flexlift.sweep.spec` and :mod:`flexlift.sweep.distributions`. The
ranges and defaults are the schema's own, so the pages cannot drift from the code. The
meanings come from ``docs/reference/scenario-keys.yaml`` (falling back to the comment beside
the key in the source); a key with neither, or a meaning for a key that no longer exists, is a
warning, which ``mkdocs build --strict`` turns into a failed build.
"""

from __future__ import annotations

import inspect
import logging
import math
import re
import types
import typing
from pathlib import Path

import annotated_types as at
import yaml
from pydantic import BaseModel
from pydantic_core import PydanticUndefined

log = logging.getLogger("mkdocs.plugins.flexlift")

HERE = Path(__file__).resolve().parent
MEANINGS = HERE.parent / "reference" / "scenario-keys.yaml"
SCENARIO_MARKER = "<!-- generated: scenario-keys -->"
SWEEP_MARKER = "<!-- generated: sweep-spec -->"
CATALOGUE_MARKER = "<!-- generated: bag-catalogue -->"


# --------------------------------------------------------------------------- numbers
def num(v) -> str:
    """A number as a reader writes it: 350, 0.57, 1e-9, 1e6, 2.5e-5."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if v == 2**63 - 1:
        return "2⁶³−1"
    if isinstance(v, int):
        return str(v)
    if math.isinf(v):
        return "∞" if v > 0 else "-∞"
    if v == int(v) and abs(v) < 1e5:
        return str(int(v))
    text = f"{v:.6g}"
    if "e" in text:
        mant, exp = text.split("e")
        text = f"{mant}e{int(exp)}"
    return text


def _unwrap(ann):
    """(base annotation, constraints dict, validator names) of an Annotated type, layers merged."""
    cons: dict = {}
    funcs: list[str] = []
    while typing.get_origin(ann) is typing.Annotated:
        base, *meta = typing.get_args(ann)
        for m in meta:
            for c in getattr(m, "metadata", None) or [m]:
                for attr in ("ge", "gt", "le", "lt", "min_length", "max_length"):
                    if isinstance(c, at.BaseMetadata) and hasattr(c, attr):
                        cons[attr] = getattr(c, attr)
                    elif getattr(c, attr, None) is not None and not isinstance(c, at.BaseMetadata):
                        cons[attr] = getattr(c, attr)
                f = getattr(c, "func", None)
                if f is not None:
                    funcs.append(f.__name__)
        ann = base
    return ann, cons, funcs


def _interval(cons: dict, whole: bool) -> str:
    lo = cons.get("ge", cons.get("gt", -math.inf))
    hi = cons.get("le", cons.get("lt", math.inf))
    if whole:
        return f"{num(lo)}..{num(hi)}"
    left = "(" if "gt" in cons else "["
    right = ")" if "lt" in cons else "]"
    return f"{left}{num(lo)}, {num(hi)}{right}"


def _models(ann) -> list[type[BaseModel]]:
    """The models a list item may be (one, or a discriminated union of several)."""
    ann, _, _ = _unwrap(ann)
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return [ann]
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        out = []
        for a in typing.get_args(ann):
            out += _models(a)
        return out
    return []


def allowed(ann) -> str:
    """What a value of type ``ann`` may be, in words and ranges."""
    ann, cons, funcs = _unwrap(ann)
    origin = typing.get_origin(ann)
    if origin in (typing.Union, types.UnionType):
        alts = [a for a in typing.get_args(ann) if a is not type(None)]
        text = "; or ".join(allowed(a) for a in alts)
        return text + ("; or null" if len(alts) < len(typing.get_args(ann)) else "")
    if origin is typing.Literal:
        return ", ".join(f"`{a}`" for a in typing.get_args(ann))
    if origin is list:
        (item,) = typing.get_args(ann)
        size = f"at most {num(cons['max_length'])} " if "max_length" in cons else ""
        if _models(item):
            return f"a list of {size}items (keys below)"
        return f"a list of {size}values, each {allowed(item)}"
    if origin is tuple:
        items = typing.get_args(ann)
        return f"a pair [a, b], each {allowed(items[0])}" if len(items) == 2 else "a list"
    if ann is bool:
        return "`true`, `false`"
    if ann is int:
        return _interval(cons, whole=True)
    if ann is float:
        return _interval(cons, whole=False)
    if ann is str:
        if "_name" in funcs:
            return "a name: 1..100 letters, digits, `_`, `-`, `.` (not `.` or `..`)"
        if "_fis_file" in funcs:
            return "a path ending `.fis`"
        return f"text of at most {num(cons['max_length'])} characters" if "max_length" in cons \
            else "text"
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return "a section (keys below)"
    return str(ann)


def default(field) -> str:
    if field.default is PydanticUndefined:
        return "required"
    v = field.default
    if isinstance(v, BaseModel):
        return ""
    if v is None:
        return "null"
    if isinstance(v, list | tuple):
        return "[" + ", ".join(num(x) if isinstance(x, int | float) else str(x) for x in v) + "]"
    if isinstance(v, int | float):
        return num(v)
    return f"`{v}`" if v != "" else '`""`'


def _section(ann) -> type[BaseModel] | None:
    ann, _, _ = _unwrap(ann)
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        return ann
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        alts = [a for a in typing.get_args(ann) if a is not type(None)]
        if len(alts) == 1:
            return _section(alts[0])
    return None


def _list_models(ann) -> list[type[BaseModel]]:
    ann, _, _ = _unwrap(ann)
    if typing.get_origin(ann) in (typing.Union, types.UnionType):
        alts = [a for a in typing.get_args(ann) if a is not type(None)]
        return _list_models(alts[0]) if len(alts) == 1 else []
    if typing.get_origin(ann) is list:
        return _models(typing.get_args(ann)[0])
    return []


def _comments(model: type[BaseModel]) -> dict[str, str]:
    """The comment beside each field in the model's source: ``name: ... = v  # comment``."""
    try:
        lines = inspect.getsourcelines(model)[0]
    except (OSError, TypeError):
        return {}
    out = {}
    for line in lines:
        m = re.match(r"\s+(\w+):[^#]*#\s*(.+)$", line)
        if m:
            out[m.group(1)] = m.group(2).strip()
    return out


def _field_annotation(field):
    return typing.Annotated[(field.annotation, *field.metadata)] if field.metadata \
        else field.annotation


def walk(model: type[BaseModel], prefix: str = ""):
    """Rows ``(dotted key, field, annotation, owner model, note)`` of every key, in the schema's
    order; a section's keys follow it; a list of items' keys are ``key[].item``."""
    for name, field in model.model_fields.items():
        key = f"{prefix}{name}"
        ann = _field_annotation(field)
        sub = _section(ann)
        if sub is not None:
            yield key, field, ann, model, "section"
            yield from walk(sub, key + ".")
            continue
        yield key, field, ann, model, ""
        items = _list_models(ann)
        if len(items) == 1:
            yield from walk(items[0], key + "[].")
        elif items:  # a discriminated union: every variant's keys, once
            seen: dict[str, list] = {}
            for m in items:
                kind = typing.get_args(m.model_fields["kind"].annotation)[0]
                for fname, f in m.model_fields.items():
                    if fname == "kind":
                        continue
                    seen.setdefault(fname, [f, m, []])[2].append(kind)
            kinds = [typing.get_args(m.model_fields["kind"].annotation)[0] for m in items]
            yield (f"{key}[].kind", items[0].model_fields["kind"],
                   typing.Literal[tuple(kinds)], items[0], "")
            for fname, (f, m, ks) in seen.items():
                note = "" if len(ks) == len(items) else "for " + ", ".join(f"`{k}`" for k in ks)
                yield f"{key}[].{fname}", f, _field_annotation(f), m, note


# --------------------------------------------------------------------------- scenario page
def _meanings() -> dict:
    return yaml.safe_load(MEANINGS.read_text(encoding="utf-8")) or {}


def _cell(text: str) -> str:
    return str(text).replace("|", "\\|").replace("\n", " ")


def scenario_tables() -> str:
    from flexlift.scenario import Scenario

    meanings = _meanings()
    rows = list(walk(Scenario))
    keys = {r[0] for r in rows}
    for stale in sorted(set(meanings) - keys):
        log.warning("docs/reference/scenario-keys.yaml: '%s' is not a key of the schema", stale)
    out = []
    comments: dict = {}
    current = None
    for key, field, ann, owner, note in rows:
        top = key.split(".")[0].split("[")[0]
        if top != current:
            current = top
            sub = _section(_field_annotation(Scenario.model_fields[top]))
            doc = inspect.cleandoc(sub.__doc__ or "").split("\n\n")[0].replace("\n", " ") \
                if sub else ""
            out += ["", f"### {top}", "", doc, "", "| key | default | allowed | meaning |",
                    "|---|---|---|---|"]
        if note == "section":
            if "." in key:
                out.append(f"| **`{key}.`** | | {'or null' if field.default is None else ''} "
                           f"| {_cell(meanings.get(key, ''))} |")
            continue
        if owner not in comments:
            comments[owner] = _comments(owner)
        meaning = meanings.get(key) or comments[owner].get(key.rsplit(".", 1)[-1], "")
        if not meaning:
            log.warning("scenario key %s has no meaning: add it to "
                        "docs/reference/scenario-keys.yaml", key)
        if note:
            meaning = f"({note}) {meaning}"
        out.append(f"| `{key}` | {_cell(default(field))} | {_cell(allowed(ann))} | "
                   f"{_cell(meaning)} |")
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- sweep page
SWEEP_TOP = {
    "base": ("`tanker`", "a built-in name or a path to a scenario file (relative to the SPEC's "
             "folder)"),
    "control": ("the base's `control.mode`", "one control mode or a list of different ones, "
                "each run per case"),
    "keep": ("`summary`", "`summary` (headline numbers and criteria per case) or `histories` "
             "(also every case's time histories, netCDF)"),
    "worst": ("10", "0..1000: how many worst cases the report lists, with their scenario files"),
    "set": ("{}", "fixed overrides for every case: dotted scenario key → value"),
    "grid": ("", "dotted key → a list of values, or `{low, high, num, scale: linear|log}`; the "
             "cases are the product of the lists (the last key varies fastest). Either `grid` "
             "or `monte_carlo`"),
    "monte_carlo": ("", "`samples`, `seed`, `method`, `vary` (below). Either `grid` or "
                    "`monte_carlo`"),
    "study": ("none", "a ready uncertainty study (`salvage`): its laws, each with its source, "
              "and the plan pinned; `monte_carlo.vary` narrows, widens or adds laws "
              "([guide](../guide/sweeps.md#studies))"),
}
SWEEP_MC = {
    "samples": ("required", "whole number ≥ 1: the number of cases"),
    "seed": ("0", "0..2⁶³−1: `numpy.random.SeedSequence(seed)` draws every case"),
    "method": ("`lhs`", "`lhs` (Latin hypercube, `scipy.stats.qmc`), `random`, or `sobol` "
               "(Saltelli's design, SALib: `samples` base samples, samples × (keys + 2) cases, "
               "Sobol' indices and no probability)"),
    "vary": ("", "dotted key → a distribution `{dist: …, parameters}` (below)"),
    "until_halfwidth": ("none", "0 < H < 0.5: stop at the first block's end where every "
                        "probability's 95 % Wilson half-width is ≤ H (`samples`: the most "
                        "cases); `lhs` or `random`"),
    "block": ("100", "cases per block with `until_halfwidth` (an `lhs` block is its own "
              "hypercube)"),
}


def sweep_tables() -> str:
    from flexlift.sweep import distributions, spec

    for name in spec.TOP_KEYS:
        if name not in SWEEP_TOP:
            log.warning("sweep SPEC key %s is not described in docs/_hooks/reference.py", name)
    for name in spec.MC_KEYS:
        if name not in SWEEP_MC:
            log.warning("monte_carlo key %s is not described in docs/_hooks/reference.py", name)
    out = ["### Top-level keys", "", "| key | default | allowed |", "|---|---|---|"]
    out += [f"| `{k}` | {SWEEP_TOP[k][0]} | {SWEEP_TOP[k][1]} |" for k in spec.TOP_KEYS
            if k in SWEEP_TOP]
    out += ["", "### `monte_carlo:`", "", "| key | default | allowed |", "|---|---|---|"]
    out += [f"| `monte_carlo.{k}` | {SWEEP_MC[k][0]} | {SWEEP_MC[k][1]} |" for k in spec.MC_KEYS
            if k in SWEEP_MC]
    out += ["", "### Distributions", "", "| `dist` | parameters | optional |", "|---|---|---|"]
    for kind, (need, opt) in distributions.PARAMS.items():
        out.append(f"| `{kind}` | {', '.join(f'`{p}`' for p in sorted(need))} | "
                   f"{', '.join(f'`{p}`' for p in sorted(opt)) or '—'} |")
    out += ["", f"At most {spec.LARGE:,} cases without `--yes`, and never more than "
            f"{spec.MAX_CASES:,}. A key's own range truncates a law silently where it cuts off "
            f"less than {num(distributions.TAIL_MASS)} of the probability; beyond that the "
            "SPEC must give `low` / `high` itself.", ""]
    return "\n".join(out)


# --------------------------------------------------------------------------- bag catalogue
def catalogue_table() -> str:
    """The packaged bag catalogue (flexlift/data/bags.yaml): the names
    ``lift.catalogue_bag.model`` may give, with each entry's type and size."""
    from flexlift.scenario import catalogue

    out = ["| `model` | type | lift [t] | diameter [m] | length [m] | relief [bar] | "
           "dump valve [m3/s] | source |", "|---|---|---|---|---|---|---|---|"]
    for name, e in catalogue.builtin().items():
        cells = [num(e[k]) if e.get(k) is not None else "—" for k in
                 ("lift_t", "diameter_m", "length_m", "relief_bar", "dump_valve_m3_s")]
        out.append(f"| `{name}` | {e['type'].replace('_', ' ')} | {' | '.join(cells)} | "
                   f"{_cell(e.get('source', ''))} |")
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- the hook
def on_page_markdown(markdown: str, page, config, files) -> str:
    if SCENARIO_MARKER in markdown:
        markdown = markdown.replace(SCENARIO_MARKER, scenario_tables())
    if CATALOGUE_MARKER in markdown:
        markdown = markdown.replace(CATALOGUE_MARKER, catalogue_table())
    if SWEEP_MARKER in markdown:
        markdown = markdown.replace(SWEEP_MARKER, sweep_tables())
    return markdown


#: a reST role before a code span in a rendered docstring (``:func:`name```), and the ``~``
#: that shortens a dotted name: the site shows the name alone
ROLE = re.compile(r":(?:func|class|mod|data|meth|attr|obj|exc):\s*(<code>)~?")


def on_page_content(html: str, page, config, files) -> str:
    return ROLE.sub(r"\1", html)
