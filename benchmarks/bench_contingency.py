"""Throughput of ``flexlift contingency``: every single failure at every phase, on 2 local
worker processes, against one plain ascent of the same plan timed in the same run.

Two plans, each with its margins off (the bound is on the cases; a margin is up to 6 more
runs per failing case, reported apart):

- ``tanker``: the built-in tanker's whole set (7 bags, every applicable kind, 4 phases);
- ``bags73``: the tanker lifted by 73 external 50 t catalogue bags at 10 lift points
  (``lift.layout: balanced``), one representative per lift point and type.

For each: ``plain_s``, one plain ascent (``simulate``, the plant reused as a worker reuses it,
the loop compiled and warm) timed here just before the study; ``study_s``, the wall time of
``run_contingency`` (the fault-free run, the worker pool, every case, the JSON, the report
with the worst three rerun); ``bound_s`` = 1.2 x cases x plain_s / workers; ``ratio`` =
study_s / (cases x plain_s / workers). A case that ends the run early (a breach) is cheaper
than the plain ascent, one that runs to the end of ``simulation.duration_s`` (never
separated) dearer.

Results go to ``benchmarks/contingency.json``. ``python benchmarks/bench_contingency.py
[--quick]`` (``--quick``: the tanker only).
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE / "contingency.json"
WORKERS = 2
BOUND = 1.2


def plans() -> dict:
    from flexlift import load_scenario

    tanker = load_scenario("tanker")
    return {"tanker": tanker,
            "bags73": tanker.with_changes(**{"lift.layout": "balanced", "lift.internal_bags": 0,
                                             "lift.catalogue_bag": {"lift_t": 50}})}


def plain_ascent_s(scenario, repeat: int = 3) -> float:
    """The fastest of ``repeat`` plain ascents [s], the plant reused (warm)."""
    from flexlift.ascent import simulate
    from flexlift.sweep.plants import plant_for

    plant = plant_for(scenario, scenario.control.mode)
    simulate(scenario, plant=plant)
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        simulate(scenario, plant=plant)
        best = min(best, time.perf_counter() - t0)
    return best


def bench(name: str, scenario) -> dict:
    from flexlift.sweep.contingency.run import run_contingency
    from flexlift.sweep.executors import make_engine

    plain = plain_ascent_s(scenario)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        r = run_contingency(scenario, Path(tmp) / name, engine=make_engine(WORKERS),
                            margins=False, yes=True)
        study = time.perf_counter() - t0
    s = r.summary
    n = s["n_cases"]
    ideal = n * plain / WORKERS
    return {"plan": name, "bags": sum(len(g["members"]) for g in s["groups"]),
            "groups": len(s["groups"]), "cases": n, "workers": WORKERS,
            "plain_s": round(plain, 3), "study_s": round(study, 2),
            "bound_s": round(BOUND * ideal, 2), "ratio": round(study / ideal, 3),
            "within_bound": study <= BOUND * ideal, "verdict": s["verdict"],
            "counts": s["counts"]}


def main(argv) -> int:
    quick = "--quick" in argv
    out = []
    for name, sc in plans().items():
        if quick and name != "tanker":
            continue
        res = bench(name, sc)
        out.append(res)
        print(json.dumps(res))
    OUT.write_text(json.dumps({"results": out}, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
