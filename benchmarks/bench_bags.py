"""The cost of real bag counts (issue 24): the tanker lifted by 7 to 362 catalogue bags.

The scenario is ``benchmarks/bags_tanker.yaml`` (the tanker, external bags only, balanced
layout) with ``lift.catalogue_bag.lift_t`` of 565 / 150 / 50 / 20 / 10 t: 7, 25, 73, 181 and
362 bags. For each bag count, in a new process per code tree (this tree's and the baseline
commit's, :data:`BASELINE_COMMIT`, checked out into a temporary worktree when git can):

- ``ascent_s``: the whole ascent (decentralized, to the target held or the scenario's 6,000 s),
  warm, in-process, best of ``repeats``;
- ``loop_us_per_step``, ``loop_us_per_bag_step``: the compiled loop alone over the same ascent;
- ``plant_build_s`` (quiet) and ``plant_build_busy_s`` (two busy processes on the machine's two
  cores): the coupled plant with its lift plan, best of three;
- ``run_peak_MB``, ``run_folder_MB``, ``run_s``: ``flexlift run`` on the scenario, the largest
  resident set of its processes and the output folder's size (``--no-run`` skips these).

The report's page count (headless Chromium) is not measured here.

Usage: ``python benchmarks/bench_bags.py [--sizes 565,150,50] [--no-baseline] [--no-run]``;
writes ``benchmarks/bags.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "benchmarks" / "bags_tanker.yaml"
#: the code before the work on bag counts (issue 24)
BASELINE_COMMIT = "30b642f"
#: catalogue bag lifts [t] and the bag counts they give the tanker
SIZES_T = (565.0, 150.0, 50.0, 20.0, 10.0)

#: run in a new process with PYTHONPATH on one tree's src: argv[1] the scenario, argv[2] the
#: lifts (comma separated), argv[3] repeats; prints one JSON line
_MEASURE = r"""
import json, subprocess, sys, time
from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.ascent.loop import Ascent
from flexlift.ascent.plant import coupled_plant

base = load_scenario(sys.argv[1])
lifts = [float(v) for v in sys.argv[2].split(",")]
repeats = int(sys.argv[3])
simulate(load_scenario("tanker"), duration=10.0)  # the compiled loop loaded (or compiled)


def scenario(lift_t):
    return base.with_changes(**{"lift.catalogue_bag.lift_t": lift_t})


def best(fn, n):
    walls = []
    for _ in range(n):
        t = time.perf_counter()
        fn()
        walls.append(time.perf_counter() - t)
    return min(walls)


out = {}
for lt in lifts:
    sc = scenario(lt)
    P = coupled_plant(sc)
    nb = len(P.names)
    row = {"bags": nb, "plant_build_s": best(lambda: coupled_plant(sc), 3)}
    res = simulate(sc, plant=P)
    row["ascent_s"] = best(lambda: simulate(sc, plant=P), repeats)
    row["criteria_pass"] = all(res.criteria.values())
    row["end_time_s"] = res.headline.get("end_time_s")
    run = Ascent(sc, P, "decentralized", sc.simulation.duration_s, "table")
    t = time.perf_counter()
    run._advance(run.settings.n_steps + 1) if hasattr(run, "settings") else run._advance(
        run.X.n_steps + 1)
    wall = time.perf_counter() - t
    state = run.state if hasattr(run, "state") else run.R
    steps = int(state.counters[0])
    row["loop_steps"] = steps
    row["loop_us_per_step"] = wall / steps * 1e6
    row["loop_us_per_bag_step"] = wall / steps / nb * 1e6
    out[str(lt)] = row
# the plant built with two busy processes on the two cores
busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(2)]
try:
    time.sleep(0.5)
    for lt in lifts:
        sc = scenario(lt)
        out[str(lt)]["plant_build_busy_s"] = best(lambda: coupled_plant(sc), 3)
finally:
    for p in busy:
        p.kill()
        p.wait()
print(json.dumps(out))
"""

#: ``flexlift run`` in a child, the largest resident set of its processes [MB] after it
_RUN = r"""
import json, resource, subprocess, sys, time
t = time.perf_counter()
res = subprocess.run([sys.executable, "-m", "flexlift", "run", sys.argv[1], "--out", sys.argv[2],
                      "--quiet"], capture_output=True, text=True, timeout=3600)
wall = time.perf_counter() - t
print(json.dumps({"rc": res.returncode, "run_s": wall, "err": res.stderr[-500:],
                  "run_peak_MB": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}))
"""


def _python(code: str, args: list[str], src: Path, timeout: float) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src), MPLBACKEND="Agg")
    res = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True,
                         text=True, timeout=timeout)
    if res.returncode:
        raise RuntimeError(res.stderr[-2000:])
    return json.loads(res.stdout.strip().splitlines()[-1])


def _scenario_file(folder: Path, lift_t: float) -> Path:
    """The benchmark scenario with catalogue bags of ``lift_t`` [t], as a file."""
    text = SCENARIO.read_text()
    assert "    lift_t: 565.0" in text
    path = folder / f"bags_{lift_t:g}t.yaml"
    path.write_text(text.replace("    lift_t: 565.0", f"    lift_t: {lift_t}")
                    .replace("name: bags_tanker", f"name: bags_{lift_t:g}t"))
    return path


def _folder_MB(path: Path) -> float:
    return sum(f.stat().st_size for f in path.rglob("*") if f.is_file()) / 1e6


def measure_tree(src: Path, lifts: list[float], repeats: int, with_run: bool,
                 work: Path) -> dict:
    """Every measurement of one code tree (``src`` its source folder)."""
    out = _python(_MEASURE, [str(SCENARIO), ",".join(map(str, lifts)), str(repeats)], src,
                  timeout=3600)
    if with_run:
        for lt in lifts:
            folder = work / f"out_{lt:g}"
            shutil.rmtree(folder, ignore_errors=True)
            r = _python(_RUN, [str(_scenario_file(work, lt)), str(folder)], src, timeout=3700)
            row = out[str(lt)]
            row["run_s"], row["run_peak_MB"] = r["run_s"], r["run_peak_MB"]
            row["run_rc"] = r["rc"]
            row["run_folder_MB"] = _folder_MB(folder) if folder.exists() else None
            shutil.rmtree(folder, ignore_errors=True)
    return out


def _baseline_tree(tmp: Path) -> Path | None:
    if shutil.which("git") is None:
        return None
    wt = tmp / "baseline"
    res = subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(wt),
                          BASELINE_COMMIT], capture_output=True)
    return wt if res.returncode == 0 else None


def _rounded(obj):
    if isinstance(obj, float):
        return round(obj, 4)
    if isinstance(obj, dict):
        return {k: _rounded(v) for k, v in obj.items()}
    return obj


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", default=",".join(f"{v:g}" for v in SIZES_T),
                    help="catalogue bag lifts [t], comma separated")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--no-baseline", action="store_true")
    ap.add_argument("--no-run", action="store_true", help="skip flexlift run (folder, memory)")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "bags.json"))
    args = ap.parse_args(argv)
    lifts = [float(v) for v in args.sizes.split(",")]
    tmp = Path(tempfile.mkdtemp(prefix="flexlift-bench-bags-"))
    result: dict = {"scenario": "benchmarks/bags_tanker.yaml", "lifts_t": lifts,
                    "load_before": os.getloadavg()}
    base = None
    try:
        t0 = time.perf_counter()
        result["current"] = measure_tree(ROOT / "src", lifts, args.repeats, not args.no_run,
                                         tmp)
        base = None if args.no_baseline else _baseline_tree(tmp)
        result["baseline_commit"] = BASELINE_COMMIT if base else None
        if base is not None:
            result["baseline"] = measure_tree(base / "src", lifts, args.repeats,
                                              not args.no_run, tmp)
        result["wall_s"] = time.perf_counter() - t0
    finally:
        if base is not None:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)],
                           capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)
    result["load_after"] = os.getloadavg()
    result = _rounded(result)
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    return result


if __name__ == "__main__":
    print(json.dumps(main(), indent=1))
