"""The search: optuna's constrained NSGA-II over the space, each candidate up the ladder as
far as it survives (docs/theory/design.md).

Generation by generation: ``population`` trials are asked of the seeded sampler, each made a
:class:`~flexlift.design.space.Candidate`; a candidate already in the cache is answered from
it, the others climb the ladder (statics, then the generation's nominal ascents in one batch,
then single failures, then the salvage study); the trials are told their objectives and their
constraints (one per rung, <= 0 when met). The same seed and the same cache replay the same
trials: an interrupted search resumes where it stopped, and gives the plan it would have.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass

from flexlift import constants as C
from flexlift.design import dynamic, mixed
from flexlift.design.bound import lower_bound
from flexlift.design.cache import Cache
from flexlift.design.internal import most_internal, tank_check
from flexlift.design.space import VARIABLES, Candidate, Space, candidate_changes
from flexlift.design.statics import static_checks
from flexlift.errors import InputError

RUNGS = ("statics", "nominal", "contingency", "salvage")
OBJECTIVES = ("bags", "gas", "cost")


@dataclass(frozen=True)
class Options:
    """How the search runs: ``budget`` candidates, ``population`` per generation, ``seed``;
    ``target`` P(unsafe)'s upper bound; ``up_to`` the last rung; ``objectives``."""

    budget: int = 60
    population: int = 12
    seed: int = 0
    target: float = 0.01
    objectives: tuple[str, ...] = ("bags",)
    up_to: str = "salvage"
    tolerant: bool = True  # the static N-1 lift check
    kinds: tuple[str, ...] | None = None
    samples: int = 600
    block: int = 40
    study_seed: int = 0
    batch: bool = True

    def _input(self, scenario, space: Space) -> dict:
        return {"scenario": scenario.checksum(), "span": space.span_m,
                "entries": space.entries, "target": self.target, "up_to": self.up_to,
                "tolerant": self.tolerant, "kinds": self.kinds, "samples": self.samples,
                "block": self.block, "study_seed": self.study_seed}

    def folder_identity(self, scenario, space: Space) -> str:
        """What the search is of (the output folder's identity): its input alone, so that a
        rerun after a change to flexlift continues the folder (and re-runs its candidates:
        :meth:`identity`) rather than refusing it."""
        return _digest(self._input(scenario, space))

    def identity(self, scenario, space: Space) -> str:
        """What every evaluation depends on, as text (the cache's identity): the input, and
        the code that evaluates it: ``flexlift.__version__`` and the digest of the package's
        source (:func:`flexlift.plumbing.source.code_digest`; the version alone stays 0.1.0
        across changes). Another code answers no candidate from the cache
        (docs/theory/design.md#resume)."""
        from flexlift import __version__
        from flexlift.plumbing.source import code_digest

        return _digest({**self._input(scenario, space), "flexlift": __version__,
                        "code": code_digest()})


def _digest(parts: dict) -> str:
    import hashlib
    import json

    return hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode()
                          ).hexdigest()[:20]


def check_options(o: Options, space: Space) -> None:
    """InputError (one line) for options that cannot run."""
    if not 0.0 < o.target < 1.0:
        raise InputError("--target", o.target, "a probability strictly between 0 and 1")
    if o.budget < 1:
        raise InputError("--budget", o.budget, "at least 1 candidate")
    if o.population < 2:
        raise InputError("--population", o.population, "at least 2 candidates per generation")
    if o.samples < 1:
        raise InputError("--samples", o.samples, "at least 1 salvage case")
    if o.up_to not in RUNGS:
        raise InputError("--up-to", o.up_to, f"one of {', '.join(RUNGS)}")
    for name in o.objectives:
        if name not in OBJECTIVES:
            raise InputError("--objectives", name, f"use {', '.join(OBJECTIVES)}")
    if "cost" in o.objectives:
        missing = [m for m, e in space.entries.items() if e.get("cost") is None]
        if missing:
            raise InputError("--objectives", "cost", f"the catalogue gives no cost for "
                             f"{missing[0]}; add cost: to its entries (lift.catalogue_file)")


def _suggest(trial, space: Space, ev) -> Candidate:
    """The candidate of ``trial``, each variable asked by name (a fixed one is not asked);
    ``ev`` the evaluator (the fewest bags of each model that lift, N; the most internal bags
    of each model the tanks hold)."""
    fixed = space.fixed()

    def pick(name, choices):
        return fixed[name] if name in fixed else trial.suggest_categorical(name, list(choices))

    def whole(name, pair):
        return fixed[name] if name in fixed else trial.suggest_int(name, pair[0], pair[1])

    if space.per_point:  # the points first, then each point's bag
        points = whole("points", space.points)
        point_models = [pick(f"model_{j + 1}", space.models) if len(space.models) > 1
                        else space.models[0] for j in range(points)]
        model = mixed.largest(point_models, space.entries)
    else:
        model = pick("model", space.models)
        points = whole("points", space.points)
        point_models = [model] * points
    lo, hi = space.internal
    internal = fixed["internal"] if "internal" in fixed else trial.suggest_int(
        "internal", lo, max(lo, min(hi, ev.most[model])))  # the range of this bag's tanks
    if space.count is not None:
        bags = points * space.count + internal
    elif len(set(point_models)) > 1:
        lifts = [float(space.entries[m]["lift_t"]) for m in point_models]
        bags = mixed.fewest(lifts, internal, float(space.entries[model]["lift_t"]),
                            ev.bounds[model]["required_lift_t"]) + whole("over", space.over)
    else:
        bags = ev.fewest[model] + whole("over", space.over)
    external = max(bags - internal, 0)
    points = max(1, min(points, external))
    point_models = point_models[:points]
    return Candidate(model=model, points=points, count=external // points,
                     extra=external % points, mode=pick("mode", space.modes),
                     ascent_speed_m_s=pick("ascent_speed_m_s", space.ascent_speeds),
                     breakout_pull_t=pick("breakout_pull_t", space.breakout_pulls),
                     dump_valve_factor=pick("dump_valve_factor", space.dump_valve_factors),
                     internal=internal,
                     point_models=tuple(point_models) if len(set(point_models)) > 1 else None,
                     supply_free_air_m3_min=pick("supply_free_air_m3_min", space.supplies),
                     sequence=pick("sequence", space.sequences))


class Evaluator:
    """Climbs candidates up the ladder on one engine, with the cache; counts the calls."""

    def __init__(self, scenario, space: Space, options: Options, engine, cache: Cache):
        from flexlift.structure.hull import hull_from_scenario

        self.scenario, self.space, self.o = scenario, space, options
        self.engine, self.cache = engine, cache
        self.hull = hull_from_scenario(scenario)
        self.calls = {r: 0 for r in RUNGS}
        self.bounds = {m: lower_bound(scenario, self.hull, e["lift_t"])
                       for m, e in space.entries.items()}
        self.fewest = {m: b["n"] for m, b in self.bounds.items()}
        self.most = {m: most_internal(scenario, self.hull, e)
                     for m, e in space.entries.items()}
        self.last = RUNGS.index(options.up_to)

    def scenario_of(self, c: Candidate):
        return self.scenario.with_changes(**candidate_changes(c, self.space, self.hull,
                                                              self.scenario))

    def generation(self, candidates: list[Candidate]) -> list[dict]:
        """The results of ``candidates`` (cached ones from the cache)."""
        out: list[dict | None] = [self.cache.get(c.key()) for c in candidates]
        first: dict[str, int] = {}  # a candidate asked twice in one generation runs once
        twins = {}
        for i, r in enumerate(out):
            if r is None:
                k = candidates[i].key()
                if k in first:
                    twins[i] = first[k]
                else:
                    first[k] = i
        todo = [i for i, r in enumerate(out) if r is None and i not in twins]
        scen = {}
        for i in todo:
            out[i], scen[i] = self._statics(candidates[i])
        if self.last >= 1:
            alive = [i for i in todo if out[i]["passed"]]
            for i, res in zip(alive, self._nominal([scen[i] for i in alive])):
                self._rung(out[i], "nominal", res)
        for i in todo:
            for rung in RUNGS[2:self.last + 1]:
                if out[i]["passed"]:
                    self._rung(out[i], rung, self._dynamic(rung, scen[i]))
            self.cache.put(candidates[i].key(), out[i])
        for i, j in twins.items():
            out[i] = out[j]
        return out

    def _statics(self, c: Candidate):
        self.calls["statics"] += 1
        entry = self.space.entries[c.model]
        bags = _bag_models(c)  # the model of every bag, external then internal
        costs = [self.space.entries[m].get("cost") for m in bags]
        res = {"candidate": asdict(c), "bags": c.bags, "counts": c.counts(),
               "lift_t": float(entry["lift_t"]), "type": entry["type"],
               "cost": None if None in costs else float(sum(costs)),
               "reached": "statics", "passed": False, "rejected": None}
        failed = tank_check(self.scenario, self.hull, c.internal, entry)
        if failed is None:
            try:
                sc = self.scenario_of(c)
            except InputError as exc:
                failed = {"passed": False, "check": "scenario", "why": str(exc),
                          "violation": 1.0}
        if failed is not None:
            res["statics"] = failed
            res["rejected"] = {"rung": "statics", "check": failed["check"],
                               "why": failed["why"]}
            return res, None
        res["points_m"] = [b.x_m for b in sc.lift.bags if b.kind == "external"]
        lift_t = sum(float(self.space.entries[m]["lift_t"]) for m in bags)
        res["gas_m3"] = _gas_estimate(sc, lift_t)
        st = static_checks(sc, self.hull, self.o.tolerant)
        res["statics"], res["passed"] = st, st["passed"]
        if not st["passed"]:
            res["rejected"] = {"rung": "statics", "check": st["check"], "why": st["why"]}
        return res, sc

    def _nominal(self, scenarios: list) -> list[dict]:
        self.calls["nominal"] += len(scenarios)
        return dynamic.nominal(scenarios, self.o.batch) if scenarios else []

    def _dynamic(self, rung: str, sc) -> dict:
        self.calls[rung] += 1
        if rung == "contingency":
            return dynamic.contingency(sc, self.engine, self.o.kinds)
        return dynamic.salvage(sc, self.engine, self.o.target, self.o.samples,
                               self.o.study_seed, self.o.block)

    def _rung(self, res: dict, rung: str, r: dict) -> None:
        res[rung], res["reached"], res["passed"] = r, rung, r["passed"]
        if rung == "nominal" and r.get("gas_m3") is not None:
            res["gas_m3"] = r["gas_m3"]
        if not r["passed"]:
            res["rejected"] = {"rung": rung, **_why(rung, r)}


def _bag_models(c: Candidate) -> list[str]:
    """The catalogue bag of each of ``c``'s bags: every point's, then the internal ones'."""
    return [m for m, n in zip(c.models(), c.counts()) for _ in range(n)] + [c.model] * c.internal


def _why(rung: str, r: dict) -> dict:
    if rung == "nominal":
        return {"check": r["outcome"], "why": r["why"]}
    if rung == "contingency":
        f = r["first"] or {}
        return {"check": f.get("kind", ""), "why": f"{f.get('outcome')} on {f.get('kind')} of "
                f"{f.get('bag')} at {f.get('phase')}: {f.get('reason', '')}"}
    p = r["p_unsafe"]
    return {"check": "p_unsafe", "why": f"P(unsafe) {p['p'] or 0:.3f} ({p['low'] or 0:.3f}-"
            f"{p['high'] or 1:.3f}, n = {p['n']}): {r['decided']}"}


def _gas_estimate(sc, lift_t: float) -> float:
    """Every bag full at the wreck's depth, as free air [m^3]: the gas objective of a
    candidate that never ran an ascent (Boyle)."""
    env = sc.environment
    p = env.atmospheric_pressure_Pa + env.seawater_density_kg_m3 * env.gravity_m_s2 * (
        env.water_depth_m - sc.hull.depth_m)
    return round(lift_t * C.TONNE / env.seawater_density_kg_m3 * p / env.atmospheric_pressure_Pa,
                 1)


def constraints(res: dict, last: int) -> list[float]:
    """One value per rung up to ``last``, <= 0 when met (a rung not reached: 1)."""
    out = []
    for rung in RUNGS[:last + 1]:
        r = res.get(rung)
        if r is None:
            out.append(1.0)
        elif rung == "statics":
            out.append(float(r["violation"]) if not r["passed"] else 0.0)
        elif rung == "contingency":
            c = r["counts"]
            out.append(0.0 if r["passed"] else float(max(1, c["unsafe"] + c["incomplete"])))
        elif rung == "salvage":
            out.append(0.0 if r["passed"] else float((r["p_unsafe"]["high"] or 1.0) + 1e-3))
        else:
            out.append(0.0 if r["passed"] else 1.0)
    return out


def objective_values(res: dict, names) -> list[float]:
    table = {"bags": float(res["bags"]), "gas": float(res.get("gas_m3") or 0.0),
             "cost": float(res.get("cost") or 0.0)}
    return [table[n] for n in names]


def run_search(scenario, space: Space, options: Options, engine, cache: Cache,
               progress=None) -> dict:
    """Every candidate's result, in trial order, and the evaluation counts."""
    import optuna

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    ev = Evaluator(scenario, space, options, engine, cache)
    sampler = optuna.samplers.NSGAIISampler(population_size=options.population,
                                            seed=options.seed)
    study = optuna.create_study(directions=["minimize"] * len(options.objectives),
                                sampler=sampler)
    t0, rows = time.perf_counter(), []
    while len(rows) < options.budget:
        n = min(options.population, options.budget - len(rows))
        trials = [study.ask() for _ in range(n)]
        results = ev.generation([_suggest(t, space, ev) for t in trials])
        for t, res in zip(trials, results):
            for rung, value in zip(RUNGS, constraints(res, ev.last)):
                t.set_constraint(rung, value)  # feasible when every value is <= 0
            study.tell(t, objective_values(res, options.objectives))
            rows.append({"trial": t.number, **res})
        if progress is not None:
            progress(len(rows), options.budget, sum(r["passed"] for r in rows))
    return {"rows": rows, "calls": ev.calls, "cache_hits": cache.hits,
            "cache_stale": cache.stale,
            "elapsed_s": time.perf_counter() - t0, "evaluator": ev}


__all__ = ["Options", "run_search", "check_options", "RUNGS", "OBJECTIVES", "VARIABLES"]
