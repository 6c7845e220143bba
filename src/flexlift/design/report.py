"""The designer's report (``report.html``) and its figure (``pareto.png``), and the words
for a search that found no plan (docs/guide/design.md).

The report leads with the decision: the proposal beside the user's own plan (bags, single
failures, P(unsafe)), the plan to rig (each lift point's position and bags, the control and
equipment, the static margins), then the lower bound, the Pareto front, why each nearby alternative was
rejected (the rung, the check, the failure and its margin), the design basis the proposal
was checked by, and the evaluations by rung.
"""

from __future__ import annotations

import html
from collections import Counter
from pathlib import Path

from flexlift.plumbing.atomic import write_bytes, write_text

RUNG_TEXT = {"statics": "static checks", "nominal": "nominal ascent",
             "contingency": "single failures", "salvage": "salvage study"}


def nearby(rows: list[dict], best: dict | None, n: int = 8,
           keep_order: bool = False) -> list[dict]:
    """The rejected candidates nearest the proposal (by bags; the fewest when none), or in
    the order given (``keep_order``): each with the rung, the check and why it failed."""
    seen, out = set(), []
    ref = best["bags"] if best else 0
    rejected = [r for r in rows if not r["passed"]]
    for r in (rejected if keep_order else
              sorted(rejected, key=lambda r: (abs(r["bags"] - ref), r["bags"]))):
        if r["candidate_key"] in seen:
            continue
        seen.add(r["candidate_key"])
        rej = r.get("rejected") or {}
        c = r["candidate"]
        out.append({"bags": r["bags"], "model": " + ".join(c.get("point_models") or [c["model"]]),
                    "internal": c.get("internal", 0), "reached": r["reached"],
                    "sequence": c.get("sequence", "own"),
                    "points": r["candidate"]["points"], "mode": r["candidate"]["mode"],
                    "rung": rej.get("rung"), "check": rej.get("check"),
                    "why": rej.get("why", "")})
        if len(out) == n:
            break
    return out


#: the criteria a run's cause names (:func:`flexlift.ascent` outcome text), in its words
CRITERIA = ("ascent velocity", "descent velocity", "bending utilisation", "pitch",
            "surface breach", "resettle", "slope passed")


def climbed(rows: list[dict], n: int = 5) -> list[dict]:
    """The rejected candidates that climbed highest up the ladder (fewest bags first among
    those), in :func:`nearby`'s form: a search without a plan leads with these."""
    from flexlift.design.search import RUNGS

    order = sorted((r for r in rows if not r["passed"]),
                   key=lambda r: (-RUNGS.index(r["reached"]), r["bags"]))
    return nearby(order, None, n, keep_order=True)


def failed_criteria(rows: list[dict]) -> dict:
    """Of the candidates rejected by a dynamic rung, how many broke each criterion: the
    nominal ascent's by the criteria its cause names; the single failures' by the kind and
    phase of the case that stopped the candidate (the first unsafe or incomplete one)."""
    nominal, single = Counter(), Counter()
    for r in rows:
        rej = r.get("rejected") or {}
        if rej.get("rung") == "nominal":
            why = rej.get("why", "")
            for c in CRITERIA:
                if c in why:
                    nominal[c] += 1
        elif rej.get("rung") == "contingency":
            f = (r.get("contingency") or {}).get("first") or {}
            single[f"{f.get('kind')} at {f.get('phase')} ({f.get('outcome')})"] += 1
    return {"nominal": dict(nominal.most_common()), "contingency": dict(single.most_common())}


def no_plan(rows: list[dict], space, scenario=None) -> dict:
    """What no candidate survived, which criteria broke, and what would change it: an option
    the space already searched is named as searched with its values, never asked for again
    (``scenario``: where the dump valve comes from, when it is the scenario's own)."""
    where = Counter((r.get("rejected") or {}).get("rung") for r in rows)
    checks = Counter(f"{(r.get('rejected') or {}).get('rung')}: "
                     f"{(r.get('rejected') or {}).get('check')}" for r in rows)
    broke = failed_criteria(rows)
    hints = []
    if checks and all(k.startswith("statics") for k in checks):
        worst = checks.most_common(1)[0][0]
        if "lift" in worst or "clusters" in worst:
            hints.append("a larger catalogue bag, or a longer attachment span: the bags "
                         "offered cannot carry the required lift on this hull")
        if "strength" in worst:
            hints.append("more lift points, spreading the lift along the hull")
    if where.get("nominal"):
        named = ", ".join(f"{k} {v}" for k, v in broke["nominal"].items()) or "unsafe"
        hint = (f"the nominal ascent was unsafe for all {where['nominal']} candidates that "
                f"reached it (criteria broken, by candidates: {named})")
        if getattr(space, "staged", False) and tuple(space.sequences) == ("own",):
            hint += "; on a staged lift, every bag at once (--sequence own,none)"
        tried, ask = ascent_choices(space, scenario)
        hint += f"; tried: {tried}; the speeds and valves searched did not stop it"
        hint += ("; outside them, against a runaway ascent: " + " or ".join(ask) if ask else
                 "; no slower speed or larger valve is allowed")
        hints.append(hint)
    if where.get("contingency"):
        kinds = ", ".join(f"{k}: {v}" for k, v in broke["contingency"].items())
        hint = (f"a single failure stopped each of the {where['contingency']} candidates that "
                f"reached them ({kinds})")
        if any("(incomplete)" in k for k in broke["contingency"]):
            hint += ("; incomplete: the run ended before the lift finished after the loss (it "
                     "never separated, or its hold was cut short): a larger breakout pull "
                     "(--pulls) or more bags (--over), or a longer simulation.duration_s")
        hint += _searched(space, scenario)
        hints.append(hint)
    if where.get("salvage"):
        tried, ask = ascent_choices(space, scenario, valves=False)
        over = getattr(space, "over", None)
        if getattr(space, "count", None) is not None:
            tried += f", {space.count} bags at each lift point (--count)"
            ask.append(f"more bags at each lift point than {space.count} (--count)")
        elif over is not None:
            tried += f", up to {over[1]} bags over the fewest that lift"
            ask.append(f"more margin than {over[1]} bags over the fewest (e.g. --over "
                       f"{over[0]}..{over[1] + max(2, over[1] // 2)})")
        hints.append(f"the salvage study's P(unsafe) bound stays above the target for all "
                     f"{where['salvage']} candidates that reached it; tried: {tried}"
                     + ("; outside them: " + " or ".join(ask) if ask else ""))
    return {"rejected_at": dict(where), "checks": dict(checks.most_common(8)),
            "criteria": broke,
            "what_would_change_it": hints or ["a wider search (--budget, --over, --points)"],
            "best_candidates": climbed(rows, 5)}


def _limit(name: str, bound: str) -> float:
    """The bound (``ge`` or ``le``) of the scenario's ``control.<name>`` (its schema)."""
    from flexlift.scenario.schema import Control

    return next(getattr(m, bound) for m in Control.model_fields[name].metadata
                if hasattr(m, bound))


def ascent_choices(space, scenario=None, valves: bool = True) -> tuple[str, list[str]]:
    """The planned ascent speeds and dump valves the space searched, as words (``tried``),
    and what lies outside them, each with its option and a value to try (``ask``: a speed
    below the slowest searched, half of it; a valve above the largest, twice it); nothing
    beyond what a scenario allows (the schema's slowest speed, a factor of
    :data:`~flexlift.design.space.DUMP_FACTOR_MAX`)."""
    from flexlift.design.space import DUMP_FACTOR_MAX

    speeds = sorted(set(getattr(space, "ascent_speeds", ()) or ()))
    tried, ask = [], []
    if speeds:
        tried.append(f"planned ascent speed{'s' if len(speeds) > 1 else ''} "
                     + ", ".join(f"{v:g}" for v in speeds) + " m/s")
        slowest = _limit("ascent_speed_m_s", "ge")
        if speeds[0] > slowest:
            ask.append(f"a planned ascent slower than {speeds[0]:g} m/s (e.g. --speeds "
                       f"{max(slowest, float(f'{speeds[0] / 2:.2g}')):g})")
    if not valves:
        return ", ".join(tried), ask
    own = None
    if scenario is not None:
        from flexlift.scenario.valves import purge_given

        if purge_given(scenario):
            own = float(scenario.gas.purge_rate_max_m3_s)
    dumps = sorted(set(getattr(space, "dump_valve_factors", (1.0,)) or (1.0,)))
    if own is not None:  # it replaces every catalogue valve: a factor is refused
        tried.append(f"the scenario's purge valve, {own:g} m3/s (gas.purge_rate_max_m3_s)")
        ask.append(f"a larger gas.purge_rate_max_m3_s than {own:g} m3/s")
    else:
        tried.append(f"dump valve{'s' if len(dumps) > 1 else ''} "
                     + ", ".join(f"{f:g}" for f in dumps) + " x the catalogue bag's")
        if dumps[-1] < DUMP_FACTOR_MAX:
            ask.append(f"a dump valve larger than {dumps[-1]:g} x (e.g. --dump-valve "
                       f"{min(DUMP_FACTOR_MAX, 2 * dumps[-1]):g})")
    return " and ".join(tried), ask


def _searched(space, scenario=None) -> str:
    """What the space left fixed (each one a change to try: its option) and what it already
    varied without a plan (not to be asked for again)."""
    untried, tried = [], []
    models = tuple(getattr(space, "models", ()))
    if len(models) == 1:
        untried.append(f"another bag than {models[0]} (--bags)")
    elif models:
        tried.append(f"{len(models)} catalogue bags")
    supplies = tuple(getattr(space, "supplies", (None,)))
    (tried if len(supplies) > 1 else untried).append(
        "compressor supplies " + ", ".join("auto" if v is None else f"{v:g}" for v in supplies)
        if len(supplies) > 1 else "a second or larger supply (--supply)")
    dump = tuple(getattr(space, "dump_valve_factors", (1.0,)))
    from flexlift.scenario.valves import purge_given

    if scenario is not None and purge_given(scenario):  # --dump-valve is refused then
        untried.append("a larger purge valve (gas.purge_rate_max_m3_s)")
    elif max(dump) > 1.0:
        tried.append(f"dump valves up to {max(dump):g} x")
    else:
        untried.append("a larger dump valve (--dump-valve)")
    for attr, opt, what in (("modes", "--modes", "control modes"),
                            ("breakout_pulls", "--pulls", "breakout pulls"),
                            ("ascent_speeds", "--speeds", "planned ascent speeds")):
        vals = tuple(getattr(space, attr, ()))
        if len(vals) > 1:
            tried.append(f"{what} " + ", ".join("auto" if v is None else f"{v}" for v in vals))
        elif vals:
            untried.append(f"other {what} ({opt})")
    over = getattr(space, "over", None)
    if over is not None:
        untried.append(f"more bags than the fewest that lift + {over[1]} (--over)")
    out = "; not searched: " + ", ".join(untried) if untried else ""
    return out + ("; searched without a plan: " + ", ".join(tried) if tried else "")


def _figure(summary: dict, rows: list[dict]) -> bytes:
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=100)
    for rung, marker in (("statics", "x"), ("nominal", "v"), ("contingency", "s"),
                         ("salvage", "o")):
        pts = [(r["bags"], r.get("gas_m3") or 0) for r in rows
               if not r["passed"] and (r.get("rejected") or {}).get("rung") == rung]
        if pts:
            ax.scatter(*zip(*pts), marker=marker, alpha=0.5,
                       label=f"rejected: {RUNG_TEXT[rung]}")
    front = [(p["bags"], p["gas_m3"] or 0) for p in summary["pareto"]]
    if front:
        ax.plot(*zip(*front), "k-o", label="Pareto front (feasible)")
    lb = summary["lower_bound"]
    ax.axvline(lb["n_minus_1"], color="grey", ls="--", label="N-1 lower bound")
    ax.set_xlabel("bags")
    ax.set_ylabel("gas, free air [m3]")
    ax.legend(fontsize=7)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return buf.getvalue()


def _row(cells, head=False) -> str:
    tag = "th" if head else "td"
    return "<tr>" + "".join(f"<{tag}>{html.escape(str(c))}</{tag}>" for c in cells) + "</tr>"


def _p(p: dict | None) -> str:
    """P(unsafe) and its 95 % interval in per cent, to two decimals (a bound of 0.95 % is
    not shown as the 1 % target it meets)."""
    if not p or p.get("p") is None:
        return "not run"
    return (f"{100 * p['p']:.2f} % (95 %: {100 * p['low']:.2f}-{100 * p['high']:.2f} %, "
            f"n = {p['n']})")


def _counts(c: dict | None) -> str:
    if not c:
        return "not run"
    return ", ".join(f"{v} {k.replace('_', ' ')}" for k, v in c.items() if v)


def _supply(summary: dict) -> str:
    """The scenario's own gas supply in the words of the design basis (per bag, and what it
    assumes), so that a proposal of many bags shows what it takes for granted."""
    row = next((r for r in summary.get("design_basis") or []
                if r["item"].startswith("gas supply")), None)
    if row is None:
        return "the scenario's"
    note = f"; {row['note']}" if row.get("note") else ""
    return f"the scenario's: {row['value']}{note}, for each of the {summary['best']['bags']} bags"


def _decision(summary: dict) -> str:
    b, lb = summary["best"], summary["lower_bound"]
    if b is None:
        return ("<p><b>No plan found</b> in the space searched: every candidate failed a "
                "check (below: where, and what would change it).</p>")
    inner = f" ({b['internal']} of them internal, in the tanks)" if b.get("internal") else ""
    return (f"<p><b>Rig {b['bags']} x {html.escape(' + '.join(b['types']))}</b>{inner} at "
            f"{len(b['points'])} lift points ({html.escape(b['mode'])} control, {b['ascent_speed_m_s']:g} m/s): "
            f"the least found that passed every check up to the {RUNG_TEXT[b['reached']]}; "
            f"{b['bags'] / lb['n_minus_1']:.2f} x the N-1 lower bound of {lb['n_minus_1']} "
            "bags.</p>" + (f"<p><b>Not assessed:</b> {html.escape(summary['not_assessed'])}."
                           "</p>" if summary.get("not_assessed") else ""))


def _rigging(summary: dict) -> str:
    """The proposal as a salvor rigs it: each lift point's position, bags and model, the
    internal bags, the control and equipment choices, and the static margins."""
    b, lb = summary["best"], summary["lower_bound"]
    if b is None:
        return ""
    rows = [_row(["lift point", "x [m] from aft", "bags", "catalogue bag"], True)]
    rows += [_row([f"p{j + 1}", f"{p['x_m']:.2f}", p["count"], p["model"]])
             for j, p in enumerate(b["points"])]
    if b.get("internal"):
        rows.append(_row(["internal", "in the ballast tanks", b["internal"], b["types"][0]]))
    supply = b.get("supply_free_air_m3_min")
    pull = b.get("breakout_pull_t")
    items = [("control mode", b["mode"]),
             ("planned ascent speed", f"{b['ascent_speed_m_s']:g} m/s"),
             ("breakout pull", "the default share" if pull is None else f"{pull:g} t"),
             ("dump valve", f"{b['dump_valve_factor']:g} x the catalogue bag's"),
             ("compressor supply", _supply(summary) if supply is None
              else f"{supply:g} m3/min free air, shared by the bags"),
             ("staging", {"own": "the scenario's own", "none": "every bag at once"}.get(
                 b.get("sequence") or "own", b.get("sequence")))]
    margins = []
    if b.get("rated_lift_t") is not None:
        req = lb["required_lift_t"]
        margins.append(f"rated lift {b['rated_lift_t']:,.0f} t against the required "
                       f"{req:,.0f} t ({b['rated_lift_t'] / req:.3f} x); after losing the "
                       f"largest bag {b['rated_lift_after_losing_one_t']:,.0f} t "
                       f"({b['rated_lift_after_losing_one_t'] / req:.3f} x)")
    if b.get("utilisation") is not None:
        margins.append(f"largest hull girder bending utilisation in the design cases "
                       f"{b['utilisation']:.2f} (at most 1)")
    if b.get("contingency_cases"):
        margins.append(f"single failures: {_counts(b['contingency'])} of "
                       f"{b['contingency_cases']} cases")
    if b.get("salvage_counts"):
        margins.append("salvage study: " + _counts(b["salvage_counts"]))
    return ("<h2>The plan to rig</h2><p>As written to plan.yaml (the scenario every command "
            "takes unchanged).</p><table>" + "".join(rows) + "</table><ul>"
            + "".join(f"<li>{html.escape(k)}: {html.escape(str(v))}</li>" for k, v in items)
            + "</ul><p>Margins:</p><ul>"
            + "".join(f"<li>{html.escape(m)}</li>" for m in margins) + "</ul>")


def _basis(summary: dict) -> str:
    rows = summary.get("design_basis") or []
    if not rows:
        return ""
    judged = "the proposal" if summary["best"] else "your plan"
    return (f"<h2>Design basis</h2><p>The factors, limits and their sources {judged} was "
            "checked by.</p><table>" + _row(["item", "value", "source", "note"], True)
            + "".join(_row([r["item"], r["value"], r["source"], r.get("note", "")])
                      for r in rows) + "</table>")


def _own_statics(own: dict) -> str:
    st = own.get("statics") or {}
    if st.get("passed", True):
        return "passed"
    return f"failed: {st.get('check')} ({st.get('why', '')})"


def _side_by_side(summary: dict) -> str:
    own, b = summary.get("own_plan"), summary["best"]
    if own is None:
        head = "your plan (not run: --no-compare)"
    else:
        head = "your plan"
    rows = [_row(["", head, "proposal"], True)]
    o = own or {}
    rows.append(_row(["bags", o.get("bags", "-"), b["bags"] if b else "-"]))
    rows.append(_row(["static checks", _own_statics(own) if own else "-",
                      "passed" if b else "-"]))
    rows.append(_row(["nominal ascent", (o.get("nominal") or {}).get("outcome", "-"),
                      "safe" if b else "-"]))
    rows.append(_row(["single failures", _counts((o.get("contingency") or {}).get("counts")),
                      _counts(b["contingency"]) if b else "-"]))
    rows.append(_row(["P(unsafe), salvage study", _p((o.get("salvage") or {}).get("p_unsafe")),
                      _p(b["p_unsafe"]) if b else "-"]))
    return "<table>" + "".join(rows) + "</table>"


def write(folder: Path, summary: dict, rows: list[dict]) -> None:
    """``pareto.png`` and ``report.html`` into ``folder``."""
    write_bytes(folder / "pareto.png", _figure(summary, rows))
    lb, ev = summary["lower_bound"], summary["evaluations"]
    parts = [f"<h1>flexlift design: {html.escape(summary['scenario'])}</h1>",
             _decision(summary), _side_by_side(summary), _rigging(summary),
             f"<h2>Lower bound</h2><p>{html.escape(lb['model'])}: the required "
             f"{lb['required_lift_t']:,.0f} t needs N = {lb['n']} bags; still lifting after "
             f"losing any one, N-1 = {lb['n_minus_1']}.</p>",
             "<h2>Pareto front</h2><img src='pareto.png' alt='bags and gas of every "
             "candidate'>",
             "<table>" + _row(["bags", "model", "gas m3", "cost", "P(unsafe)"], True)
             + "".join(_row([p["bags"], " + ".join(p["types"]),
                             "-" if p["gas_m3"] is None else f"{p['gas_m3']:,.0f}",
                             "-" if p["cost"] is None else f"{p['cost']:,.0f}",
                             _p(p["p_unsafe"])]) for p in summary["pareto"]) + "</table>",
             "<h2>" + ("Why the nearby alternatives were rejected" if summary["best"] else
                       "The candidates that climbed highest, and why each was rejected")
             + "</h2><table>"
             + _row(["bags", "model", "points", "internal", "rung", "check", "why"], True)
             + "".join(_row([n["bags"], n["model"], n["points"], n.get("internal", 0),
                             RUNG_TEXT.get(n["rung"], ""), n["check"], n["why"]])
                       for n in summary["nearby"]) + "</table>"]
    if summary["no_plan"]:
        np_ = summary["no_plan"]
        crit = np_.get("criteria") or {}
        broke = "".join(f"<li>{html.escape(RUNG_TEXT[k])}: " + html.escape(", ".join(
            f"{c} {n}" for c, n in v.items())) + "</li>" for k, v in crit.items() if v)
        parts.append("<h2>No plan: what would change it</h2><ul>" + "".join(
            f"<li>{html.escape(h)}</li>" for h in np_["what_would_change_it"]) + "</ul>"
            + (f"<p>What broke, by candidates:</p><ul>{broke}</ul>" if broke else ""))
    parts.append(_basis(summary))
    parts.append(f"<h2>Evaluations</h2><p>{ev['candidates']} candidates ({ev['distinct']} "
                 "distinct); reached each rung: " + ", ".join(
                     f"{RUNG_TEXT[k]} {v}" for k, v in ev["reached"].items())
                 + f"; answered from the cache: {ev['cache_hits']}"
                 + (f" (its {ev['cache_stale']} evaluations by another flexlift code "
                    "answered none: re-run)" if ev.get("cache_stale") else "")
                 + f"; {summary['elapsed_s']:.0f} s.</p>")
    write_text(folder / "report.html", "<!doctype html><html><head><meta charset='utf-8'>"
               "<title>flexlift design</title></head><body>" + "\n".join(parts)
               + "</body></html>\n")
