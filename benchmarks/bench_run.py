"""``flexlift run`` on the built-in tanker, warm: the whole main job, by stage, against the
code before the report was trimmed and sped up (issue 12), measured in the same run.

``python benchmarks/bench_run.py [--quick] [--no-baseline]`` writes ``benchmarks/run.json``
(``./dev bench`` runs it too, without the baseline, into its own ``results.json``). The
variants are measured in alternating rounds (3 rounds of 3 runs each), so that the load of
this shared machine weighs on each alike.

- ``run_s``: the median wall time of ``flexlift.cli.main(["run", "--quiet", "--out", ...])``
  with every figure drawn in the main process (``FLEXLIFT_FIGURE_PROCESSES=0``, what a busy
  machine does by default), in a Python process that has already run it once (imports done, the compiled ascent loaded
  from numba's cache); ``run_s_min``, ``run_s_runs`` every run; ``cpu_s``: the median CPU
  time of the process and of its children (the figure processes), ``cpu_main_process_s`` of
  the process alone: the load of other programs inflates CPU times less than wall times.
- ``subprocess_s``: the median of ``python -m flexlift run --quiet`` as a user starts it
  (interpreter, imports and the cached compiled loop included).
- ``stages_s``: the median wall time by stage (``modes``, ``loads``, ``reduce``, ``fuzzy``,
  ``simulate:<mode>`` per control mode, ``compare``, ``report``: the HTML page); within them
  ``figures_save_s``, the time ``flexlift.output.plots._style.save`` and ``draw`` take in the
  main process (the whole building, drawing and writing of the PNG files, or handing them to
  figure processes and waiting for a free one), for ``figures`` figures, and ``csv_s`` (the
  ascents' time-history CSV files).
- ``two_figure_processes``: the same with ``FLEXLIFT_FIGURE_PROCESSES=2`` (what a machine
  with two free cores does by default).
- ``load_average``: the machine's 1-minute load at the start and at the end (2 cores shared
  with other jobs: the wall times scale with it).
- ``baseline_*``: the same measurements of :data:`BASELINE_COMMIT` (main when this work
  started), its sources exported with ``git archive`` into a folder of the system's
  temporary directory kept between runs (its compiled loop is cached after the first);
  ``speedup`` (wall, median against median) and ``speedup_cpu``.
- ``speedup_two_figure_processes``: the baseline's median against that of
  ``two_figure_processes``; ``goal_speedup``: the speed-up issue 12's goal asks for (its
  4 s against the baseline's 10.7 s on the machine it was measured on,
  ``baseline_recorded_quiet_s``), so that a run on a slower or busier machine is judged by
  a ratio measured in the same run; ``at_recorded_machine_s`` and
  ``at_recorded_machine_two_figure_processes_s``: the medians scaled by that same-run ratio
  to the recorded machine (10.7 s over the baseline's median here).
"""

from __future__ import annotations

import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = Path(__file__).resolve().parent / "run.json"
#: main when the report work of issue 12 started
BASELINE_COMMIT = "f7b1d71"
#: its ``flexlift run`` on a quiet machine, warm (issue 12) [s]
BASELINE_RECORDED_S = 10.7
GOAL_S = 4.0

#: timed in a fresh process: one warm-up run, then ``runs`` runs with the time by stage
_MEASURE = r"""
import importlib, json, os, resource, sys, tempfile, time
from pathlib import Path
import flexlift.cli.run as cli_run
import flexlift.output.plots._style as style
import flexlift.output.results as results
from flexlift.cli import main

runs = int(sys.argv[1])
log = []

inside = set()  # the keys being timed now: a figure saved by draw is timed once, by draw

def timed(key, fn):
    def wrapper(*a, **k):
        name = key(a, k)
        if name in inside:
            return fn(*a, **k)
        inside.add(name)
        t = time.perf_counter()
        try:
            return fn(*a, **k)
        finally:
            inside.discard(name)
            log.append((name, time.perf_counter() - t))
    return wrapper

for name in ("modes", "loads", "reduce", "fuzzy", "simulate"):
    m = importlib.import_module(f"flexlift.stages.{name}")
    key = ((lambda a, k: "simulate:" + k.get("control", "?")) if name == "simulate"
           else (lambda a, k, n=name: n))
    m.run_stage = timed(key, m.run_stage)
    if name == "simulate":
        m.compare_stage = timed(lambda a, k: "compare", m.compare_stage)
cli_run.render_report = timed(lambda a, k: "report", cli_run.render_report)
style.save = timed(lambda a, k: "~figures", style.save)
if hasattr(style, "draw"):  # the baseline has no draw
    style.draw = timed(lambda a, k: "~figures", style.draw)
results.to_csv = timed(lambda a, k: "~csv", results.to_csv)

def cpu():
    s, c = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
    return s.ru_utime + s.ru_stime, c.ru_utime + c.ru_stime

out = Path(tempfile.mkdtemp()) / "tanker"
measured = []
for k in range(runs + 1):
    log.clear()
    t, (s0, c0) = time.perf_counter(), cpu()
    assert main(["run", "--quiet", "--out", str(out)]) == 0
    (s1, c1), wall = cpu(), time.perf_counter() - t
    if k:  # the first run warms up
        stages, figures, csv = {}, [], 0.0
        for name, dt in log:
            if name == "~figures":
                figures.append(dt)
            elif name == "~csv":
                csv += dt
            else:
                stages[name] = stages.get(name, 0.0) + dt
        measured.append({"wall": wall, "cpu": s1 - s0 + c1 - c0, "cpu_self": s1 - s0,
                         "stages": stages, "figures": figures, "csv": csv})
print(json.dumps(measured))
"""


def _median(values) -> float:
    return float(statistics.median(values))


def _raw(src: Path, runs: int, cwd: Path, env_extra: dict) -> tuple[list, list]:
    """``runs`` warm in-process runs and as many ``python -m flexlift run`` processes of the
    sources under ``src`` (with ``env_extra`` in the environment): (measured, process walls)."""
    env = dict(os.environ, PYTHONPATH=str(src), MPLBACKEND="Agg", **env_extra)
    res = subprocess.run([sys.executable, "-c", _MEASURE, str(runs)], env=env, cwd=cwd,
                         capture_output=True, text=True, timeout=3600)
    if res.returncode:
        raise RuntimeError(res.stderr[-2000:])
    measured = json.loads(res.stdout.strip().splitlines()[-1])
    out_dir = cwd / "subprocess-out"
    sub = []
    for _ in range(runs):
        t = time.perf_counter()
        subprocess.run([sys.executable, "-m", "flexlift", "run", "--quiet", "--out",
                        str(out_dir)], env=env, cwd=cwd, check=True, capture_output=True,
                       timeout=3600)
        sub.append(time.perf_counter() - t)
    shutil.rmtree(out_dir, ignore_errors=True)
    return measured, sub


def _summary(measured: list, sub: list) -> dict:
    """Medians (and the minimum wall) of what :func:`_raw` measured."""
    walls = [m["wall"] for m in measured]
    names = list(measured[0]["stages"])
    return {
        "run_s": round(_median(walls), 2),
        "run_s_min": round(min(walls), 2),
        "run_s_runs": [round(w, 2) for w in walls],
        "cpu_s": round(_median([m["cpu"] for m in measured]), 2),
        "cpu_main_process_s": round(_median([m["cpu_self"] for m in measured]), 2),
        "subprocess_s": round(_median(sub), 2),
        "stages_s": {k: round(_median([m["stages"].get(k, 0.0) for m in measured]), 3)
                     for k in names},
        "figures": len(measured[0]["figures"]),
        "figures_save_s": round(_median([sum(m["figures"]) for m in measured]), 3),
        "csv_s": round(_median([m["csv"] for m in measured]), 3),
    }


def _baseline_sources() -> Path | None:
    """The baseline's ``src`` exported into the temporary directory (kept: its numba cache
    then survives between runs of this benchmark)."""
    if shutil.which("git") is None:
        return None
    where = Path(tempfile.gettempdir()) / f"flexlift-bench-run-{BASELINE_COMMIT}"
    if not (where / "src" / "flexlift" / "__init__.py").is_file():
        shutil.rmtree(where, ignore_errors=True)
        where.mkdir(parents=True)
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", BASELINE_COMMIT, "src"],
                                 capture_output=True, check=True)
        subprocess.run(["tar", "-x", "-C", str(where)], input=archive.stdout, check=True)
    return where / "src"


def _load_average() -> float | None:
    try:
        return round(os.getloadavg()[0], 2)
    except OSError:
        return None


def run(quick: bool = False, baseline: bool = False) -> dict:
    """The measurements (module docstring); the baseline only when asked (it takes minutes).
    The variants are measured in alternating rounds, so that the load of a shared machine
    weighs on each alike."""
    runs, rounds = (1, 1) if quick else (3, 3)
    variants = {"one_process": (ROOT / "src", {"FLEXLIFT_FIGURE_PROCESSES": "0"}),
                "two_figure_processes": (ROOT / "src", {"FLEXLIFT_FIGURE_PROCESSES": "2"})}
    if baseline:
        src = _baseline_sources()
        if src is not None:
            variants["baseline"] = (src, {})
    raw = {k: ([], []) for k in variants}
    work = Path(tempfile.mkdtemp(prefix="flexlift-bench-run-"))
    load = _load_average()
    try:
        for _ in range(rounds):
            for name, (src, env) in variants.items():
                measured, sub = _raw(src, runs, work, env)
                raw[name][0].extend(measured)
                raw[name][1].extend(sub)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    res = {k: _summary(*v) for k, v in raw.items()}
    out = {"load_average": [load, _load_average()], "runs": runs * rounds, **res["one_process"],
           "two_figure_processes": res["two_figure_processes"], "goal_s": GOAL_S,
           "baseline_commit": BASELINE_COMMIT, "baseline_recorded_quiet_s": BASELINE_RECORDED_S}
    if "baseline" in res:
        base, two = res["baseline"], res["two_figure_processes"]
        out.update({f"baseline_{k}": v for k, v in base.items()})
        out["speedup"] = round(base["run_s"] / out["run_s"], 2)
        out["speedup_cpu"] = round(base["cpu_s"] / out["cpu_s"], 2)
        out["speedup_two_figure_processes"] = round(base["run_s"] / two["run_s"], 2)
        out["goal_speedup"] = round(BASELINE_RECORDED_S / GOAL_S, 2)
        scale = BASELINE_RECORDED_S / base["run_s"]
        out["at_recorded_machine_s"] = round(scale * out["run_s"], 2)
        out["at_recorded_machine_two_figure_processes_s"] = round(scale * two["run_s"], 2)
    return out


if __name__ == "__main__":
    result = run(quick="--quick" in sys.argv, baseline="--no-baseline" not in sys.argv)
    result["date"] = time.strftime("%Y-%m-%d %H:%M")
    text = json.dumps(result, indent=2) + "\n"
    OUT.write_text(text)
    print(text, end="")
