"""The single-failure study's report: one self-contained HTML page (figures embedded).

The verdict; the phases (from the fault-free run's events) and the representatives; per lift
point, the matrix kind x phase coloured by outcome; the failures the plan does not survive,
ranked, with their reasons and margins; the time histories of the worst three; every case
with its answer and its rerun file.
"""

from __future__ import annotations

import base64
import html

from flexlift.sweep import plots
from flexlift.sweep.contingency.cases import KIND_TEXT, KINDS
from flexlift.sweep.report import _CSS

#: a cell's colour by outcome
COLOUR = {"safe": "#cfe8d5", "incomplete": "#fdf1c7", "not_achieved": "#f9d3a8",
          "unsafe": "#f4b6b0"}
#: what each outcome means in one word, for the matrix's key
WORD = {"safe": "safe", "incomplete": "incomplete", "not_achieved": "not achieved",
        "unsafe": "unsafe"}


def _e(x) -> str:
    return html.escape(str(x))


def _num(v, fmt="{:.3g}", beyond=False) -> str:
    if beyond:  # a number up to the model's validity, then beyond it
        return "beyond validity" if v is None else f"{fmt.format(v)}, then beyond validity"
    return "–" if v is None else fmt.format(v)


def _table(head, rows) -> str:
    th = "".join(f"<th>{_e(h)}</th>" for h in head)
    body = "".join("<tr>" + "".join(f'<td class="l">{c}</td>' if k == 0 else f"<td>{c}</td>"
                                    for k, c in enumerate(r)) + "</tr>" for r in rows)
    return f"<table><thead><tr>{th}</tr></thead><tbody>{body}</tbody></table>"


def _margin(m) -> str:
    if not m:
        return "–"
    extra = f" (+{m['extra_t']:g} t)" if m.get("extra_t") is not None else ""
    return _e(f"{m['text']} {m['scales']}{extra}, {m['runs']} runs")


def _matrices(summary: dict) -> str:
    phases = [p["name"] for p in summary["phases"] if p["time_s"] is not None]
    by_point: dict[str, dict] = {}
    for r in summary["cases"]:
        by_point.setdefault(r["lift_point"] + f" ({r['bag']})", {})[(r["kind"], r["phase"])] = r
    out = []
    for point, cells in by_point.items():
        rows = []
        for kind in KINDS:
            if not any(k == kind for k, _ in cells):
                continue
            row = [_e(KIND_TEXT[kind])]
            for ph in phases:
                r = cells.get((kind, ph))
                o = r["answer"]["outcome"] if r else None
                row.append("–" if r is None else
                           f'<span title="{_e(r["answer"].get("reason", ""))}" style="display:'
                           f'block;background:{COLOUR.get(o, "#fff")}">{_e(WORD.get(o, o))}</span>')
            rows.append(row)
        out.append(f"<h3>{_e(point)}</h3>" + _table(["kind"] + phases, rows))
    key = " ".join(f'<span style="background:{c};padding:0 .4rem">{_e(WORD[o])}</span>'
                   for o, c in COLOUR.items())
    return f'<p class="meta">{key}</p>' + "".join(out)


def _failures(summary: dict) -> str:
    rows = {r["index"]: r for r in summary["cases"]}
    if not summary["failures"]:
        return "<p>None: every single failure at every phase is survived.</p>"
    out = []
    for rank, i in enumerate(summary["failures"], start=1):
        r = rows[i]
        a = r["answer"]
        out.append([str(rank), _e(f"{KIND_TEXT[r['kind']]}: {r['bag']} at {r['phase']} "
                                  f"({r['time_s']:g} s)"), _e(WORD.get(a["outcome"])),
                    _e(a.get("reason", "")), _margin(r.get("margin")),
                    f"<code>{_e(r.get('rerun', ''))}</code>"])
    return _table(["#", "failure", "outcome", "reason", "margin", "rerun file"], out)


def _cases(summary: dict) -> str:
    rows = []
    for r in summary["cases"]:
        a = r["answer"]
        b = {k: a.get(f"{k}_beyond", False) for k in ("up_ms", "down_ms", "pitch_deg",
                                                       "sling_ratio", "utilisation")}
        rows.append([_e(r["case"]), _e(r["bag"]), _e(KIND_TEXT[r["kind"]]), _e(r["phase"]),
                     _e(WORD.get(a["outcome"], a["outcome"])),
                     _num(a.get("up_ms"), beyond=b["up_ms"]),
                     _num(a.get("down_ms"), beyond=b["down_ms"]),
                     _num(a.get("pitch_deg"), beyond=b["pitch_deg"]),
                     _num(a.get("sling_ratio"), beyond=b["sling_ratio"]),
                     _num(a.get("utilisation"), beyond=b["utilisation"]),
                     _num(a.get("breach_s"), "{:.0f} s", a.get("breach_beyond", False)),
                     _num(a.get("resettle_s"), "{:.0f} s", a.get("resettle_beyond", False)), _e(a.get("reason", "")),
                     f"<code>{_e(r.get('rerun', ''))}</code>"])
    return _table(["case", "bag", "kind", "phase", "outcome", "up [m/s]", "down [m/s]",
                   "pitch [deg]", "sling / design", "bending util.", "breach", "resettle",
                   "reason", "rerun file"], rows)


def _histories(summary: dict, histories: dict) -> str:
    if not histories:
        return ""
    rows = {r["index"]: r for r in summary["cases"]}
    fig, axes = plots.new_figure(3, 1, (8.0, 7.5), sharex=False)
    for i, tr in histories.items():
        r = rows[i]
        label = f"{r['case']}: {KIND_TEXT[r['kind']]}, {r['bag']}, {r['phase']}"
        axes[0].plot(tr["time"], tr["height"], label=label)
        axes[1].plot(tr["time"], tr["speed"])
        axes[2].plot(tr["time"], tr["pitch"])
    axes[0].set_ylabel("mean bag height [m]")
    axes[1].set_ylabel("largest |bag speed| [m/s]")
    axes[2].set_ylabel("hull pitch [deg]")
    axes[2].set_xlabel("time [s]")
    axes[0].legend(fontsize=7)
    data = base64.b64encode(plots.png(fig)).decode("ascii")
    return (f'<figure><img alt="time histories" src="data:image/png;base64,{data}">'
            "<figcaption>The worst three cases: mean bag height, largest bag speed and hull "
            "pitch against time.</figcaption></figure>")


def render_report(summary: dict, histories: dict) -> str:
    """The page for ``summary`` (:func:`~flexlift.sweep.contingency.run.run_contingency`) and
    the worst cases' traces ``histories`` ({case index:
    :func:`~flexlift.sweep.contingency.answer.trace`})."""
    tol = summary["tolerant"]
    ph = _table(["phase", "time [s]", "how"], [[_e(p["name"]), _num(p["time_s"], "{:.1f}"),
                                                 _e(p["how"])] for p in summary["phases"]])
    reps = ("Without noise, identical bags at one lift point give the same result: one "
            "representative per lift point and type was run (it stands for the bags listed)."
            if summary["representatives"] else "Every bag was run (noise, or --all).")
    groups = _table(["lift point", "representative", "bags"],
                    [[_e(g["lift_point"]), _e(g["representative"]), _e(", ".join(g["members"]))]
                     for g in summary["groups"]])
    b = summary["baseline"]
    parts = [
        f"<h1>Single failures: {_e(summary['scenario'])} ({_e(summary['control'])} control)</h1>",
        f'<div class="verdict"><span class="{"pass" if tol else "fail"}">'
        f"{_e(summary['verdict'])}</span></div>",
        f'<p class="meta">{summary["n_cases"]} cases on {_e(summary["engine"])}, '
        f"{summary['elapsed_s']:.1f} s; the fault-free run: {_e(b['outcome'])} "
        f"({_e(b['cause'])}).</p>",
        "<h2>Phases (from the fault-free run's events)</h2>", ph,
        "<h2>Bags run</h2>", f"<p>{_e(reps)}</p>", groups,
        "<h2>Kind x phase, per lift point</h2>", _matrices(summary),
        "<h2>Failures not survived (worst first) and their margins</h2>", _failures(summary),
        "<h2>The worst three</h2>", _histories(summary, histories),
        "<h2>Every case</h2>",
        "<p class=\"meta\">Peaks reached after the slope passed limits.slope_validity_deg are "
        "beyond the model's validity; sling / design is the peak sling force over the bag's "
        "full true lift. Each rerun file reproduces its case: <code>flexlift simulate "
        "rerun/case_NNNN.yaml</code>.</p>", _cases(summary)]
    return ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>flexlift "
            f"single failures: {_e(summary['scenario'])}</title><style>{_CSS}</style></head>"
            "<body>" + "\n".join(parts) + "</body></html>")
