"""The report page: one self-contained HTML file (figures embedded), readable when printed.

:func:`render_report` takes the scenario and the stages' :class:`~flexlift.output.stage.StageOutput`
and returns the HTML text; writing it is the caller's business.
"""

from __future__ import annotations

import base64
import html
import math
from datetime import UTC, datetime
from pathlib import Path

from flexlift import __version__
from flexlift.output.checktext import explain_check
from flexlift.output.stage import StageOutput, Table

STAGE_TITLES = {
    "modes": "1. Modal analysis of the hull",
    "loads": "2. Lift plan and longitudinal strength",
    "reduce": "3. State space and model reduction",
    "fuzzy": "4. Supervisory fuzzy controller",
    "simulate": "5. Controlled ascent",
    "contingency": "6. Single failures",
}

_CSS = """
body { font-family: "DejaVu Sans", Helvetica, Arial, sans-serif; max-width: 60rem;
       margin: 2rem auto; padding: 0 1rem; color: #1d2330; line-height: 1.45; }
h1 { font-size: 1.6rem; border-bottom: 3px solid #1f4e79; padding-bottom: .3rem; }
h2 { font-size: 1.25rem; color: #1f4e79; margin-top: 2.2rem; border-bottom: 1px solid #c9d3e0; }
h3 { font-size: 1.05rem; margin-bottom: .3rem; }
h1, h2, h3 { break-after: avoid; page-break-after: avoid; }
table { border-collapse: collapse; margin: .6rem 0 1rem; font-size: .88rem; }
table, tr, figure, .keep { break-inside: avoid; page-break-inside: avoid; }
th, td { border: 1px solid #c9d3e0; padding: .25rem .55rem; text-align: right; }
th { background: #eef3f9; text-align: center; }
td:first-child, th:first-child { text-align: left; }
figure { margin: 1rem 0; }
figure img { max-width: 100%; border: 1px solid #e1e6ee; }
figcaption { font-size: .85rem; color: #4a5568; }
.pass { color: #17703a; font-weight: bold; }
.fail { color: #b42318; font-weight: bold; }
.verdict { font-size: 1.1rem; padding: .6rem .9rem; border-radius: 4px; margin: 1rem 0; }
.verdict.ok { background: #e7f5ec; border: 1px solid #17703a; }
.verdict.bad { background: #fdecea; border: 1px solid #b42318; }
.verdict.partial { background: #fff7e0; border: 1px solid #d69e2e; }
.warn { background: #fff7e0; border-left: 4px solid #d69e2e; padding: .4rem .8rem; margin: .5rem 0; }
.meta { font-size: .85rem; color: #4a5568; }
nav ul { columns: 2; font-size: .9rem; list-style: none; padding-left: 0; }
@media print { body { max-width: none; margin: 0; } h2 { page-break-before: auto; }
               a { color: inherit; text-decoration: none; } }
"""


def _e(x) -> str:
    return html.escape(str(x))


def _cell(v) -> str:
    if isinstance(v, bool):
        return f'<span class="{"pass" if v else "fail"}">{"PASS" if v else "FAIL"}</span>'
    if isinstance(v, float):
        if math.isnan(v):
            return "–"
        if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
            return f"{v:.4g}"
        return f"{v:.4g}" if abs(v) < 10 else f"{v:,.1f}"
    if v is None:
        return "–"
    return _e(v)


def _table(t) -> str:
    if not t.in_report:
        return _csv_only(t)
    head = "".join(f"<th>{_e(c)}</th>" for c in t.columns)
    body = "".join("<tr>" + "".join(f"<td>{_cell(v)}</td>" for v in row) + "</tr>" for row in t.rows)
    link = (f' Also as <a href="tables/{_e(t.csv)}"><code>tables/{_e(t.csv)}</code></a>.'
            if t.csv else "")
    note = f'<p class="meta">{_e(t.note)}{link}</p>' if t.note or link else ""
    # the title stays with its table when printed (and the heading never ends a page)
    return (f'<div class="keep"><h3>{_e(t.title)}</h3><table><thead><tr>{head}</tr></thead>'
            f"<tbody>{body}</tbody></table>{note}</div>")


def _csv_only(t) -> str:
    """A table left off the page: one line linking its CSV file (relative to the report, in
    the same output folder) with its size."""
    if not t.csv:
        return ""
    href = f"tables/{t.csv}"
    return (f'<p class="meta csv">{_e(t.title)}: {len(t.rows)} rows × {len(t.columns)} '
            f'columns, in <a href="{_e(href)}"><code>{_e(href)}</code></a>.</p>')


def _figure(fig) -> str:
    data = base64.b64encode(fig.path.read_bytes()).decode("ascii")
    return (
        f'<figure><img alt="{_e(fig.caption)}" src="data:image/png;base64,{data}">'
        f"<figcaption>{_e(fig.caption)}</figcaption></figure>"
    )


def _criteria(criteria: dict[str, bool]) -> str:
    rows = "".join(
        f"<tr><td>{_e(k.replace('_', ' '))}</td><td>{_cell(bool(v))}</td></tr>"
        for k, v in criteria.items()
    )
    return f"<table><thead><tr><th>criterion</th><th>result</th></tr></thead><tbody>{rows}</tbody></table>"


def _controller_file(scenario, role: str) -> str:
    """Which fuzzy system ran as ``role``: the built-in one or the user's file, by checksum."""
    from flexlift.scenario.schema import file_sha256

    path = scenario.controller_files().get(f"control.{role}.fis_file")
    if path is None:
        return "built-in rule base (docs/theory/control.md#rule-table)"
    return f"the user's MATLAB file {Path(path).name}, SHA-256 {file_sha256(path)}"


def _faults(scenario) -> str:
    """The scenario's faults, one phrase each ("none" when the run is fault-free)."""
    parts = []
    for f in scenario.faults:
        extra = {k: v for k, v in f.model_dump().items() if k not in ("kind", "bag", "time_s")}
        more = ", ".join(f"{k} {v:g}" for k, v in extra.items() if isinstance(v, (int, float)))
        parts.append(f"{f.kind.replace('_', ' ')} of {f.bag} at {f.time_s:g} s"
                     + (f" ({more})" if more else ""))
    return "; ".join(parts) or "none"


def _disturbances(d) -> str:
    """The environmental disturbances of the run ("none" when calm)."""
    parts = []
    if d.current_m_s:
        parts.append(f"vertical current {d.current_m_s:+g} m/s (positive up)")
    if d.force_noise_N_m:
        parts.append(f"random line load, std {d.force_noise_N_m:g} N/m, correlation time "
                     f"{d.noise_time_s:g} s, seed {d.seed}")
    return "; ".join(parts) or "none"


def _sequence(seq) -> str:
    """The staged lift in words ("all bags at once" without one)."""
    if seq is None:
        return "all bags at once"
    if seq.groups is not None:
        how = f"{len(seq.groups)} named groups"
    else:
        how = (f"groups of {seq.group_size} from the {'aft end (x = 0)' if seq.from_end == 'start' else 'forward end'}")
    return f"staged: {how}, {seq.delay_s:g} s apart; each stage's stretch breaks out on its own"


def _particulars(scenario) -> str:
    h, env, c = scenario.hull, scenario.environment, scenario.control
    mass = f"{h.displacement_t:g} t" if h.displacement_t is not None else "per element (see scenario)"
    ei = h.bending_stiffness_Nm2
    ei = f"{ei:.3g} N m²" if not isinstance(ei, list) else "per element (see scenario)"
    rows = [
        ("Length overall L", f"{h.length_m:g} m"),
        ("Breadth / depth", f"{h.breadth_m:g} m / {h.depth_m:g} m"),
        ("Structural mass", mass),
        ("Bending stiffness EI", ei),
        ("Finite elements", f"{h.elements}"),
        ("Water depth at the wreck", f"{env.water_depth_m:g} m"),
        ("Target height above the seabed", f"{c.target_height_m:g} m"),
        ("Planned ascent speed", f"{c.ascent_speed_m_s:g} m/s"),
        ("Lift sequence", _sequence(c.sequence)),
        ("Retained flexible modes", f"{scenario.simulation.retained_flexible_modes}"),
        ("Limits", f"ascent < {scenario.limits.ascent_velocity_m_s:g} m/s, "
                   f"descent < {scenario.limits.descent_velocity_m_s:g} m/s, "
                   + ("no tilt criterion (the bending utilisation governs)"
                      if scenario.limits.pitch_deg is None
                      else f"pitch < {scenario.limits.pitch_deg:g}°") + ", no surface breach"),
        ("Supervisory controller", _controller_file(scenario, "supervisor")),
        ("Fill map", _controller_file(scenario, "fill")),
        ("Faults", _faults(scenario)),
        ("Disturbances", _disturbances(scenario.disturbance)),
    ]
    body = "".join(f"<tr><td>{_e(a)}</td><td>{_e(b)}</td></tr>" for a, b in rows)
    return f"<table><tbody>{body}</tbody></table>"


#: the verdict's heading and colour per outcome of the ascent (flexlift.ascent.outcome)
_OUTCOME_HEAD = {"unsafe": ("bad", "Unsafe"), "not_achieved": ("bad", "Not achieved"),
                 "incomplete": ("partial", "Incomplete"), "safe": ("ok", "Safe")}


def _verdict(lift: dict, checks: dict, warnings: list, reasons: dict | None = None,
             outcomes: dict | None = None, check_reasons: dict | None = None) -> str:
    """The verdict box: the ascent's outcome in each control mode decides (``outcomes``:
    mode -> {kind, cause, needs_s}); the numerical checks and warnings count, each failed one
    with what it means (``check_reasons``: "stage: criterion" -> sentence); each failed lift
    criterion with its cause (``reasons``: "mode: criterion" -> sentence)."""
    if not lift:
        return ('<div class="verdict bad">The ascent was not simulated, so the lift criteria '
                "were not evaluated.</div>")
    outcomes = outcomes or {}
    failed = [k for k, v in {**lift, **checks}.items() if not v]
    bad_checks = [k for k, v in checks.items() if not v]
    if not failed and not warnings:
        return ('<div class="verdict ok"><b>Lift plan acceptable:</b> every lift criterion passed '
                "in every control mode simulated, every numerical check passed, no warnings.</div>")
    kinds = [o.get("kind") for o in outcomes.values()]
    worst = next((k for k in ("unsafe", "not_achieved", "incomplete") if k in kinds), None)
    items = [f"<li><b>{_e(m)} control: {_e(_OUTCOME_HEAD[o['kind']][1].lower())}</b> — "
             f"{_e(o.get('cause', ''))}</li>" for m, o in outcomes.items()
             if o.get("kind") in ("unsafe", "not_achieved", "incomplete")]
    shown = {f"{m}: reached_target" for m, o in outcomes.items()
             if o.get("kind") in ("not_achieved", "incomplete")}
    items += [f"<li><b>{_e(k)}</b>: {_e(r)}</li>" for k, r in (reasons or {}).items()
              if k not in shown and not any(o.get("kind") == "unsafe" and k.startswith(f"{m}: ")
                                            for m, o in outcomes.items())]
    items += [f"<li><b>numerical check {_e(k)} failed</b>: "
              f"{_e((check_reasons or {}).get(k, 'see its stage'))}</li>" for k in bad_checks]
    cls, head = _OUTCOME_HEAD.get(worst, ("bad", "Review needed"))
    if worst is None:
        lead = "every lift criterion passed"
        cls, head = ("bad", "Review needed") if bad_checks else ("partial", "Review the warnings")
        if bad_checks:
            lead += (f", but {len(bad_checks)} numerical check(s) of the analysis failed: its "
                     "numbers cannot be signed until they pass")
    elif worst == "incomplete":
        lead = ("every limit held, but the run ended before the target was held: no lift was "
                "unsafe; lengthen the run to know")
    elif worst == "not_achieved":
        lead = "every limit held, but the plan cannot finish"
    else:
        lead = f"{len(failed)} criterion(s) failed: {', '.join(failed)}"
    if warnings:
        lead += f"; {len(warnings)} warning(s)"
    causes = f"<ul>{''.join(items)}</ul>" if items else ""
    return f'<div class="verdict {cls}"><b>{_e(head)}:</b> {_e(lead)}.{causes}</div>'


#: the stages a client reads in the body (the plan and its strength, the ascent); the modal
#: analysis, the reduction and the fuzzy controller are the research appendix
BODY_STAGES = ("loads", "simulate", "compare", "contingency")


def _limits_table(scenario, stages: list[StageOutput]) -> Table | None:
    """The ascent against its limits: each simulated value beside its limit and the share of
    the limit it used, in every control mode (None when nothing was simulated)."""
    runs = [(s.name.split(":", 1)[1], s.summary) for s in stages if s.name.startswith("simulate:")]
    if not runs:
        return None
    lim = scenario.limits
    rows_spec = [
        ("largest upward speed", "m/s", lim.ascent_velocity_m_s, "max_ascent_velocity_ms"),
        ("largest downward speed once separated", "m/s", lim.descent_velocity_m_s,
         "max_descent_velocity_ms"),
        ("largest pitch", "deg", lim.pitch_deg, "max_pitch_deg"),
        ("hull girder bending utilisation", "-", 1.0, "max_utilisation"),
        ("largest slope (the beam model's validity)", "deg", lim.slope_validity_deg,
         "max_slope_deg"),
    ]
    rows = []
    for label, unit, limit, key in rows_spec:
        values = [summary.get(key) for _, summary in runs]
        known = [abs(v) for v in values if isinstance(v, int | float)]
        used = f"{100 * max(known) / limit:.0f} %" if known and limit else None
        limit = "none (not judged)" if limit is None else limit
        rows.append([f"{label} [{unit}]", limit, *values, used])
    rows.append(["outcome", "safe", *[summary.get("outcome") for _, summary in runs], None])
    return Table("The ascent against its limits",
                 ["criterion", "limit", *[f"{m} control" for m, _ in runs], "most of the limit used"],
                 rows, note="Each value is the run's own (flexlift simulate); the limits are the "
                 "scenario's (section limits).")


def _title(stage: str) -> str:
    """A stage's heading without the analysis's step number ("Lift plan and longitudinal
    strength", not "2. Lift plan ..."): the report reads in a client's order, not the code's."""
    return STAGE_TITLES.get(stage, stage).split(". ", 1)[-1]


def _stage_sections(stages: list[StageOutput], level: int = 2) -> list[str]:
    """One section per stage (control modes as sub-sections): lead, tables, figures;
    ``level``: the stage headings' level (3 inside the appendix)."""
    parts: list[str] = []
    seen: set[str] = set()
    for s in stages:
        base, _, variant = s.name.partition(":")
        base = "simulate" if base == "compare" else base
        if base not in seen:
            seen.add(base)
            parts.append(f'<h{level} id="{_e(base)}">{_e(_title(base))}</h{level}>')
        if variant:
            parts.append(f'<h{level + 1} id="{_e(s.name)}">{_e(variant)} control</h{level + 1}>')
        elif s.name == "compare":  # its table carries the title "Control modes compared"
            parts.append('<span id="compare"></span>')
        lead = s.summary.get("conclusion") if isinstance(s.summary, dict) else None
        if lead:
            parts.append(f"<p>{_e(lead)}</p>")
        if s.warnings:
            parts.append(f'<p class="meta">{len(s.warnings)} warning(s): see '
                         '<a href="#warnings">Warnings</a>.</p>')
        parts += [_table(t) for t in s.tables if not _appendix(t)]
        parts += [_figure(f) for f in s.figures]
    return parts


def _appendix(t) -> bool:
    """A table that belongs to the appendix (its title says so: e.g. the paper's still-water
    strength table, kept for comparison beside the design cases)."""
    return t.title.startswith("Appendix")


def _appendix_section(stages: list[StageOutput]) -> list[str]:
    """The tables that belong to the appendix (the paper's own), after its stages."""
    return [_table(t) for s in stages for t in s.tables if _appendix(t)]


def _basis(scenario) -> str:
    """Every factor, limit and assumed value with its source, the catalogue bag, and the
    factors that do not apply with their reason (scenario/basis.py)."""
    from flexlift.scenario.basis import design_basis

    def show(v):
        return f"{v:g}" if isinstance(v, float | int) and not isinstance(v, bool) else str(v)

    rows = "".join(f"<tr><td>{_e(r['item'])}</td><td>{_e(show(r['value']))}</td>"
                   f"<td>{_e(r['source'])}</td><td>{_e(r['note'])}</td></tr>"
                   for r in design_basis(scenario))
    return ('<div class="keep"><h3 id="factors">Factors, limits and their sources</h3>'
            "<table><tr><th>item</th><th>value</th><th>source</th><th>note</th></tr>"
            f"{rows}</table></div>")


def _assumed(scenario) -> str:
    """The values nobody gave (scenario/defaults.py): each with its rule or assumption."""
    from flexlift.scenario.defaults import assumed_summary

    lines = assumed_summary(scenario)
    if not lines:
        return ('<p class="meta">Every value of the structure and the site was given in the '
                "scenario (or is the built-in reference case's); none was assumed.</p>")
    items = "".join(f"<li>{_e(line)}</li>" for line in lines)
    return (f'<div class="keep"><h3 id="assumed">Values assumed or derived, not given</h3>'
            f"<ul>{items}</ul></div>")


#: the separate page of the research appendix beside report.html (flexlift run writes both)
APPENDIX_PAGE = "appendix.html"


def render_appendix(scenario, stages: list[StageOutput],
                    generated: datetime | None = None) -> str:
    """The research appendix as its own page: the modal analysis, the model reduction and the
    fuzzy controller the ascent is built on (what a researcher opens; the client's report
    links it)."""
    generated = generated or datetime.now(UTC)
    research = [s for s in stages if s.name.split(":")[0] not in BODY_STAGES]
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>flexlift appendix: {_e(scenario.name)}</title><style>{_CSS}</style></head>"
        "<body>",
        f"<h1>flexlift report — {_e(scenario.name)}: the analysis behind the numbers</h1>",
        f'<p class="meta">flexlift {_e(__version__)} · scenario checksum (SHA-256) '
        f"<code>{_e(scenario.checksum())}</code> · generated {generated:%Y-%m-%d %H:%M} UTC · "
        'the decision and the plan are in <a href="report.html">report.html</a></p>',
    ]
    parts += _stage_sections(research)
    parts.append("</body></html>")
    return "\n".join(p for p in parts if p)


def render_report(scenario, stages: list[StageOutput], generated: datetime | None = None,
                  appendix_page: str | None = None) -> str:
    """The whole report as one HTML page (figures embedded as base64 PNG). With
    ``appendix_page`` (a file name beside it, written from :func:`render_appendix`) the
    modal, reduction and fuzzy stages are left to that page and linked; without, they are the
    report's appendix."""
    generated = generated or datetime.now(UTC)
    # lift criteria (docs/theory/factors.md#criteria) decide the verdict; the other stages' checks are numerical
    # self-checks of the analysis, shown apart but counted too
    lift = {f"{s.name.split(':', 1)[1]}: {k}": v for s in stages
            if s.name.startswith("simulate:") for k, v in s.criteria.items()}
    checks = {f"{s.name}: {k}": v for s in stages
              if not s.name.startswith("simulate:") for k, v in s.criteria.items()}
    reasons = {f"{s.name.split(':', 1)[1]}: {k}": r for s in stages
               if s.name.startswith("simulate:") for k, r in s.summary.get("reasons", {}).items()}
    outcomes = {s.name.split(":", 1)[1]: {"kind": s.summary.get("outcome"),
                                          "cause": s.summary.get("outcome_cause")}
                for s in stages if s.name.startswith("simulate:") and s.summary.get("outcome")}
    check_reasons = {f"{s.name}: {k}": explain_check(s.name, k, s.summary) for s in stages
                     if not s.name.startswith("simulate:") for k, v in s.criteria.items() if not v}
    warnings = [(s.name, w) for s in stages for w in s.warnings]
    headline = _limits_table(scenario, stages)
    if headline is None:
        headline = next((s.tables[0] for s in stages if s.name == "loads" and s.tables), None)
    body = [s for s in stages if s.name.split(":")[0] in BODY_STAGES]
    research = [s for s in stages if s.name.split(":")[0] not in BODY_STAGES]
    apart = bool(appendix_page and research)
    bases = dict.fromkeys("simulate" if s.name == "compare" else s.name.split(":")[0] for s in body)
    nav = '<li><a href="#design-basis">Design basis</a></li>'
    nav += "".join(f'<li><a href="#{b}">{_e(_title(b))}</a></li>' for b in bases)
    if warnings:
        nav += '<li><a href="#warnings">Warnings</a></li>'
    if research or checks:
        nav += '<li><a href="#appendix">Appendix: the analysis behind the numbers</a></li>'
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>flexlift report: {_e(scenario.name)}</title><style>{_CSS}</style></head><body>",
        f"<h1>flexlift report — {_e(scenario.name)}</h1>",
        f"<p>{_e(scenario.description)}</p>" if scenario.description else "",
        f'<p class="meta">flexlift {_e(__version__)} · scenario checksum (SHA-256) '
        f"<code>{_e(scenario.checksum())}</code> · generated {generated:%Y-%m-%d %H:%M} UTC</p>",
        '<h2 id="decision">Decision</h2>',
        _verdict(lift, checks, warnings, reasons, outcomes, check_reasons),
        _table(headline) if headline is not None else "",
        f"<nav><ul>{nav}</ul></nav>",
        '<h2 id="design-basis">Design basis</h2>',
        _particulars(scenario),
        _basis(scenario),
        _assumed(scenario),
    ]
    if lift:
        parts += ['<h3 id="criteria">Lift criteria</h3>', _criteria(lift)]
    parts += _stage_sections(body)
    if warnings:
        parts += ['<h2 id="warnings">Warnings</h2>'] + [
            f'<div class="warn"><b>{_e(name)}:</b> {_e(w)}</div>' for name, w in warnings]
    if research or checks or any(_appendix(t) for s in stages for t in s.tables):
        parts.append('<h2 id="appendix">Appendix: the analysis behind the numbers</h2>')
        parts.append('<p class="meta">For the researcher and the checker: the modal analysis, '
                     "the model reduction and the fuzzy controller the ascent is built on, the "
                     "numerical self-checks of the analysis, and the paper's own tables.</p>")
    if apart:
        titles = ", ".join(STAGE_TITLES.get(b, b).split(". ", 1)[-1].lower()
                           for b in dict.fromkeys(s.name.split(":")[0] for s in research))
        parts.append(f'<p id="research">The {_e(titles)}: in <a href="{_e(appendix_page)}">'
                     f"<code>{_e(appendix_page)}</code></a>, beside this report.</p>")
    if checks:
        parts += ['<h3 id="checks">Numerical checks of the analysis</h3>', _criteria(checks)]
    if not apart:
        parts += _stage_sections(research, level=3)
    parts += _appendix_section(stages)
    parts.append("</body></html>")
    return "\n".join(p for p in parts if p)
