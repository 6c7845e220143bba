"""The ascent: wall time against the code before the core rebuild, against the same loop with
scikit-fuzzy as the supervisor, the compile cost, fine meshes, and a long pipeline's memory.

- ``ascent_<mode>_s``: the whole tanker ascent (7 bags, 10 Hz, dt 0.1 s, to the target held
  10 minutes), best of three, warm; ``kernel_us_per_step``: the compiled loop alone.
- ``baseline_<mode>_s``: the same ascent by the code before the rebuild (commit
  :data:`BASELINE_COMMIT`, checked out into a temporary worktree and run in this same
  benchmark when git can; otherwise the time recorded on this machine,
  :data:`BASELINE_RECORDED_S`); ``speedup_<mode>``.
- ``skfuzzy_*``: a short window of the ascent with scikit-fuzzy's ``ControlSystemSimulation``
  as the supervisor (evaluated outside the compiled loop at every sample) against the table.
- ``first_call_cold_s``: a new process with an empty numba cache (the compile, paid once per
  machine and per change of the compiled sources); ``first_call_warm_s``: a new process with
  the cache (import, load and one ascent).
- ``mesh_1000_<mode>_s``: the tanker on 1,000 elements, its bags where the 11-element plan
  puts them (goal <= 1 s).
- ``pipeline_*``: a 1 km line on 2,000 elements lifted by 50 bags (22 modes integrated), in a
  new process: wall time and peak resident memory (goal <= 300 MB); ``traced_MB`` the arrays
  the ascent allocates itself.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
#: the last commit before the core rebuild
BASELINE_COMMIT = "adc7f83"
#: its tanker ascent on this machine (2026-12-01, best of one, quiet machine) [s]
BASELINE_RECORDED_S = {"decentralized": 2.83, "coordinated": 2.85}


def _skfuzzy_supervisor():
    import skfuzzy as fuzz
    from skfuzzy import control as ctrl

    from flexlift.fuzzy.rulebase import LABELS, SUPERVISOR_TABLE

    uni = np.linspace(-1, 1, 101)
    centres = np.linspace(-1, 1, 7)
    sigma = (centres[1] - centres[0]) / (2 * math.sqrt(2 * math.log(2)))
    e, r = ctrl.Antecedent(uni, "e"), ctrl.Antecedent(uni, "edot")
    u = ctrl.Consequent(uni, "u", defuzzify_method="centroid")
    for var in (e, r, u):
        for lb, c in zip(LABELS, centres):
            var[lb] = fuzz.gaussmf(var.universe, c, sigma)
    rules = [ctrl.Rule(e[row] & r[col], u[out])
             for row, outs in SUPERVISOR_TABLE.items() for col, out in zip(LABELS, outs)]
    sim = ctrl.ControlSystemSimulation(ctrl.ControlSystem(rules))

    def supervisor(x):
        out = np.empty(len(x))
        for k, (a, b) in enumerate(np.clip(x, -1, 1)):
            sim.input["e"], sim.input["edot"] = a, b
            sim.compute()
            out[k] = sim.output["u"]
        return out

    return supervisor


def _metre_layout(sc):
    """The tanker with its bags where the 11-element plan puts them, in metres (a finer mesh
    then carries the same lift plan, not one snapped to its own nodes)."""
    from flexlift.loads.liftplan import plan_lift
    from flexlift.structure.hull import hull_from_scenario

    bags = []
    for b in plan_lift(sc, hull_from_scenario(sc)).bags:
        d = {"name": b.name, "kind": b.kind}
        d.update({"x_m": b.x} if b.kind == "external" else {"span_m": list(b.span)})
        bags.append(d)
    return sc.with_changes(**{"lift.bags": bags})


def _best(fn, n=3):
    walls = []
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        walls.append(time.perf_counter() - t0)
    return min(walls), walls


def _baseline_in_this_run() -> dict | None:
    """The old code's ascent, timed now, from a temporary worktree of BASELINE_COMMIT."""
    if shutil.which("git") is None:
        return None
    tmp = Path(tempfile.mkdtemp(prefix="flexlift-baseline-"))
    wt = tmp / "wt"
    try:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(wt),
                        BASELINE_COMMIT], check=True, capture_output=True)
        code = ("import time, json; from flexlift import load_scenario; "
                "from flexlift.simulate import simulate; sc = load_scenario('tanker'); out = {}\n"
                "for m in ('decentralized', 'coordinated'):\n"
                "    w = []\n"
                "    for _ in range(2):\n"
                "        t = time.perf_counter(); simulate(sc, control=m); w.append(time.perf_counter() - t)\n"
                "    out[m] = min(w)\n"
                "print(json.dumps(out))")
        env = dict(os.environ, PYTHONPATH=str(wt / "src"), MPLBACKEND="Agg")
        res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                             timeout=900, cwd=tmp)
        return json.loads(res.stdout.strip().splitlines()[-1]) if res.returncode == 0 else None
    except (subprocess.SubprocessError, OSError, ValueError, IndexError):
        return None
    finally:
        subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(wt)],
                       capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)


_FIRST_CALL = ("import time; t = time.perf_counter(); from flexlift import load_scenario; "
               "from flexlift.ascent import simulate; simulate(load_scenario('tanker')); "
               "print(time.perf_counter() - t)")

_PIPELINE = """
import json, resource, time, tracemalloc
import numpy as np
from flexlift import load_scenario
from flexlift.ascent import simulate
L, nb = 1000.0, 50
bags = [{"name": f"bag_{k + 1}", "kind": "external", "x_m": float((k + 0.5) * L / nb),
         "lift_t": 12.0} for k in range(nb)]
sc = load_scenario("tanker").with_changes(**{
    "name": "pipe", "hull.length_m": L, "hull.breadth_m": 0.6, "hull.depth_m": 0.6,
    "hull.elements": 2000, "hull.displacement_t": 500.0, "hull.bending_stiffness_Nm2": 1.6e8,
    "lift.bags": bags, "environment.water_depth_m": 100.0, "control.target_height_m": 50.0,
    "control.breakout_pull_t": 60.0, "simulation.retained_flexible_modes": 20,
    "simulation.duration_s": 3000.0})
simulate(load_scenario("tanker"), duration=10.0)  # load the compiled loop first
tracemalloc.start()
t = time.perf_counter()
r = simulate(sc)
wall = time.perf_counter() - t
print(json.dumps({"wall_s": wall, "traced_MB": tracemalloc.get_traced_memory()[1] / 1e6,
                  "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "criteria": r.criteria, "end_s": r.headline["end_time_s"]}))
"""


def _subprocess(code: str, env=None, timeout=1800) -> str:
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=timeout, env=env)
    if res.returncode:
        raise RuntimeError(res.stderr[-2000:])
    return res.stdout.strip().splitlines()[-1]


def run(quick: bool = False) -> dict:
    from flexlift import load_scenario
    from flexlift.ascent import kernel, simulate
    from flexlift.ascent.loop import Ascent
    from flexlift.ascent.plant import coupled_plant

    sc = load_scenario("tanker")
    simulate(sc, duration=10.0)  # load the compiled loop
    out: dict = {}
    modes = ("decentralized", "coordinated")
    for mode in modes:
        best, walls = _best(lambda m=mode: simulate(sc, control=m), 1 if quick else 3)
        out[f"ascent_{mode}_s"] = round(best, 3)
        out[f"ascent_{mode}_s_runs"] = [round(w, 3) for w in walls]
    P = coupled_plant(sc)
    run_ = Ascent(sc, P, "coordinated", sc.simulation.duration_s, "table")
    t0 = time.perf_counter()
    kernel.advance(run_.inputs(), run_.settings.n_steps + 1)
    steps = int(run_.state.counters[0])
    out["kernel_steps"] = steps
    out["kernel_us_per_step"] = round((time.perf_counter() - t0) / steps * 1e6, 2)
    base = None if quick else _baseline_in_this_run()
    out["baseline_measured_in_this_run"] = base is not None
    base = base or BASELINE_RECORDED_S
    for mode in modes:
        out[f"baseline_{mode}_s"] = round(base[mode], 3)
        out[f"speedup_{mode}"] = round(base[mode] / out[f"ascent_{mode}_s"], 1)
    # scikit-fuzzy as the supervisor, on a window of the ascent (quick breakout, ~30 s)
    short = sc.with_changes(**{"seabed.breakout_time_s": 0.5, "control.breakout_pull_t": 20.0})
    T1, T2 = 40.0, 60.0 if quick else 100.0
    per = {}
    for name, engine in (("table", "table"), ("skfuzzy", _skfuzzy_supervisor())):
        w = [_best(lambda d=d, e=engine: simulate(short, duration=d, engine=e), 1)[0]
             for d in (T1, T2)]
        per[name] = (w[1] - w[0]) / (T2 - T1)
    out["skfuzzy_s_per_simulated_s"] = round(per["skfuzzy"], 5)
    out["table_s_per_simulated_s"] = round(per["table"], 6)
    # the table loop's cost per simulated second by difference of two windows is a few
    # microseconds and can vanish in a loaded machine's noise: then the whole ascent's own
    # cost per simulated second bounds it from above (a smaller, honest ratio)
    table_per = per["table"] if per["table"] > 0 else out["ascent_decentralized_s"] / 4045.0
    out["ratio_skfuzzy_vs_table"] = round(per["skfuzzy"] / table_per, 0)
    out["skfuzzy_ascent_estimate_s"] = round(per["skfuzzy"] * 4045.0, 0)
    if not quick:
        with tempfile.TemporaryDirectory() as cache:
            env = dict(os.environ, NUMBA_CACHE_DIR=cache, MPLBACKEND="Agg")
            out["first_call_cold_s"] = round(float(_subprocess(_FIRST_CALL, env)), 1)
            out["first_call_warm_s"] = round(float(_subprocess(_FIRST_CALL, env)), 2)
        fine = _metre_layout(sc).with_changes(**{"hull.elements": 1000})
        for mode in modes:
            out[f"mesh_1000_{mode}_s"] = round(_best(lambda m=mode: simulate(fine, control=m), 2)[0], 2)
        pipe = json.loads(_subprocess(_PIPELINE))
        out["pipeline_2000el_50bags_wall_s"] = round(pipe["wall_s"], 2)
        out["pipeline_peak_rss_MB"] = round(pipe["peak_rss_MB"], 1)
        out["pipeline_traced_MB"] = round(pipe["traced_MB"], 1)
        out["pipeline_all_criteria"] = all(pipe["criteria"].values())
    return out


if __name__ == "__main__":
    print(json.dumps(run(), indent=2))
