"""The sweep's report: one self-contained HTML page (figures embedded), readable printed.

Per control mode: the probability of failing each criterion with its 95 % Wilson interval,
the varied keys ranked by their influence (rank correlation with failing, and with the
headline numbers as a tornado plot), the distributions of the headline numbers, the worst
cases with the scenario file and the command that reruns each one exactly, and the cases that
failed or were lost with their messages.
"""

from __future__ import annotations

import base64
import functools
import html
from datetime import UTC, datetime

from flexlift import __version__
from flexlift.sweep import aggregate as agg
from flexlift.sweep import plots

_CSS = """
body { font-family: "DejaVu Sans", Helvetica, Arial, sans-serif; max-width: 64rem;
       margin: 2rem auto; padding: 0 1rem; color: #1d2330; line-height: 1.45; }
h1 { font-size: 1.6rem; border-bottom: 3px solid #1f4e79; padding-bottom: .3rem; }
h2 { font-size: 1.25rem; color: #1f4e79; margin-top: 2.2rem; border-bottom: 1px solid #c9d3e0; }
table { border-collapse: collapse; margin: .6rem 0 1rem; font-size: .86rem; }
th, td { border: 1px solid #c9d3e0; padding: .25rem .55rem; text-align: right; vertical-align: top; }
th { background: #eef3f9; text-align: center; }
td.l, th.l { text-align: left; }
code { font-size: .82rem; }
figure { margin: 1rem 0; page-break-inside: avoid; }
figure img { max-width: 100%; border: 1px solid #e1e6ee; }
figcaption, .meta { font-size: .85rem; color: #4a5568; }
.fail { color: #b42318; font-weight: bold; }
.pass { color: #17703a; font-weight: bold; }
.verdict { font-size: 1.05rem; padding: .6rem .9rem; border-radius: 4px; margin: 1rem 0;
           background: #eef3f9; border: 1px solid #1f4e79; }
@media print { body { max-width: none; margin: 0; } }
"""


def _e(x) -> str:
    return html.escape(str(x))


def _pct(p) -> str:
    return "–" if p is None else f"{100 * p:.3g} %"


def _num(v) -> str:
    if v is None:
        return "–"
    if isinstance(v, float):
        return f"{v:.4g}"
    return _e(v)


def _table(head: list[str], rows: list[list[str]], left: int = 1) -> str:
    th = "".join(f'<th class="{"l" if k < left else ""}">{_e(h)}</th>' for k, h in enumerate(head))
    body = "".join("<tr>" + "".join(f'<td class="{"l" if k < left else ""}">{c}</td>'
                                    for k, c in enumerate(r)) + "</tr>" for r in rows)
    return f"<table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"


def figure_makers(result, summary: dict) -> dict:
    """The report's figures: {name: a function drawing it (a figure, or None where there is
    nothing to draw)}, by the names :func:`render_report` reads them under."""
    spec, records = result.spec, result.records
    keys = list(spec.keys)
    out = {}
    if spec.method != "sobol":
        for m in spec.controls:
            curve = summary.get("convergence", {}).get(m, {})
            if curve.get("n", []):
                out[f"convergence:{m}"] = functools.partial(plots.convergence, curve)
            out[f"tornado:{m}"] = functools.partial(plots.tornado, summary["headline_sensitivity"],
                                                    m, keys)
    out["cdfs"] = functools.partial(plots.cdfs, records, spec.controls, _limits(spec))
    return out


def render_figures(makers: dict) -> dict:
    """{name: the figure as PNG bytes, or None} for the ``makers`` of :func:`figure_makers`."""
    out = {}
    for name, make in makers.items():
        fig = make()
        out[name] = None if fig is None else plots.png(fig)
    return out


def _limits(spec) -> dict:
    return {k: v for k, v in agg.limits_of(spec.base).items()
            if agg.LIMITED[k] not in spec.keys}  # a limit that varies has no one line


def _figure(png: bytes | None, caption: str) -> str:
    if png is None:
        return ""
    data = base64.b64encode(png).decode("ascii")
    return (f'<figure><img alt="{_e(caption)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{_e(caption)}</figcaption></figure>")


def _variations(spec) -> str:
    if spec.method == "grid":
        rows = [[f"<code>{_e(k)}</code>", _e(", ".join(map(str, v))), str(len(v))]
                for k, v in spec.grid.items()]
        return _table(["key", "values", "count"], rows)
    sources = dict(spec.study.sources) if spec.study is not None else {}
    from flexlift.sweep.studies import group_of

    rows = [[f"<code>{_e(k)}</code>", _e(d.describe()),
             _e(sources.get(k, sources.get(group_of(k), "the SPEC")))]
            for k, d in spec.distributions.items()]
    how = {"lhs": "Latin hypercube", "random": "plain Monte Carlo",
           "sobol": "Saltelli's design for Sobol' indices (base samples)"}[spec.method]
    if spec.method == "lhs" and spec.block:
        how += f" in blocks of {spec.block} (each its own hypercube)"
    study = (f" Study <b>{_e(spec.study.name)}</b>: the plan is pinned (the bags as planned for "
             "the nominal scenario), the world varies." if spec.study is not None else "")
    return (f'<p>{spec.samples:,} samples, {how}, seed {spec.seed}.{study}</p>'
            + _table(["key", "distribution", "source"], rows, left=3))


def _sobol(summary: dict, mode: str) -> str:
    """The Sobol' indices of each output, with their bootstrap 95 % half-widths."""
    parts = ["<p>Sobol' first-order (S1) and total (ST) indices, 95 % bootstrap half-widths; "
             "a key (all bags' capacity factors as one group) is named a driver only when its "
             "ST interval excludes zero. Outputs: each criterion's margin to its limit "
             "(1 - peak / limit) and the arrival time. No probability comes from these rows "
             "(they are not independent draws): run method lhs or random for them.</p>"]
    for out, res in summary["sobol"][mode].items():
        groups = res.get("groups", {})
        if not groups:
            parts.append(f"<p><b>{_e(out)}</b>: not estimated ({res['n_used']} whole base "
                         "samples, or the output does not vary).</p>")
            continue
        drivers = [g for g, v in sorted(groups.items(), key=lambda kv: -kv[1]["ST"])
                   if v["driver"]]
        rows = [[f"<code>{_e(g)}</code>", f"{v['S1']:.3f} ± {v['S1_conf']:.3f}",
                 f"{v['ST']:.3f} ± {v['ST_conf']:.3f}", "yes" if v["driver"] else "–"]
                for g, v in groups.items()]
        parts.append(f"<p><b>{_e(out)}</b> ({res['n_used']} base samples): drivers "
                     + (", ".join(f"<code>{_e(d)}</code>" for d in drivers) or "none shown")
                     + "</p>" + _table(["key or group", "S1", "ST", "driver"], rows))
    return "".join(parts)


def _convergence(summary: dict, mode: str, pngs: dict) -> str:
    """Each probability against the number of cases, with its Wilson interval."""
    curve = summary.get("convergence", {}).get(mode, {})
    ns = curve.get("n", [])
    if not ns:
        return ""
    names = [k for k in curve if k != "n"]
    rows = []
    for j, n in enumerate(ns):
        if j % max(1, len(ns) // 10) and j != len(ns) - 1:
            continue
        rows.append([str(n)] + [f"{_pct(curve[k][j][0])} ({_pct(curve[k][j][1])} – "
                                f"{_pct(curve[k][j][2])})" for k in names])
    stop = ""
    if summary.get("until_halfwidth") is not None:
        stop = (f"<p>Run until every 95 % half-width was at most "
                f"{_pct(summary['until_halfwidth'])} (checked at each block's end, "
                f"{summary['block']} cases): stopped at {summary['stopped_at']:,} cases.</p>")
    return (stop + _figure(pngs.get(f"convergence:{mode}"),
                           f"Each probability against the number of cases ({mode} control), "
                           "with its 95 % Wilson interval.")
            + _table(["cases", *[k.replace("_", " ") for k in names]], rows))


#: the outcomes' rows in the probability table (flexlift.ascent.outcome)
OUTCOME_ROWS = {
    "unsafe": "unsafe: a limit broken",
    "not_achieved": "not achieved: every limit held, the plan cannot finish",
    "failed": "failed to run: numerics, invalid values or out of memory",
    "incomplete": "incomplete: every limit held, the run ended before the target was held",
}


def _row(name: str, w: dict, bad: bool = True) -> list[str]:
    cls = "fail" if w["failed"] and bad else "pass"
    return [_e(name), f'<span class="{cls}">{w["failed"]}</span> / {w["n"]}', _pct(w["p"]),
            f"{_pct(w['low'])} – {_pct(w['high'])}"]


def _probabilities(summary: dict, mode: str) -> str:
    fp = summary["by_control"][mode]
    rows = [_row(c.replace("_", " "), w) for c, w in fp.items() if c != agg.ALL]
    out = summary.get("outcomes_by_control", {}).get(mode, {})
    rows += [_row(OUTCOME_ROWS[k], w) for k, w in out.items() if k in OUTCOME_ROWS]
    if agg.ALL in fp:
        rows.append(_row("all criteria: any criterion failed (the union)", fp[agg.ALL]))
    return (_table(["criterion or outcome", "cases", "probability", "95 % interval (Wilson)"],
                   rows) + _counted(fp))


def _counted(fp: dict) -> str:
    """The line under a probability table: over how many cases, and how the incomplete count."""
    w = fp.get(agg.ALL) or next(iter(fp.values()), None)
    if not w:
        return ""
    short = w.get("incomplete", 0)
    text = f"Every probability is over the {w['n']} case(s) run in this mode"
    if short:
        text += (f"; the {short} incomplete case(s) count as failing reached target and all "
                 "criteria, and as passing the limits they held")
    return f"<p>{text}.</p>"


def _verdict(summary: dict, mode: str) -> str:
    w = summary["by_control"][mode].get(agg.ALL)
    if not w or not w["n"]:
        return f'<div class="verdict">{_e(mode)}: no case ran.</div>'
    o = summary.get("outcomes_by_control", {}).get(mode, {})
    count = {k: o[k]["failed"] for k in OUTCOME_ROWS if k in o}
    safe = w["n"] - w["failed"]
    parts = [f"{n} {k.replace('_', ' ')}" for k, n in count.items() if n]
    more = ""
    if count.get("incomplete"):
        more = (f" {count['incomplete']} case(s) ended before the target was held with every "
                "limit kept, counted as failing: a longer run (simulation.duration_s: auto) "
                "says how they end.")
    return (f'<div class="verdict"><b>{_e(mode)} control:</b> safe in {safe} of {w["n"]} cases'
            + (f" ({', '.join(parts)})" if parts else "")
            + f": probability that any criterion fails {_pct(w['p'])} "
            f"(95 % interval {_pct(w['low'])} – {_pct(w['high'])}).{more}</div>")


def _influence(summary: dict, mode: str, keys) -> str:
    sens = summary["sensitivity_by_control"][mode]
    crits = [c for c, ranked in sens.items() if ranked]
    if not crits:
        return ("<p>No criterion's outcome varied across the cases, so no key can be ranked by "
                "Spearman's rank correlation with failing; the figure ranks them by their "
                "influence on the headline numbers.</p>")
    rows = []
    for k in keys:
        cells = []
        for c in crits:
            s = dict(map(tuple, sens[c])).get(k)
            cells.append("–" if s is None else f"{s:+.2f}")
        rows.append([f"<code>{_e(k)}</code>", *cells])
    return ("<p>Spearman's rank correlation between each key and failing the criterion "
            "(positive: larger values fail more often).</p>"
            + _table(["key", *[c.replace("_", " ") for c in crits]], rows))


def _worst(summary: dict, mode: str, rerun: dict, keys) -> str:
    worst = summary["worst"][mode]
    if not worst:
        return "<p>No case ran.</p>"
    rows = []
    for w in worst:
        vals = "<br>".join(f"{_e(k)} = {_num(w['values'].get(k))}" for k in keys)
        h = w["headline"]
        why = [f"{_e(c)}: {_e(w.get('reasons', {}).get(c, 'failed'))}" for c in w["failed"]]
        failed = (f"<b>{_e(w.get('outcome', '').replace('_', ' '))}</b><br>" if w.get("outcome")
                  else "") + ("<br>".join(why) or "none")
        path = rerun.get(w["case"])
        cmd = (f"<code>flexlift run {_e(path)} --control {_e(mode)}</code>" if path else "–")
        rows.append([_e(w["name"]), vals, f'<span class="{"fail" if w["failed"] else "pass"}">'
                     f"{failed}</span>" + (f"<br>{_e(w['error'])}" if w.get("error") else ""),
                     _num(h.get("max_ascent_velocity_ms")), _num(h.get("max_descent_velocity_ms")),
                     _num(h.get("max_pitch_deg")), _num(h.get("max_utilisation")), cmd])
    return ("<p>Worst first: numerics failed or an invalid scenario, then most criteria failed, "
            "then nearest a limit (ascent and descent speed, pitch, hull stress against the "
            "allowable). Each scenario file reruns its case exactly: it is the case as run, "
            "every default filled in, and <code>flexlift run FILE --control MODE</code> gives "
            "the whole analysis with these numbers.</p>"
            + _table(["case", "values", "failed, and why", "max ascent velocity [m/s]",
                      "max descent velocity [m/s]", "max pitch [deg]", "max utilisation",
                      "rerun"], rows, left=3))


def _failures(summary: dict) -> str:
    fails = summary["failures"]
    if not fails:
        return "<p>None: every case's simulation completed.</p>"
    rows = [[_e(f["name"]), _e(f["status"]), _e(f["message"])] for f in fails[:50]]
    more = f"<p class='meta'>and {len(fails) - 50} more (results.nc lists them all).</p>" if len(fails) > 50 else ""
    return _table(["case", "status", "message"], rows, left=3) + more


def render_report(result, summary: dict, rerun: dict, pngs: dict | None = None) -> str:
    """The HTML page of a finished sweep (``rerun``: case index -> its scenario file;
    ``pngs``: figures drawn already, by :func:`render_figures`; the others are drawn here)."""
    spec = result.spec
    keys = list(spec.keys)
    given = pngs or {}
    makers = {k: f for k, f in figure_makers(result, summary).items() if k not in given}
    pngs = {**given, **render_figures(makers)}
    when = datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC")
    parts = [f"<h1>Sweep of {_e(spec.base.name)}: {summary['cases']:,} cases</h1>",
             f'<p class="meta">flexlift {_e(__version__)}, {when}; base {_e(spec.base_ref)} '
             f"(SHA-256 {spec.base.checksum()[:16]}…), SPEC checksum {spec.checksum()[:16]}…; "
             f"engine {_e(result.engine)}; {summary['completed']} completed, "
             f"{summary['failed'] - summary['lost']} failed, {summary['lost']} lost; "
             f"{result.skipped} found finished, {result.ran} run now in {result.elapsed_s:.1f} s.</p>"]
    if spec.method != "sobol":
        parts += [_verdict(summary, m) for m in spec.controls]
    parts += ["<h2>What varies</h2>", _variations(spec)]
    if spec.fixed:
        parts.append("<p>Fixed for every case: " + ", ".join(
            f"<code>{_e(k)} = {_e(v)}</code>" for k, v in spec.fixed.items()) + ".</p>")
    for m in spec.controls:
        if spec.method == "sobol":
            parts += [f"<h2>Which uncertainty matters: {_e(m)} control</h2>", _sobol(summary, m)]
            continue
        parts += [f"<h2>Probability of failure: {_e(m)} control</h2>", _probabilities(summary, m),
                  "<p class='meta'>A case whose numerics failed, or whose values do not make a "
                  "valid scenario (e.g. a lift plan that cannot be laid out), counts as failing "
                  "every criterion and as failed to run; an incomplete case (every limit held, "
                  "the run ended before the target was held) fails the criteria reached target and "
                  "all criteria and passes the limits it held; lost cases are not counted.</p>",
                  f"<h2>Convergence: {_e(m)} control</h2>", _convergence(summary, m, pngs),
                  f"<h2>Influence of the keys: {_e(m)} control</h2>", _influence(summary, m, keys),
                  _figure(pngs.get(f"tornado:{m}"),
                          f"Spearman rank correlation of each key with the headline numbers ({m} control): "
                          "a tornado of the keys' influence."),
                  f"<h2>Worst cases: {_e(m)} control</h2>", _worst(summary, m, rerun, keys)]
    parts += ["<h2>Distributions of the headline numbers</h2>",
              _figure(pngs.get("cdfs"),
                      "Empirical CDFs over the completed cases; dashed: the limit."),
              "<h2>Failed and lost cases</h2>", _failures(summary)]
    if summary["warnings"]:
        parts += ["<h2>Warnings of the cases</h2>", _table(
            ["warning", "cases"], [[_e(w), str(n)] for w, n in summary["warnings"]])]
    body = "\n".join(p for p in parts if p)
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>flexlift sweep: "
            f"{_e(spec.base.name)}</title><style>{_CSS}</style></head><body>{body}</body></html>\n")
