"""``run_contingency``: every single failure of a plan at every phase, on the sweep engine.

1. the fault-free run (in this process): its outcome, its events, the phases
   (:mod:`.phases`), and the time of one plain ascent;
2. the cases (:mod:`.cases`), counted and refused beyond the limits before anything runs;
3. the cases as a grid sweep of ``faults:`` (one fault per case) on any engine of
   :mod:`flexlift.sweep.executors`, into a resumable sweep folder
   (:class:`~flexlift.sweep.store.SweepFolder`): a rerun skips the finished cases;
4. the margin of each failing case (:mod:`.margin`), in rounds of one run per unresolved
   case (the rounds in parallel over the cases), kept in the same folder and resumed alike;
5. ``contingency.json`` (everything), ``report.html`` (:mod:`.report`) and
   ``rerun/case_NNNN.yaml`` (each case's scenario: ``flexlift simulate`` or ``flexlift run``
   on it reproduces the case).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from flexlift import __version__
from flexlift.errors import InputError
from flexlift.sweep import aggregate as agg
from flexlift.sweep.cases import Case, case_name
from flexlift.sweep.contingency import margin as mg
from flexlift.sweep.contingency.answer import HEADLINE, run_fault_case, take_traces, warm_plant
from flexlift.sweep.contingency.cases import KINDS, check_kinds, make_cases, noisy
from flexlift.sweep.contingency.phases import PHASES, find_phases
from flexlift.sweep.spec import SweepSpec
from flexlift.sweep.store import SweepFolder

#: the most cases of one study (split it by --kinds or --phases beyond)
MAX_CASES = 20_000
#: the answers that count as surviving a failure
SURVIVED = ("safe", "incomplete")


@dataclass
class ContingencyResult:
    """A finished study: the JSON summary (``summary``), where it is, and how long it took."""

    summary: dict
    out: Path
    records: dict = field(default_factory=dict)

    @property
    def tolerant(self) -> bool | None:
        """True: single-failure tolerant; False: not; None: no verdict (no case ran, a case or
        the fault-free run ended incomplete)."""
        return self.summary["tolerant"]


def plan_study(scenario, mode: str | None = None, phases=PHASES, times=(), kinds=None,
               all_bags: bool = False, workers: int = 1, yes: bool = False):
    """The fault-free run, its phases and the cases (nothing else runs): ``(baseline result,
    phases, cases, groups, representatives?, plain ascent time [s])``; an unknown kind, a kind
    the plan has no part for, a time outside the run, or too many cases is one line."""
    from flexlift.ascent import simulate
    from flexlift.scenario.cost import MAX_SECONDS, estimate
    from flexlift.sweep.plants import plant_for

    mode = mode or scenario.control.mode
    plant = plant_for(scenario, mode)
    kinds = check_kinds(KINDS if kinds is None else kinds, plant)
    if not phases and not times:
        raise InputError("--phases", "", f"name at least one phase: {', '.join(PHASES)} or a "
                         "time in seconds")
    t0 = time.perf_counter()
    base = simulate(scenario, control=mode, plant=plant)
    plain_s = time.perf_counter() - t0
    found = find_phases(base.dataset, base.events, scenario, phases, times)
    every = all_bags or noisy(scenario)
    cases, groups = make_cases(plant, found, kinds, every)
    n = len(cases)
    per = estimate(scenario).ascent_s
    total = n * per / max(1, workers)
    if n > MAX_CASES or (total > MAX_SECONDS and not yes):
        what = f"{n:,} cases" + (" (--all: every bag)" if all_bags else "")
        raise InputError.from_line(
            f"{what}, about {total / 60:,.0f} min on {workers} worker(s); at most "
            f"{MAX_CASES:,} cases, and {MAX_SECONDS / 60:.0f} min without --yes: "
            + ("give --yes to run it, or " if n <= MAX_CASES else "")
            + ("drop --all (one representative per lift point), or " if all_bags else "")
            + "choose fewer --kinds or --phases")
    return base, found, cases, groups, not every, plain_s


def study_spec(scenario, mode: str, cases, source: str) -> SweepSpec:
    """The grid sweep of the cases' faults (its checksum names the folder's cases)."""
    base = scenario.with_changes(**{"control.mode": mode, "faults": []})
    grid = {"faults": tuple([c.fault()] for c in cases)}
    return SweepSpec(source=source, base=base, base_ref=scenario.name, controls=(mode,),
                     keep="summary", fixed={}, method="grid", grid=grid, distributions={},
                     samples=None, seed=None, worst=3)


def run_contingency(scenario, out, mode: str | None = None, phases=PHASES, times=(),
                    kinds=None, all_bags: bool = False, engine=None, progress=None,
                    margins: bool = True, yes: bool = False, announce=None) -> ContingencyResult:
    """Run (or resume) the single-failure study of ``scenario`` into the folder ``out``.

    Parameters
    ----------
    scenario : Scenario
        The plan (its own ``faults:`` are replaced by each case's one).
    out : str or path-like
        The output folder (resumable; a folder of another study is refused).
    mode : str, optional
        The control mode (default the scenario's).
    phases, times : the named phases (:data:`~.phases.PHASES`) and user times [s].
    kinds : the failure kinds (default all that apply, :data:`~.cases.KINDS`).
    all_bags : run every bag, not one representative per lift point and type.
    engine : an engine of :mod:`flexlift.sweep.executors` (default: local processes); closed
        at the end.
    progress : ``progress(done, total, failed)``.
    margins : bisect the margin of every failing case (:mod:`.margin`).
    announce : ``announce(n_cases, text)`` before the cases run (the CLI prints the count).

    Returns
    -------
    ContingencyResult
        ``summary`` (also ``contingency.json``): the verdict, the phases, every case's answer
        and the failures ranked with their margins.
    """
    from flexlift.sweep.executors import make_engine
    from flexlift.sweep.run import _execute

    t0 = time.perf_counter()
    mode = mode or scenario.control.mode
    scenario = scenario.with_changes(faults=[])
    workers = getattr(engine, "workers", 1) if engine is not None else 1
    records: dict = {}
    try:
        if workers > 1:  # the workers start (and build the plant) during the fault-free run
            _warm(engine, scenario, mode)
        base, found, cases, groups, reps, plain_s = plan_study(
            scenario, mode, phases, times, kinds, all_bags, workers, yes)
        if announce is not None:
            announce(len(cases), f"{len(cases)} cases: {len({c.bag for c in cases})} bags"
                     + (" (one representative per lift point and type)" if reps
                        else " (every bag)")
                     + f" x {len({c.kind for c in cases})} kinds x "
                     f"{len({c.phase for c in cases})} phases")
        spec = study_spec(scenario, mode, cases, f"contingency of {scenario.name}")
        names = {c.index: case_name(spec, c.index) for c in cases}
        worst = Worst(WORST, mode, list(base.criteria), agg.limits_of(scenario))
        with SweepFolder.open(out, spec, "contingency") as folder:
            records = folder.finished(names)
            for i, r in records.items():  # resumed: their traces are run again if drawn
                worst.offer(i, _answer(r, mode), {})
            todo = [Case(c.index, {"faults": [c.fault()]}) for c in submission_order(cases)
                    if c.index not in records]
            if progress is not None:
                progress(len(records), len(cases), 0)
            if todo and engine is None:
                engine = make_engine()
            if todo:
                _import_meanwhile()
                _execute(engine, spec, todo, names, folder, records, folder.inc.run_id,
                         progress, fn=run_fault_case,
                         aside=lambda i, r: worst.offer(i, _answer(r, mode), take_traces(r)))
            answers = {c.index: _answer(records[c.index], mode) for c in cases}
            margin = {}
            if margins:
                margin, engine = _margins(engine, spec, cases, answers, folder, scenario, mode)
            summary = _summary(scenario, mode, base, found, cases, names, groups, reps,
                               answers, margin, records, plain_s, time.perf_counter() - t0,
                               getattr(engine, "name", "none"), folder.path)
            _write(folder, summary, spec, cases, names, records, worst)
            folder.finish()
    except BaseException:
        if engine is not None:
            engine.close(cancel=True)
        raise
    if engine is not None:
        engine.close()
    return ContingencyResult(summary, Path(out), records)


def _warm(engine, scenario, mode: str) -> None:
    """One :func:`~.answer.warm_plant` per worker of ``engine``, not waited for: the pool's
    workers start, and build the cases' plant, while this process runs the fault-free run.
    Submitted from a background thread: a local pool's first submission waits until its
    fork server has loaded the compiled loop (:mod:`flexlift.sweep.warm`)."""
    import threading

    base = scenario.with_changes(**{"control.mode": mode, "faults": []})

    def submit():
        try:
            for _ in range(int(getattr(engine, "workers", 1))):
                engine.submit(warm_plant, base, mode)
        except Exception:  # the cases' own submissions start the workers, or say why not
            pass

    threading.Thread(target=submit, name="flexlift-warm", daemon=True).start()


#: the kinds whose cases cost the most (a lost bag or sling can resettle the hull and then run
#: to the end at every step), submitted first so that no long case is left for the end
COSTLY = ("bag_rupture", "sling_break")


def submission_order(cases: list) -> list:
    """The cases in the order they are submitted: the :data:`COSTLY` kinds first, each part
    in case order (the order of the results is the cases', whatever this is)."""
    return sorted(cases, key=lambda c: c.kind not in COSTLY)


#: what the results need and the coordinator imports while the workers run the cases
TAIL_MODULES = ("flexlift.sweep.contingency.report", "matplotlib.pyplot",
                "flexlift.plumbing.atomic")


def _import_meanwhile() -> None:
    """Import :data:`TAIL_MODULES` in a background thread while the workers run the cases."""
    import importlib
    import threading

    def load():
        for name in TAIL_MODULES:
            try:
                importlib.import_module(name)
            except Exception:  # imported again where needed, and any error reported there
                pass

    threading.Thread(target=load, name="flexlift-import", daemon=True).start()


def _width(n: int) -> int:
    """Digits of the margin runs' case names (their indices follow the ``n`` cases')."""
    return max(4, len(str(max(n * (1 + mg.MAX_RUNS), 1))))


def _answer(record: dict, mode: str) -> dict:
    res = record.get("results", {}).get(mode)
    if not res:
        return {"outcome": "unsafe", "reason": record.get("error") or "the case did not run"}
    return {**res.get("answer", {}), "criteria": res.get("criteria", {}),
            "headline": res.get("headline", {}), "status": res.get("status")}


def _margins(engine, spec, cases, answers, folder, scenario, mode):
    """Bisect the margin of every failing case, one run per unresolved case per round."""
    from flexlift.sweep.executors import make_engine
    from flexlift.sweep.plants import plant_for
    from flexlift.sweep.run import _execute

    rho = scenario.environment.seawater_density_kg_m3
    plant = plant_for(scenario, mode)
    cap_t = dict(zip(plant.names, plant.bags.capacity * rho / 1000.0))  # true capacity [t]
    pinned = mg.pinned_bags(spec.base)

    def unit(c):  # the capacity [t] the scale multiplies: the survivors' (every bag's)
        return float(sum(cap_t.values()) - (cap_t.get(c.bag, 0.0) if pinned else 0.0))
    width = _width(len(cases))
    search = {c.index: mg.Bisection(mg.CAP[mg.scaled(c.kind)],
                                    unit(c) if mg.scaled(c.kind) == "capacity" else 0.0)
              for c in cases if answers[c.index]["outcome"] not in SURVIVED}
    by_index = {c.index: c for c in cases}
    n = len(cases)
    while True:
        asks = {i: b.next_scale() for i, b in search.items()}
        asks = {i: s for i, s in asks.items() if s is not None}
        if not asks:
            break
        runs, names = {}, {}
        for i, s in asks.items():
            c = by_index[i]
            idx = n + i * mg.MAX_RUNS + len(search[i].runs)
            values = {"faults": [c.fault()], **mg.scale_changes(mg.scaled(c.kind), s,
                                                                 spec.base, c.bag, pinned)}
            runs[idx] = (i, s, Case(idx, values))
            names[idx] = f"case_{idx:0{width}d}"
        done = {k: r for k, r in folder.finished(names).items()
                if r.get("values", {}) == runs[k][2].values}
        todo = [case for k, (_, _, case) in runs.items() if k not in done]
        if todo:
            engine = engine or make_engine()
            _execute(engine, spec, todo, names, folder, done, folder.inc.run_id, None,
                     fn=run_fault_case, aside=lambda i, r: take_traces(r))
        for k, (i, s, _) in runs.items():
            search[i].tell(s, _answer(done[k], mode)["outcome"] in SURVIVED)
    out = {}
    for i, b in search.items():
        r = b.result()
        what = mg.scaled(by_index[i].kind)
        r["scales"] = ("the dump valves' capacity" if what != "capacity"
                       else "every bag's true gas capacity" if pinned is None
                       else "the surviving bags' true gas capacity")
        if what == "capacity" and r["scale"] is not None:
            r["extra_t"] = round((r["scale"] - 1.0) * unit(by_index[i]), 1)
        out[i] = r
    return out, engine


def severity(a: dict, criteria: list, limits: dict) -> tuple:
    """The sweep's severity (:func:`~flexlift.sweep.aggregate.severity`, larger is worse) of
    a case's answer ``a``; a case beyond the model's validity by its peaks up to then."""
    h = a.get("headline", {})
    if a.get("validity_end_s") is not None:
        h = {**h, **{name: a.get(k) for k, name in HEADLINE.items()}}
    res = {"status": a.get("status") or "completed", "outcome": a["outcome"],
           "criteria": a.get("criteria", {}), "headline": h}
    return agg.severity(res, criteria, limits)


def _summary(scenario, mode, base, found, cases, names, groups, reps, answers, margin,
             records, plain_s, elapsed, engine, out) -> dict:
    limits = agg.limits_of(scenario)
    criteria = list(base.criteria)
    rows = []
    for c in cases:
        a = answers[c.index]
        row = {**c.as_dict(), "case": names[c.index],
               "answer": {k: v for k, v in a.items() if k not in ("criteria", "headline")},
               "margin": margin.get(c.index)}
        rows.append(row)
    fails = [r for r in rows if r["answer"]["outcome"] not in SURVIVED]
    fails.sort(key=lambda r: severity(answers[r["index"]], criteria, limits), reverse=True)
    bo = base.outcome
    short = sum(r["answer"]["outcome"] == "incomplete" for r in rows)
    tolerant: bool | None = False
    if bo.get("kind") == "incomplete":  # not a completed lift: nothing to set failures against
        tolerant = None
        verdict = (f"no verdict: the fault-free run is itself incomplete ({bo.get('cause')}), "
                   "so it is no baseline for its failures")
    elif bo.get("kind") != "safe":
        verdict = f"the fault-free lift is itself {bo.get('kind')}: {bo.get('cause')}"
    elif fails:
        verdict = (f"not single-failure tolerant: {len(fails)} of {len(cases)} single failures "
                   "are not survived")
    elif not rows:
        tolerant = None
        verdict = "no verdict: no case ran (no phase was reached with a kind the plan has)"
    elif short:
        tolerant = None
        verdict = (f"no verdict: {short} of {len(rows)} cases ended before the target was held "
                   "(incomplete); simulation.duration_s: auto runs them until they end")
    else:
        tolerant = True
        verdict = "single-failure tolerant"
    return {
        "flexlift": __version__, "scenario": scenario.name, "control": mode,
        "verdict": verdict, "tolerant": tolerant,
        "baseline": {"outcome": bo.get("kind"), "cause": bo.get("cause"),
                     "headline": dict(base.headline), "plain_ascent_s": round(plain_s, 3)},
        "phases": [p.as_dict() for p in found],
        "representatives": reps,
        "groups": [{"lift_point": g.lift_point, "members": list(g.members),
                    "representative": g.representative} for g in groups],
        "cases": rows, "failures": [r["index"] for r in fails],
        "counts": {o: sum(r["answer"]["outcome"] == o for r in rows)
                   for o in ("safe", "unsafe", "not_achieved", "incomplete")},
        "n_cases": len(cases), "engine": engine, "elapsed_s": round(elapsed, 3),
        "out": str(out),
    }


def _write(folder, summary, spec, cases, names, records, worst=None) -> None:
    from flexlift.plumbing.atomic import write_json, write_text
    from flexlift.sweep.cases import changes
    from flexlift.sweep.contingency.report import render_report

    reruns = {c.index: f"rerun/{names[c.index]}.yaml" for c in cases}
    folder.claim("contingency.json", "report.html", "rerun", *reruns.values())
    base = spec.base
    for c in cases:
        text = records.get(c.index, {}).get("scenario_yaml")  # the case's own, as it ran
        if text is None:
            text = base.with_changes(**changes(spec, Case(c.index, {"faults": [c.fault()]}))
                                     ).to_yaml()
        write_text(folder.path / reruns[c.index], text)
    for row in summary["cases"]:
        row["rerun"] = reruns[row["index"]]
    write_json(folder.path / "contingency.json", summary)
    kept = worst.traces() if worst is not None else {}
    write_text(folder.path / "report.html", render_report(summary, _histories(summary, base,
                                                                              kept)))


#: the cases whose time histories the report draws
WORST = 3


def worst_cases(summary: dict, n: int = WORST) -> list[int]:
    """The indices of the ``n`` cases whose histories the report draws, worst first: the
    failures by severity (as ``summary["failures"]``), then the cases with the largest upward
    speed (ties in case order)."""
    rows = {r["index"]: r for r in summary["cases"]}
    order = list(summary["failures"])
    rest = sorted((i for i in rows if i not in order),
                  key=lambda i: -(rows[i]["answer"].get("up_ms") or 0.0))
    return (order + rest)[:n]


class Worst:
    """The traces (:func:`~.answer.trace`) of the cases that are the ``n`` worst so far, as
    the workers return them: the report draws the worst cases' traces as their workers ran
    them, without running them again. :meth:`offer` every case once (its answer, and its
    traces or ``{}``); the order is :func:`worst_cases`'s (larger :func:`rank` is worse)."""

    def __init__(self, n: int, mode: str, criteria: list, limits: dict):
        self.n, self.mode, self.criteria, self.limits = n, mode, criteria, limits
        self.kept: list[tuple] = []  # (rank, index, traces or None), worst first

    def rank(self, index: int, answer: dict) -> tuple:
        """The sort key of a case (larger is worse): a failure by its severity, then a
        survived case by its upward speed; the earlier case first among equals."""
        if answer["outcome"] not in SURVIVED:
            return (1, severity(answer, self.criteria, self.limits), -index)
        return (0, answer.get("up_ms") or 0.0, -index)

    def offer(self, index: int, answer: dict, traces: dict) -> None:
        self.kept.append((self.rank(index, answer), index, traces.get(self.mode)))
        self.kept.sort(key=lambda e: e[0], reverse=True)
        del self.kept[self.n:]

    def traces(self) -> dict:
        """{case index: traces} of the kept cases that have them."""
        return {i: tr for _, i, tr in self.kept if tr is not None}


def _histories(summary: dict, base, kept: dict | None = None) -> dict:
    """The traces of the worst :data:`WORST` cases (:func:`worst_cases`): those the workers
    returned (``kept``), else (a case resumed from the folder) run again here as the workers
    ran it (stopped once beyond the model's validity): ``{case index: traces}``."""
    from flexlift.errors import SimulationError
    from flexlift.sweep.contingency.answer import trace

    kept = kept or {}
    rows = {r["index"]: r for r in summary["cases"]}
    out = {}
    for i in worst_cases(summary):
        if i in kept:
            out[i] = kept[i]
            continue
        from flexlift.ascent import simulate

        try:
            out[i] = trace(simulate(base.with_changes(faults=[rows[i]["fault"]]),
                                    control=summary["control"], stop_beyond=True).dataset)
        except SimulationError as exc:
            if exc.partial is not None:
                out[i] = trace(exc.partial.dataset)
    return out
