"""The dynamic rungs of the ladder (docs/theory/design.md#ladder): the nominal ascent, every
single failure, and the salvage study, each the code a user's own command runs.

- nominal: the candidates of a generation that passed their statics, prepared as
  :func:`flexlift.ascent.simulate` prepares a run (:func:`flexlift.ascent.loop.prepare`, on
  the plant the statics built) and advanced together in one compiled call per chunk
  (:func:`flexlift.ascent.batch.run_batch`); the outcome must be ``safe``;
- contingency: the cases of ``flexlift contingency`` (:func:`~flexlift.sweep.contingency.run.
  plan_study`: one representative bag per lift point, every kind, every phase), run on the
  search's one engine by the sweep's own loop; no case may be ``unsafe`` or ``incomplete``
  (``not_achieved`` is allowed and counted); the first that is stops the candidate;
- salvage: the cases of ``flexlift sweep --study salvage`` in blocks; after each block the
  95 % Wilson interval of P(unsafe) over the cases with an outcome: met once its upper bound
  is at most the target, broken once its lower bound is above it (or no number of further
  safe cases could meet it).

Cases run on the engine the search started once (:mod:`flexlift.sweep.executors`); their
records stay in memory (:class:`Memory`), not in a sweep folder.
"""

from __future__ import annotations

from collections import Counter

from flexlift.errors import InputError, SimulationError
from flexlift.sweep import aggregate as agg

#: the headline key of the gas an ascent used (initial fill and top-up), free air [m^3]
GAS_KEY = "gas_total_free_air_m3"


class Memory:
    """Where :func:`flexlift.sweep.run._execute` writes a case's record: kept in memory."""

    def write_case(self, name: str, record: dict, datasets: dict) -> dict:
        return record


class _Stop(Exception):
    """A case decided the rung: the rest need not be waited for."""


def nominal(scenarios: list, batch: bool = True) -> list[dict]:
    """The nominal ascent of each scenario: ``{"passed", "outcome", "why", "gas_m3"}``."""
    from flexlift.ascent.batch import run_batch
    from flexlift.ascent.loop import prepare
    from flexlift.sweep.plants import plant_for

    runs, out = [], [None] * len(scenarios)
    for i, sc in enumerate(scenarios):
        try:
            runs.append((i, prepare(sc, plant=plant_for(sc, sc.control.mode))))
        except InputError as exc:
            out[i] = {"passed": False, "outcome": "refused", "why": str(exc), "gas_m3": None}
    results = run_batch([r for _, r in runs]) if batch else None
    for k, (i, run) in enumerate(runs):
        res = results[k] if batch else _one(run)
        if isinstance(res, SimulationError):
            out[i] = {"passed": False, "outcome": "unsafe", "why": str(res), "gas_m3": None}
            continue
        kind = res.outcome.get("kind", "unsafe")
        out[i] = {"passed": kind == "safe", "outcome": kind,
                  "why": res.outcome.get("cause", ""), "gas_m3": res.headline.get(GAS_KEY)}
    return out


def _one(run):
    from flexlift.ascent.batch import run_batch

    return run_batch([run])[0]


def contingency(scenario, engine, kinds=None, stop: bool = True) -> dict:
    """Every single failure of ``scenario``: ``{"passed", "cases", "counts", "first"}``
    (``first``: the case that failed it, its kind, phase, bag and reason); ``stop``: at the
    first such case (else every case runs, for the user's own plan)."""
    from flexlift.sweep.cases import Case, case_name
    from flexlift.sweep.contingency.answer import run_fault_case, take_traces
    from flexlift.sweep.contingency.run import _answer, plan_study, study_spec, submission_order
    from flexlift.sweep.run import _execute

    mode = scenario.control.mode
    sc = scenario.with_changes(faults=[])
    _, _, cases, _, _, _ = plan_study(sc, mode, workers=getattr(engine, "workers", 1),
                                      kinds=kinds, yes=True)
    spec = study_spec(sc, mode, cases, f"design: single failures of {sc.name}")
    names = {c.index: case_name(spec, c.index) for c in cases}
    by_index = {c.index: c for c in cases}
    records: dict = {}
    first: dict = {}

    def watch(done, total, failed):
        for i, r in records.items():
            a = _answer(r, mode)
            if a["outcome"] in ("unsafe", "incomplete") and not first:
                c = by_index[i]
                first.update(kind=c.kind, phase=c.phase, bag=c.bag, outcome=a["outcome"],
                             reason=a.get("reason", ""))
                if stop:
                    raise _Stop

    todo = [Case(c.index, {"faults": [c.fault()]}) for c in submission_order(cases)]
    try:
        _execute(engine, spec, todo, names, Memory(), records, "design", watch,
                 fn=run_fault_case, aside=lambda i, r: take_traces(r))
    except _Stop:
        pass
    counts = Counter(_answer(r, mode)["outcome"] for r in records.values())
    return {"passed": not first, "cases": len(cases), "ran": len(records),
            "counts": {k: counts.get(k, 0) for k in agg.OUTCOMES}, "first": first or None}


def salvage(scenario, engine, target: float, samples: int, seed: int, block: int) -> dict:
    """The salvage study of ``scenario`` until P(unsafe)'s bound decides (module docstring):
    ``{"passed", "p_unsafe": {p, low, high, n}, "counts", "ran", "decided"}``."""
    from flexlift.sweep.cases import case_name, make_cases
    from flexlift.sweep.run import _execute
    from flexlift.sweep.spec import parse_spec

    spec = parse_spec({"base": scenario, "study": "salvage",
                       "monte_carlo": {"samples": int(samples), "seed": int(seed)}},
                      f"design: salvage study of {scenario.name}", None, True)
    mode = spec.controls[0]
    cases = make_cases(spec)
    names = {c.index: case_name(spec, c.index) for c in cases}
    records: dict = {}
    decided = "all cases run"
    for b0 in range(0, len(cases), block):
        _execute(engine, spec, cases[b0:b0 + block], names, Memory(), records, "design", None)
        w, _ = p_unsafe(records, mode)
        left = len(cases) - len(records)
        if w["n"] and w["high"] <= target:
            decided = "met: upper bound at most the target"
            break
        if w["n"] and (w["low"] > target
                       or agg.wilson(w["failed"], w["n"] + left)["high"] > target):
            decided = "broken: the target cannot be met"
            break
    w, counts = p_unsafe(records, mode)
    return {"passed": bool(w["n"]) and w["high"] <= target,
            "p_unsafe": {k: w[k] for k in ("p", "low", "high", "n")}, "counts": counts,
            "ran": len(records), "decided": decided}


def p_unsafe(records: dict, mode: str) -> tuple[dict, dict]:
    """(the Wilson interval of P(unsafe) over the cases with an outcome, incomplete ones left
    out and failed runs counted unsafe; every outcome's count)."""
    kinds = [agg.outcome_of(r["results"][mode]) for r in agg.ran(records, mode)]
    counts = {k: kinds.count(k) for k in agg.OUTCOMES}
    n = len(kinds) - counts["incomplete"]
    # a case whose run failed is not known to be safe: it counts as unsafe
    return agg.wilson(counts["unsafe"] + counts["failed"], n), counts
