"""Throughput of ``flexlift sweep`` on 2 cores, against commit 30b642f in the same run (issue 28).

Every sweep is ``flexlift sweep ... --quiet --json --yes`` as a new process with PYTHONPATH on
one code tree's ``src`` (this tree's, and 30b642f's checked out into a temporary git worktree,
as ``bench_bags.py`` does), timed from its start to its exit:

- ``tanker``: the tanker with its nominal plan pinned (``lift.bags`` as the salvage study
  lists it, a SPEC both trees read), the uncertainties of the study that are scenario keys in
  both trees: ``lift.breakout_factor`` uniform 1.15-1.45 (the soil's +-50 % on H0), T_b
  log-uniform 200-800 s, the current +-0.25 m/s, the fill and dump valves +-20 %; LHS, seed 1,
  ``--workers 2`` (and ``--workers 1`` for the scaling);
- ``study``: this tree only, ``flexlift sweep --study salvage tanker`` (also every bag's
  capacity factor and the weight);
- ``bags73``: ``benchmarks/bags_tanker.yaml`` with ``lift.catalogue_bag.lift_t`` 50 (73
  bags), T_b, the current and the valves varied as above.

Per sweep: ``wall_s``, ``ascents_per_s`` (cases / wall), ``steady_per_s`` (between the first
and the last case file written), ``fixed_s`` (wall - cases / steady: the start and the end
of a sweep: imports, the pool, the numba load, the results), its two parts ``start_s`` (until
the first case file, less that case's own time in its worker) and ``end_s`` (from the last
case file to the exit: the results, the report), ``case_in_worker_s`` (the mean of the
cases' own ``elapsed_s``: the case in the loop, as the worker timed it). The load average
is recorded before and after. ``--pairs N`` runs the tanker sweep N more times in each tree,
alternating, for the spread of the end-to-end ratio (``tanker_pairs``: each run, the sorted
ratios and their median). ``--starts N`` first runs N sweeps of 40 tanker cases of this tree
for the fixed start and end alone (``starts``: each run's, with the load average before it,
and the median start). ``python benchmarks/bench_sweep.py [--samples 1000]
[--bags-samples 100] [--no-baseline | --baseline COMMIT] [--pairs N] [--starts N]
[--out FILE]``; writes ``benchmarks/sweep.json``.
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

import yaml

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "sweep.json"
BAGS = ROOT / "benchmarks" / "bags_tanker.yaml"
BASELINE_COMMIT = "30b642f"
WORKERS = 2
VALVES = {"gas.fill_rate_max_m3_s": {"dist": "uniform", "low": 0.4, "high": 0.6},
          "gas.purge_rate_max_m3_s": {"dist": "uniform", "low": 1.6, "high": 2.4},
          "seabed.breakout_time_s": {"dist": "loguniform", "low": 200.0, "high": 800.0},
          "disturbance.current_m_s": {"dist": "uniform", "low": -0.25, "high": 0.25}}


def _pinned_bags() -> list[dict]:
    """The tanker's nominal plan as ``lift.bags`` (only keys both trees know)."""
    sys.path.insert(0, str(ROOT / "src"))
    from flexlift import load_scenario
    from flexlift.loads.clusters import with_default_bag
    from flexlift.sweep.studies import pin_plan

    pinned = pin_plan(with_default_bag(load_scenario("tanker")), "bench")[0]
    return [b.model_dump(mode="json", exclude_none=True, exclude={"count"})
            for b in pinned.lift.bags]


def _specs(folder: Path, samples: int, bags_samples: int) -> dict[str, Path]:
    tanker = {"base": "tanker", "control": ["coordinated"], "keep": "summary",
              "set": {"lift.bags": _pinned_bags()},
              "monte_carlo": {"samples": samples, "seed": 1, "method": "lhs", "vary": {
                  "lift.breakout_factor": {"dist": "uniform", "low": 1.15, "high": 1.45},
                  **VALVES}}}
    text = BAGS.read_text().replace("    lift_t: 565.0", "    lift_t: 50.0")
    (folder / "bags73_base.yaml").write_text(text.replace("name: bags_tanker", "name: bags73"))
    bags73 = {"base": "bags73_base.yaml", "control": ["decentralized"], "keep": "summary",
              "monte_carlo": {"samples": bags_samples, "seed": 1, "method": "lhs",
                              "vary": dict(VALVES)}}
    out = {}
    for name, data in (("tanker", tanker), ("bags73", bags73)):
        out[name] = folder / f"{name}.yaml"
        out[name].write_text(yaml.safe_dump(data, sort_keys=False))
    return out


def _sweep(src: Path, args: list[str], out: Path, timeout: float) -> dict:
    env = dict(os.environ, PYTHONPATH=str(src), MPLBACKEND="Agg")
    shutil.rmtree(out, ignore_errors=True)
    t0, t0_wall = time.perf_counter(), time.time()
    proc = subprocess.run([sys.executable, "-m", "flexlift", "sweep", *args, "--out", str(out),
                           "--quiet", "--json", "--yes"], env=env, capture_output=True,
                          text=True, timeout=timeout)
    wall = time.perf_counter() - t0
    if proc.returncode:
        return {"error": proc.stderr[-1500:], "rc": proc.returncode}
    j = json.loads(proc.stdout)
    files = sorted((out / "cases").glob("case_*.json"), key=lambda p: p.stat().st_mtime)
    stamps = [p.stat().st_mtime for p in files]
    worker = [json.loads(p.read_text()).get("elapsed_s") for p in files]
    # the start: until the first case file, less that case's own time in its worker; the
    # end: from the last case file to the process's exit
    start = stamps[0] - t0_wall - (worker[0] or 0.0) if files else None
    end = t0_wall + wall - stamps[-1] if files else None
    worker = [w for w in worker if w is not None]
    n = j["cases"]
    steady = (len(stamps) - 1) / (stamps[-1] - stamps[0]) if len(stamps) > 2 else None
    shutil.rmtree(out, ignore_errors=True)
    return {"cases": n, "completed": j["completed"], "failed": j["failed"],
            "wall_s": round(wall, 2), "ascents_per_s": round(n / wall, 2),
            "steady_per_s": round(steady, 2) if steady else None,
            "fixed_s": round(wall - n / steady, 2) if steady else None,
            "start_s": None if start is None else round(start, 2),
            "end_s": None if end is None else round(end, 2),
            "case_in_worker_s": round(sum(worker) / len(worker), 4) if worker else None,
            "p_fail": j["failure_probability"].get("all_criteria", {}).get("p")}


def measure_tree(src: Path, specs: dict, samples: int, work: Path, own: bool) -> dict:
    warm = yaml.safe_load(specs["tanker"].read_text())
    warm["monte_carlo"]["samples"] = 2
    (work / "warm.yaml").write_text(yaml.safe_dump(warm, sort_keys=False))
    # numba's cache of this tree filled first (a fresh worktree compiles the loop once)
    _sweep(src, [str(work / "warm.yaml"), "--workers", "1"], work / "o", 3600)
    out = {"tanker": _sweep(src, [str(specs["tanker"]), "--workers", str(WORKERS)],
                            work / "o", 7200)}
    one = dict(samples=max(20, samples // 4))
    data = yaml.safe_load(specs["tanker"].read_text())
    data["monte_carlo"]["samples"] = one["samples"]
    single = work / "tanker1.yaml"
    single.write_text(yaml.safe_dump(data, sort_keys=False))
    out["tanker_workers1"] = _sweep(src, [str(single), "--workers", "1"], work / "o", 7200)
    if own:
        out["study"] = _sweep(src, ["tanker", "--study", "salvage", "--samples", str(samples),
                                    "--workers", str(WORKERS)], work / "o", 7200)
    out["bags73"] = _sweep(src, [str(specs["bags73"]), "--workers", str(WORKERS)], work / "o",
                           7200)
    a, b = out["tanker"].get("steady_per_s"), out["tanker_workers1"].get("steady_per_s")
    out["two_over_one_worker"] = round(a / b, 2) if a and b else None
    return out


def _pairs(base_src: Path, specs: dict, work: Path, n: int, first_current: dict,
           first_baseline: dict) -> dict:
    """The tanker sweep run ``n`` more times in each tree, alternating (the baseline first:
    the first pair ran this tree first), each pair's end-to-end ratio, and their median and
    range: the machine's drift between the two trees' runs shows as the ratios' spread."""
    ratios = []
    if first_current.get("wall_s") and first_baseline.get("wall_s"):
        ratios.append(first_baseline["wall_s"] / first_current["wall_s"])
    runs = []
    for _ in range(n):
        b = _sweep(base_src, [str(specs["tanker"]), "--workers", str(WORKERS)], work / "o", 7200)
        c = _sweep(ROOT / "src", [str(specs["tanker"]), "--workers", str(WORKERS)], work / "o",
                   7200)
        runs.append({"current_wall_s": c.get("wall_s"), "baseline_wall_s": b.get("wall_s"),
                     "current_case_s": c.get("case_in_worker_s"),
                     "baseline_case_s": b.get("case_in_worker_s")})
        if c.get("wall_s") and b.get("wall_s"):
            ratios.append(b["wall_s"] / c["wall_s"])
    ratios.sort()
    return {"runs": runs, "end_to_end": [round(r, 3) for r in ratios],
            "median": round(ratios[len(ratios) // 2], 2) if ratios else None}


def _starts(work: Path, n: int) -> dict:
    """The start and end of ``n`` small sweeps (40 tanker cases of the benchmark's SPEC,
    ``--workers 2``) of this tree, after a warm one, each with the load average before it:
    the fixed start measured alone, before the long sweeps load the machine."""
    small = _specs(work, 40, 10)["tanker"]
    _sweep(ROOT / "src", [str(small), "--workers", "1"], work / "o", 3600)  # warm
    runs = []
    for _ in range(n):
        load = round(os.getloadavg()[0], 2)
        r = _sweep(ROOT / "src", [str(small), "--workers", str(WORKERS)], work / "o", 3600)
        runs.append({"load": load, "start_s": r.get("start_s"), "end_s": r.get("end_s")})
    starts = sorted(r["start_s"] for r in runs if r["start_s"] is not None)
    return {"cases": 40, "runs": runs,
            "median_start_s": starts[len(starts) // 2] if starts else None}


def _baseline_tree(tmp: Path, commit: str) -> Path | None:
    if shutil.which("git") is None:
        return None
    wt = tmp / "baseline"
    res = subprocess.run(["git", "-C", str(ROOT), "worktree", "add", "--detach", str(wt),
                          commit], capture_output=True)
    return wt if res.returncode == 0 else None


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=200, help="tanker cases (issue 28: 1000)")
    ap.add_argument("--bags-samples", type=int, default=40, help="73-bag cases")
    ap.add_argument("--no-baseline", action="store_true")
    ap.add_argument("--baseline", default=BASELINE_COMMIT, metavar="COMMIT",
                    help=f"the commit compared in the same run (default {BASELINE_COMMIT}, "
                    "the issue's; e.g. the previous commit, with --out elsewhere)")
    ap.add_argument("--pairs", type=int, default=0, metavar="N",
                    help="N more runs of the tanker sweep in each tree, alternating (the "
                    "baseline first), for the spread of the end-to-end ratio")
    ap.add_argument("--starts", type=int, default=0, metavar="N",
                    help="first, N sweeps of 40 tanker cases of this tree: their start and "
                    "end alone, on the machine before the long sweeps")
    ap.add_argument("--out", default=str(OUT))
    args = ap.parse_args(argv)
    tmp = Path(tempfile.mkdtemp(prefix="flexlift-bench-sweep-"))
    head = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"],
                          capture_output=True, text=True).stdout.strip() or None
    dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "src"],
                           capture_output=True, text=True).stdout.strip()
    result: dict = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()),
                    "commit": head, "src_changed_since_commit": bool(dirty),
                    "samples": args.samples, "bags_samples": args.bags_samples,
                    "workers": WORKERS, "cores": os.cpu_count(),
                    "load_before": [round(x, 2) for x in os.getloadavg()]}
    base = None
    try:
        specs = _specs(tmp, args.samples, args.bags_samples)
        t0 = time.perf_counter()
        if args.starts > 0:
            (tmp / "starts").mkdir()
            result["starts"] = _starts(tmp / "starts", args.starts)
        result["current"] = measure_tree(ROOT / "src", specs, args.samples, tmp, True)
        result["load_mid"] = [round(x, 2) for x in os.getloadavg()]
        base = None if args.no_baseline else _baseline_tree(tmp, args.baseline)
        result["baseline_commit"] = args.baseline if base else None
        if base is not None:
            result["baseline"] = measure_tree(base / "src", specs, args.samples, tmp, False)
            for k in ("tanker", "bags73"):
                c, b = result["current"][k], result["baseline"][k]
                if c.get("wall_s") and b.get("wall_s"):
                    result[f"speedup_{k}"] = {
                        "end_to_end": round(b["wall_s"] / c["wall_s"], 2),
                        "steady": (round(c["steady_per_s"] / b["steady_per_s"], 2)
                                   if c.get("steady_per_s") and b.get("steady_per_s") else None),
                        "case_in_worker": round(b["case_in_worker_s"] / c["case_in_worker_s"],
                                                2)}
            if args.pairs > 0:
                result["tanker_pairs"] = _pairs(base / "src", specs, tmp, args.pairs,
                                                result["current"]["tanker"],
                                                result["baseline"]["tanker"])
        result["wall_s"] = round(time.perf_counter() - t0, 1)
    finally:
        if base is not None:
            subprocess.run(["git", "-C", str(ROOT), "worktree", "remove", "--force", str(base)],
                           capture_output=True)
        shutil.rmtree(tmp, ignore_errors=True)
    result["load_after"] = [round(x, 2) for x in os.getloadavg()]
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    return result


if __name__ == "__main__":
    print(json.dumps(main(), indent=1))
