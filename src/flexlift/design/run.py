"""``run_design``: the search into an output folder, its answer and its files
(docs/guide/design.md).

The folder is written in place (:func:`flexlift.output.folders.incremental_folder`: a rerun
of the same search continues it): ``evaluations.jsonl`` (the cache, one line per candidate),
then at the end ``summary.json``, ``candidates.csv``, ``plan.yaml`` (the proposal, a scenario
that ``flexlift run``, ``contingency`` and ``sweep --study salvage`` take as it is; absent
when no plan was found), ``pareto.png`` and ``report.html``.
"""

from __future__ import annotations

import csv
import io
import time
from pathlib import Path

from flexlift.design import report
from flexlift.design.cache import Cache
from flexlift.design.search import RUNGS, Options, check_options, run_search
from flexlift.design.space import Space
from flexlift.plumbing.atomic import write_json, write_text

COMMAND = "design"
FILES = ("evaluations.jsonl", "summary.json", "candidates.csv", "plan.yaml", "pareto.png",
         "report.html")


def run_design(scenario, space: Space, options: Options, out, engine=None, progress=None,
               compare: bool = True) -> dict:
    """Search ``space`` for the plan of ``scenario`` into the folder ``out``; returns the
    summary (also ``summary.json``). ``engine``: where contingency and study cases run
    (default local processes, one per core), started once and closed at the end;
    ``compare``: the user's own plan through the same dynamic rungs, for the report."""
    from flexlift.output.folders import incremental_folder
    from flexlift.sweep.executors import make_engine

    check_options(options, space)
    t0 = time.perf_counter()
    identity = options.identity(scenario, space)  # the cache's: the input and the code
    with incremental_folder(out, COMMAND, options.folder_identity(scenario, space)) as inc:
        inc.claim(*FILES)
        engine = engine or (make_engine() if RUNGS.index(options.up_to) >= 2 else None)
        try:
            found = run_search(scenario, space, options, engine, Cache(inc.path, identity),
                               progress)
            own = own_plan(scenario, found["evaluator"], options) if compare else None
        except BaseException:
            if engine is not None:
                engine.close(cancel=True)
            raise
        if engine is not None:
            engine.close()
        summary = summarise(scenario, space, options, found, own, time.perf_counter() - t0)
        _write(inc.path, summary, found, scenario)
        inc.finish()
    return summary


def own_plan(scenario, ev, options: Options) -> dict:
    """The user's plan through every rung (none stops it), for the side-by-side."""
    from flexlift.design import dynamic
    from flexlift.design.statics import static_checks

    out = {"statics": static_checks(scenario, ev.hull, options.tolerant),
           "nominal": dynamic.nominal([scenario], options.batch)[0]}
    from flexlift.loads.liftplan import plan_lift

    out["bags"] = plan_lift(scenario, ev.hull).bag_count
    last = RUNGS.index(options.up_to)
    if last >= 2:
        out["contingency"] = dynamic.contingency(scenario, ev.engine, options.kinds,
                                                 stop=False)
    if last >= 3:
        out["salvage"] = dynamic.salvage(scenario, ev.engine, options.target, options.samples,
                                         options.study_seed, options.block)
    return out


def pareto(rows: list[dict], names) -> list[dict]:
    """The feasible rows no other feasible row dominates in the objectives ``names``."""
    from flexlift.design.search import objective_values

    ok = {r["candidate_key"]: r for r in rows if r["passed"]}
    vals = {k: objective_values(r, names) for k, r in ok.items()}

    def dominated(k):
        a = vals[k]
        return any(all(x <= y for x, y in zip(b, a)) and b != a for b in vals.values())

    front = [r for k, r in ok.items() if not dominated(k)]
    # ties broken by the lower bending utilisation in the design cases
    return sorted(front, key=lambda r: (objective_values(r, names),
                                        (r.get("statics") or {}).get("utilisation") or 0.0))


def summarise(scenario, space, options, found, own, elapsed: float) -> dict:
    rows = found["rows"]
    for r in rows:
        r["candidate_key"] = _key(r)
    ev = found["evaluator"]
    front = pareto(rows, options.objectives)
    best = front[0] if front else None
    from flexlift.scenario.basis import design_basis

    # the factors, limits and their sources the proposal (else the user's plan) was judged by
    basis = design_basis(ev.scenario_of(_candidate(best)) if best else scenario)
    model = best["candidate"]["model"] if best else _closest(rows)["candidate"]["model"]
    reached = {rung: sum(1 for r in rows if RUNGS.index(r["reached"]) >= k)
               for k, rung in enumerate(RUNGS)}
    return {
        "scenario": scenario.name, "found": best is not None,
        "best": _brief(best, space.entries) if best else None,
        "pareto": [_brief(r, space.entries) for r in front],
        "lower_bound": {**ev.bounds[model], "model": model},
        "evaluations": {"candidates": len(rows), "distinct": len({r["candidate_key"]
                                                                  for r in rows}),
                        "reached": reached, "calls": found["calls"],
                        "cache_hits": found["cache_hits"],
                        "cache_stale": found["cache_stale"]},
        "no_plan": None if best else report.no_plan(rows, space, scenario),
        "not_assessed": (None if options.up_to == "salvage" else
                         f"the search stopped at the {options.up_to} rung: what comes after it "
                         "(" + ", ".join(RUNGS[RUNGS.index(options.up_to) + 1:]) + ") was not "
                         "checked; P(unsafe) not assessed"),
        "own_plan": own, "compared": own is not None, "design_basis": basis, "options": {k: (list(v) if isinstance(v, tuple) else v)
                                     for k, v in vars(options).items()},
        "space": {"models": list(space.models), "points": list(space.points),
                  "over": list(space.over), "count": space.count, "modes": list(space.modes),
                  "ascent_speeds_m_s": list(space.ascent_speeds),
                  "breakout_pulls_t": list(space.breakout_pulls),
                  "dump_valve_factors": list(space.dump_valve_factors),
                  "internal": list(space.internal), "per_point_types": space.per_point,
                  "supplies_free_air_m3_min": list(space.supplies),
                  "sequences": list(space.sequences),
                  "span_m": list(space.span_m)},
        # no plan: the candidates that climbed highest, not merely the fewest bags
        "nearby": report.nearby(rows, best) if best else report.climbed(rows, 8),
        "elapsed_s": round(elapsed, 2),
    }


def _candidate(r: dict):
    """The :class:`~flexlift.design.space.Candidate` of a row (a cached one's lists as
    tuples)."""
    from flexlift.design.space import Candidate

    c = dict(r["candidate"])
    if c.get("point_models") is not None:
        c["point_models"] = tuple(c["point_models"])
    return Candidate(**c)


def _key(r: dict) -> str:
    return _candidate(r).key()


def _closest(rows: list[dict]) -> dict:
    """The row that climbed highest (fewest bags among those)."""
    return max(rows, key=lambda r: (RUNGS.index(r["reached"]), r["passed"], -r["bags"]))


def _brief(r: dict, entries: dict) -> dict:
    """The summary of row ``r`` (``entries``: the space's catalogue entries, by model)."""
    c = r.get("contingency") or {}
    s = r.get("salvage") or {}
    cand = _candidate(r)
    models = cand.models()
    lifts = [float(r["lift_t"])] * cand.internal + [
        float(entries[m]["lift_t"]) for m, n in zip(models, r["counts"]) for _ in range(n)]
    st = r.get("statics") or {}
    return {"bags": r["bags"], "types": sorted(set(models), key=models.index),
            "type": r["type"], "lift_t": r["lift_t"],
            # the static margins: the rated lift in all and after losing the largest bag, the
            # largest bending utilisation in the design cases
            "rated_lift_t": round(sum(lifts), 1),
            "rated_lift_after_losing_one_t": round(sum(lifts) - max(lifts), 1),
            "utilisation": st.get("utilisation"),
            "points": [{"x_m": x, "count": n, "model": m} for x, n, m in
                       zip(r.get("points_m", []), r["counts"], models)],
            "internal": cand.internal, "supply_free_air_m3_min": cand.supply_free_air_m3_min,
            "gas_m3": r.get("gas_m3"), "cost": r.get("cost"),
            "mode": r["candidate"]["mode"],
            "ascent_speed_m_s": r["candidate"]["ascent_speed_m_s"],
            "breakout_pull_t": r["candidate"]["breakout_pull_t"],
            "dump_valve_factor": r["candidate"]["dump_valve_factor"],
            "sequence": cand.sequence,
            "reached": r["reached"], "contingency": c.get("counts"),
            "contingency_cases": c.get("cases"), "p_unsafe": s.get("p_unsafe"),
            "salvage_counts": s.get("counts"), "key": r["candidate_key"]}


def _write(folder: Path, summary: dict, found: dict, scenario) -> None:
    rows = found["rows"]
    write_json(folder / "summary.json", summary)
    write_text(folder / "candidates.csv", _csv(rows))
    if summary["best"] is not None:
        best = next(r for r in rows if r["candidate_key"] == summary["best"]["key"])
        plan = found["evaluator"].scenario_of(_candidate(best))
        write_text(folder / "plan.yaml", "# proposed by flexlift design: "
                   f"{best['bags']} x {', '.join(summary['best']['types'])}"
                   + (f" ({best['candidate']['internal']} internal)"
                      if best["candidate"]["internal"] else "") + "\n" + plan.to_yaml())
    report.write(folder, summary, rows)


def _csv(rows: list[dict]) -> str:
    cols = ("trial", "key", "model", "bags", "points", "counts", "internal", "point_models",
            "mode", "ascent_speed_m_s", "breakout_pull_t", "dump_valve_factor",
            "supply_free_air_m3_min", "sequence", "gas_m3", "cost", "reached", "passed",
            "rejected_rung", "rejected_check", "rejected_why")
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(cols)
    for r in rows:
        c, rej = r["candidate"], r.get("rejected") or {}
        w.writerow([r["trial"], r["candidate_key"], c["model"], r["bags"], c["points"],
                    " ".join(map(str, r["counts"])), c.get("internal", 0),
                    " ".join(c.get("point_models") or ()), c["mode"], c["ascent_speed_m_s"],
                    c["breakout_pull_t"], c["dump_valve_factor"],
                    c.get("supply_free_air_m3_min"), c.get("sequence", "own"), r.get("gas_m3"),
                    r.get("cost"), r["reached"], r["passed"], rej.get("rung", ""),
                    rej.get("check", ""), rej.get("why", "")])
    return buf.getvalue()
