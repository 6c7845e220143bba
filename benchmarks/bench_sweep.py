"""Throughput of ``flexlift sweep``: a Monte Carlo of 1,000 tanker ascents on 2 cores, against
running the same cases one by one in a loop of ``flexlift simulate`` processes.

- ``sweep_*``: ``flexlift sweep SPEC --workers 2 --quiet --json`` as a new process, wall time
  from its start to its exit (imports, the worker pool, the numba load, every case, the
  netCDF, summary and report); ``cases_per_s`` is cases / that wall time,
  ``steady_cases_per_s`` the rate between the first and the last case file written (what a
  longer sweep approaches).
- ``loop_*``: ``flexlift simulate CASE.yaml --control coordinated --json`` for the first
  :data:`LOOP_CASES` cases, each a new process, one after another (a shell loop); its mean
  per process is extrapolated to every case (``loop_extrapolated_s``; stated, not run);
  ``ratio`` = that / the sweep's wall time. The loop's numbers are checked to equal the
  sweep's for those cases.
- ``case_*``: where a case's time goes, in one process over :data:`PROFILE_CASES` cases of the
  same sweep: the plant built afresh (what ``simulate`` does alone) or reused by the worker
  (:mod:`flexlift.sweep.plants`), the compiled loop, the results.

The cases: the built-in tanker, coordinated control, to the target held 10 minutes (the
default ``simulation``), with the breakout factor uniform in [1.25, 1.35] (the 7-bag plan of
the built-in ``mode_nodes`` layout holds there: wider, some cases need 6 or 8 bags, which that
layout cannot place, and they would fail at once), T_b lognormal (median 400 s, sigma 0.3),
C_D normal (1.2 +- 0.1, at least 0.8) and the current triangular on [-0.1, 0.1] m/s, Latin
hypercube, seed 1. Results go to ``benchmarks/sweep.json`` (``results.json`` belongs to
``./dev bench``). ``python benchmarks/bench_sweep.py [--quick]``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
OUT = HERE / "sweep.json"
SAMPLES = 1000
LOOP_CASES = 5
PROFILE_CASES = 40
WORKERS = 2
SPEC = {
    "base": "tanker",
    "control": ["coordinated"],
    "keep": "summary",
    "monte_carlo": {
        "samples": SAMPLES, "seed": 1, "method": "lhs",
        "vary": {
            "lift.breakout_factor": {"dist": "uniform", "low": 1.25, "high": 1.35},
            "seabed.breakout_time_s": {"dist": "lognormal", "median": 400, "sigma": 0.3},
            "hydro.drag_coefficient": {"dist": "normal", "mean": 1.2, "std": 0.1, "low": 0.8},
            "disturbance.current_m_s": {"dist": "triangular", "low": -0.1, "mode": 0.0,
                                        "high": 0.1},
        },
    },
}


def _flexlift(*args) -> list[str]:
    return [sys.executable, "-m", "flexlift", *args]


def _sweep(spec_file: Path, out: Path) -> dict:
    t0 = time.perf_counter()
    proc = subprocess.run(_flexlift("sweep", str(spec_file), "--workers", str(WORKERS),
                                    "--out", str(out), "--quiet", "--json", "--yes"),
                          capture_output=True, text=True, check=True)
    wall = time.perf_counter() - t0
    j = json.loads(proc.stdout)
    stamps = sorted(p.stat().st_mtime for p in (out / "cases").glob("case_*.json"))
    records = [json.loads(p.read_text()) for p in sorted((out / "cases").glob("case_*.json"))]
    worker_s = [r["elapsed_s"] for r in records if r.get("elapsed_s") is not None]
    return {"sweep_wall_s": round(wall, 2), "sweep_cases": j["cases"],
            "sweep_completed": j["completed"], "sweep_failed": j["failed"],
            "sweep_engine": j["engine"],
            "cases_per_s": round(j["cases"] / wall, 2),
            "steady_cases_per_s": round((len(stamps) - 1) / (stamps[-1] - stamps[0]), 2),
            "worker_case_mean_s": round(sum(worker_s) / len(worker_s), 4),
            "failure_probability_all": j["failure_probability"]["all_criteria"]}


def _loop(spec, out: Path, tmp: Path, n: int) -> dict:
    from flexlift.sweep.cases import case_name, case_scenario, make_cases

    cases = make_cases(spec)[:n]
    times, same = [], True
    for case in cases:
        path = tmp / f"{case_name(spec, case.index)}.yaml"
        path.write_text(case_scenario(spec, case).to_yaml())
        t0 = time.perf_counter()
        proc = subprocess.run(_flexlift("simulate", str(path), "--control", "coordinated",
                                        "--json"), capture_output=True, text=True, check=True)
        times.append(time.perf_counter() - t0)
        got = json.loads(proc.stdout)
        rec = json.loads((out / "cases" / f"{path.stem}.json").read_text())
        want = rec["results"]["coordinated"]["headline"]
        same &= all(got[k] == want[k] for k in ("max_ascent_velocity_ms", "max_pitch_deg",
                                                "max_bending_moment_MNm", "end_time_s"))
    mean = sum(times) / len(times)
    return {"loop_processes_timed": len(times), "loop_process_s": [round(t, 3) for t in times],
            "loop_mean_process_s": round(mean, 3),
            "loop_extrapolated_s": round(mean * spec.n_cases, 1),
            "loop_cases_per_s": round(1 / mean, 3), "loop_results_equal_sweep": bool(same)}


def _profile(spec, n: int) -> dict:
    """Mean per case, in this process: a fresh plant, a reused one, the loop, the results."""
    import flexlift.ascent.loop as loop
    from flexlift.ascent import simulate
    from flexlift.ascent.plant import coupled_plant
    from flexlift.sweep import plants
    from flexlift.sweep.cases import case_scenario, make_cases

    cases = [case_scenario(spec, c) for c in make_cases(spec)[:n]]
    simulate(cases[0], control="coordinated")  # load the compiled code
    spent = {"kernel": 0.0, "result": 0.0}
    real_advance, real_build = loop.kernel.advance, loop.build_result

    def advance(*a):
        t = time.perf_counter()
        try:
            return real_advance(*a)
        finally:
            spent["kernel"] += time.perf_counter() - t

    def build(*a):
        t = time.perf_counter()
        try:
            return real_build(*a)
        finally:
            spent["result"] += time.perf_counter() - t

    fresh = reused = plant_fresh = plant_reused = 0.0
    loop.kernel.advance, loop.build_result = advance, build
    try:
        for s in cases:
            t = time.perf_counter()
            coupled_plant(s)
            plant_fresh += time.perf_counter() - t
            t = time.perf_counter()
            simulate(s, control="coordinated")
            fresh += time.perf_counter() - t
        spent = dict.fromkeys(spent, 0.0)
        for s in cases:
            t = time.perf_counter()
            p = plants.plant_for(s, "coordinated")
            plant_reused += time.perf_counter() - t
            simulate(s, control="coordinated", plant=p)
            reused += time.perf_counter() - t
    finally:
        loop.kernel.advance, loop.build_result = real_advance, real_build
    ms = 1000.0 / n
    return {"case_profiled": n, "case_simulate_fresh_plant_ms": round(fresh * ms, 1),
            "case_simulate_reused_plant_ms": round(reused * ms, 1),
            "case_plant_fresh_ms": round(plant_fresh * ms, 2),
            "case_plant_reused_ms": round(plant_reused * ms, 2),
            "case_kernel_ms": round(spent["kernel"] * ms, 1),
            "case_result_ms": round(spent["result"] * ms, 1),
            "case_cache": plants.stats()}


def run(quick: bool = False) -> dict:
    from flexlift.sweep import parse_spec

    samples = 100 if quick else SAMPLES
    data = json.loads(json.dumps(SPEC))
    data["monte_carlo"]["samples"] = samples
    spec = parse_spec(data)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        import yaml

        spec_file = tmp / "spec.yaml"
        spec_file.write_text(yaml.safe_dump(data, sort_keys=False))
        load_before = os.getloadavg()
        res = {"samples": samples, "workers": WORKERS, "cores": os.cpu_count(),
               "load_average_before": [round(x, 2) for x in load_before]}
        res.update(_sweep(spec_file, tmp / "out"))
        res.update(_loop(spec, tmp / "out", tmp, 3 if quick else LOOP_CASES))
        res.update(_profile(spec, 10 if quick else PROFILE_CASES))
    res["ratio"] = round(res["loop_extrapolated_s"] / res["sweep_wall_s"], 1)
    res["load_average_after"] = [round(x, 2) for x in os.getloadavg()]
    res["wall_s"] = round(time.perf_counter() - t0, 1)
    OUT.write_text(json.dumps({"date": time.strftime("%Y-%m-%d"), "sweep": res}, indent=2) + "\n")
    return res


if __name__ == "__main__":
    out = run(quick="--quick" in sys.argv[1:])
    json.dump(out, sys.stdout, indent=2)
    sys.stdout.write("\n")
