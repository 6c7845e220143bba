"""Running a sweep: cases out to an engine, records into the folder as they finish, and the
results at the end.

:func:`run_sweep` skips the cases its folder already holds (a rerun of an interrupted sweep),
keeps at most ``engine.window`` cases in flight, and writes each case's record as soon as it
returns. A case whose worker died (a killed process, a lost Dask worker) is retried once, on
its own (so that a case that kills its worker cannot take an innocent one down with it
twice); if it dies again it is recorded as lost. A case that raises a programming error
(:class:`~flexlift.sweep.worker.CaseError`) stops the sweep like Ctrl-C (or any exception,
such as a lost Dask scheduler: :class:`~flexlift.sweep.executors.SchedulerLost`): the engine
stops and every finished case stays in the folder for the rerun.

A Monte Carlo with ``until_halfwidth`` H runs block by block (``block`` cases, in order) and
stops at the first block's end where every probability (each outcome's and the lift
failing's, per control mode) has a 95 % Wilson half-width of at most H, or at ``samples``;
its results are those of the cases up to that block's end, whatever else the folder holds,
so the stop, and the results, are the same on any engine and after any interruption.
"""

from __future__ import annotations

import collections
import concurrent.futures as cf
import json
import logging
import time
from dataclasses import dataclass, field
from pathlib import Path

from flexlift import __version__
from flexlift.errors import clean
from flexlift.sweep import aggregate as agg
from flexlift.sweep.cases import Case, case_name, case_scenario, changes, make_cases
from flexlift.sweep.executors import Serial
from flexlift.sweep.spec import SweepSpec
from flexlift.sweep.store import SweepFolder
from flexlift.sweep.worker import CaseError, Task, run_case

log = logging.getLogger(__name__)
#: how often the coordinator wakes up while waiting for a case (progress stays live) [s]
POLL_S = 0.5
#: most failed cases listed in summary.json and the report (results.nc has them all)
MAX_LISTED = 100


@dataclass
class SweepResult:
    """A finished sweep: its records by case index, what was run now, and the summary."""

    spec: SweepSpec
    out: Path
    engine: str
    records: dict
    skipped: int
    ran: int
    elapsed_s: float
    summary: dict = field(default_factory=dict)

    @property
    def completed(self) -> int:
        return sum(r["status"] == "completed" for r in self.records.values())

    @property
    def failed(self) -> int:
        return sum(r["status"] != "completed" for r in self.records.values())

    def most_common_failure(self) -> tuple[str, int] | None:
        """The most common failure message and how many cases it ended, or None."""
        msgs = collections.Counter(failure_message(r) for r in self.records.values()
                                   if r["status"] != "completed")
        return msgs.most_common(1)[0] if msgs else None


def failure_message(record: dict) -> str:
    if record["status"] == "lost":
        return record.get("error") or "lost"
    errs = [f"{m}: {res['error']}" for m, res in record.get("results", {}).items()
            if res.get("status") != "completed"]
    return errs[0] if errs else "failed"


def run_sweep(spec: SweepSpec, out, engine=None, progress=None) -> SweepResult:
    """Run (or resume) ``spec`` into the folder ``out`` and write its results there.

    Finished cases already in ``out`` are kept and skipped; the folder gets ``results.nc``,
    ``summary.json`` and ``report.html`` (``docs/guide/sweeps.md``).

    Parameters
    ----------
    spec : SweepSpec
        The validated SPEC (:func:`~flexlift.sweep.spec.load_spec`,
        :func:`~flexlift.sweep.spec.parse_spec`).
    out : str or path-like
        The output folder (created; a folder of another SPEC is refused).
    engine : optional
        An engine of :mod:`flexlift.sweep.executors` (default: local processes, one per
        core); it is closed when the sweep ends.
    progress : callable, optional
        ``progress(done, total, failed)``, called as cases finish.

    Returns
    -------
    SweepResult
        The records by case, ``completed`` and ``failed`` counts, and ``summary`` (the
        failure probabilities with their Wilson intervals, the sensitivities).

    Examples
    --------
    A grid of two breakout times, each ascent cut at 50 s, in this process:

    >>> import tempfile
    >>> from flexlift.sweep import parse_spec, run_sweep
    >>> from flexlift.sweep.executors import Serial
    >>> spec = parse_spec({"base": "tanker", "control": "coordinated",
    ...                    "set": {"simulation.duration_s": 50},
    ...                    "grid": {"seabed.breakout_time_s": [200, 400]}})
    >>> spec.n_cases
    2
    >>> with tempfile.TemporaryDirectory() as folder:
    ...     result = run_sweep(spec, folder + "/out", engine=Serial())
    >>> result.completed, result.failed
    (2, 0)
    """
    t0 = time.perf_counter()
    cases = make_cases(spec)
    names = {c.index: case_name(spec, c.index) for c in cases}
    try:
        with SweepFolder.open(out, spec) as folder:
            records = folder.finished(names)
            skipped = len(records)
            if progress is not None:
                progress(len(records), len(cases), _failures(records))
            importing = None
            if not isinstance(engine, Serial) and len(records) < len(cases):
                importing = _import_meanwhile(engine)
            engine, ran_now, upto = _run_blocks(spec, cases, names, folder, records, engine,
                                                progress)
            if spec.halfwidth is not None:
                cases = cases[:upto]
                records = _prefix(records, upto)
                skipped = min(skipped, len(records))
            result = SweepResult(spec, folder.path, getattr(engine, "name", "none"), records,
                                 skipped, ran_now, round(time.perf_counter() - t0, 3))
            if engine is not None:  # the cases are done: the results need no engine
                engine.close()
                engine = None
            if importing is not None:  # the results need them (and a process to fork alone)
                importing.join()
            _write_results(result, cases, names, folder)
            folder.finish()
    except BaseException:
        if engine is not None:
            engine.close(cancel=True)
        raise
    return result


def _run_blocks(spec, cases, names, folder, records, engine, progress):
    """Run the cases not yet in ``records`` block by block (one block unless the SPEC asks
    for a half-width, which is checked at each block's end); the engine is made at the first
    case to run. Returns (the engine or None, the cases run now, the cases up to the last
    block run)."""
    from flexlift.sweep.executors import make_engine

    ran, upto, made = 0, len(cases), None
    try:
        for block in _blocks(spec, cases):
            todo = [c for c in block if c.index not in records]
            if engine is None and todo:
                engine = made = make_engine()
            if todo:
                _execute(engine, spec, todo, names, folder, records, folder.inc.run_id,
                         progress)
                ran += len(todo)
            if spec.halfwidth is not None:
                upto = block[-1].index + 1
                if halfwidth_reached(_prefix(records, upto), spec.controls, spec.halfwidth):
                    break
    except BaseException:
        if made is not None:  # the caller closes an engine it gave
            made.close(cancel=True)
        raise
    return engine, ran, upto


#: what the results need and the coordinator imports while the workers run the cases
TAIL_MODULES = ("xarray", "flexlift.sweep.report", "scipy.io")
#: and with Dask about (a Dask engine, or Dask imported before): xarray asks it for Dask arrays
#: at the first Dataset, and for a Dask client in its netCDF writer (over half a second);
#: without Dask it is not imported at all (:mod:`flexlift.sweep.nodask`)
DASK_TAIL = ("dask.array", "dask.distributed")


def _import_meanwhile(engine):
    """Import :data:`TAIL_MODULES` (xarray, matplotlib, the netCDF writer; :data:`DASK_TAIL`
    with Dask about) in a background thread: the coordinator waits on its workers anyway,
    so the results are not held up by them. Returns the thread."""
    import importlib
    import sys
    import threading

    names = TAIL_MODULES
    if getattr(engine, "name", None) == "dask" or "dask" in sys.modules:
        names += DASK_TAIL

    def load():
        for name in names:
            try:
                importlib.import_module(name)
            except Exception:  # the results import it again, and report any error there
                log.debug("could not import %s ahead", name, exc_info=True)

    thread = threading.Thread(target=load, name="flexlift-import", daemon=True)
    thread.start()
    return thread


def _blocks(spec: SweepSpec, cases: list[Case]):
    """The cases in the blocks at whose ends a sweep run until a half-width may stop (all
    the cases in one block otherwise)."""
    if spec.halfwidth is None:
        yield cases
        return
    for b0 in range(0, len(cases), spec.block):
        yield cases[b0:b0 + spec.block]


def _prefix(records: dict, upto: int) -> dict:
    return {i: r for i, r in records.items() if i < upto}


def halfwidths(records: dict, modes) -> dict:
    """{probability: its 95 % Wilson half-width}: each outcome's but safe, and the lift
    failing's, per control mode (a name ``mode.outcome``)."""
    out = {}
    for m in modes:
        ws = {**agg.outcome_probability(records, [m])[m],
              agg.ALL: agg.failure_probability(records, [m])[m][agg.ALL]}
        for k, w in ws.items():
            out[f"{m}.{k}"] = 0.5 if w["p"] is None else (w["high"] - w["low"]) / 2
    return out


def halfwidth_reached(records: dict, modes, h: float) -> bool:
    """Whether every probability's half-width (:func:`halfwidths`) is at most ``h``."""
    return max(halfwidths(records, modes).values(), default=0.5) <= h


#: cases whose cost is estimated to bound a sweep's per-case cost (spread over the sweep)
COST_SAMPLE = 50


def estimate_sweep(spec: SweepSpec, workers: int) -> tuple[float, float]:
    """(the largest estimated cost of a case [s], the sweep's [s] on ``workers``): each case
    is an ascent per control mode (:func:`flexlift.scenario.cost.estimate`), priced on up to
    ``COST_SAMPLE`` cases spread over the sweep; cases x that cost / workers."""
    from flexlift.scenario.cost import estimate

    cases = make_cases(spec)
    if not cases:
        return 0.0, 0.0
    step = max(1, len(cases) // COST_SAMPLE)
    per = max(estimate(case_scenario(spec, c)).ascent_s for c in cases[::step][:COST_SAMPLE + 1])
    per *= len(spec.controls)
    return per, per * len(cases) / max(1, int(workers))


def _failed(record: dict) -> int:
    return int(record["status"] != "completed")


def _failures(records: dict) -> int:
    return sum(map(_failed, records.values()))


def _execute(engine, spec, todo: list[Case], names, folder, records, run_id, progress,
             fn=None, aside=None) -> None:
    """Run ``todo`` on ``engine`` (each case a :class:`~flexlift.sweep.worker.Task` given to
    ``fn``, by default :func:`~flexlift.sweep.worker.run_case`), writing each record into
    ``folder`` and ``records`` as it returns; ``progress(done, total, failed)``;
    ``aside(case index, record)`` first, for what ``fn`` returned beside the record (it may
    take it out of the record: the rest is written)."""
    fn = fn or run_case  # looked up now (a test may replace the module's run_case)
    queue = collections.deque(todo)
    suspects: collections.deque[Case] = collections.deque()
    attempts: dict[int, int] = collections.Counter()
    inflight: dict[cf.Future, Case] = {}
    total = len(names)
    failed = _failures(records)  # then counted as cases end (a recount per case: n^2 / 2)
    while queue or suspects or inflight:
        # a suspect (its worker died once) runs alone, when nothing else is in flight
        while suspects and not inflight:
            _submit(engine, spec, suspects.popleft(), attempts, inflight, fn)
        while queue and not suspects and len(inflight) < engine.window:
            _submit(engine, spec, queue.popleft(), attempts, inflight, fn)
        done, _ = cf.wait(list(inflight), timeout=POLL_S, return_when=cf.FIRST_COMPLETED)
        bug = None
        for f in done:
            case = inflight.pop(f)
            try:
                record, datasets = f.result()
            except CaseError as exc:  # a programming error: stop, once the others are kept
                bug = bug or exc
                continue
            except Exception as exc:  # the case never returned (run_case records its errors)
                if not worker_lost(exc):  # e.g. flexlift cannot be imported on a Dask worker
                    record, datasets = _broken(case, exc), {}
                elif attempts[case.index] >= 2:
                    record, datasets = _lost(case, exc), {}
                else:
                    log.info("case %d: worker lost (%s); retrying it once", case.index, exc)
                    suspects.append(case)
                    continue
            else:
                if aside is not None:  # what the worker returned beside the record
                    aside(case.index, record)
            record.update(values=dict(case.values), noise_seed=case.seed, run_id=run_id,
                          attempts=attempts[case.index])
            records[case.index] = folder.write_case(names[case.index], record, datasets)
            failed += _failed(records[case.index])
            if progress is not None:
                progress(len(records), total, failed)
        if bug is not None:
            raise bug
        check = getattr(engine, "check", None)
        if check is not None:  # a lost Dask scheduler ends the sweep (executors.SchedulerLost)
            check()


def _submit(engine, spec, case: Case, attempts, inflight, fn) -> None:
    attempts[case.index] += 1
    task = Task(case.index, spec.base, changes(spec, case), spec.controls, spec.keep == "histories")
    inflight[engine.submit(fn, task)] = case


#: how engines report a worker that died under a case (the process killed, the machine lost)
LOST = ("BrokenProcessPool", "BrokenExecutor", "KilledWorker", "CommClosedError",
        "CancelledError", "FutureCancelledError")


def worker_lost(exc: BaseException) -> bool:
    """Whether ``exc`` (from a case's future) says its worker died, rather than that the
    worker could not run the case at all."""
    return any(t.__name__ in LOST for t in type(exc).__mro__)


def _broken(case: Case, exc: Exception) -> dict:
    """A case its worker could not run (not retried now; a rerun tries it again)."""
    why = clean(f"{type(exc).__name__}: {exc}", 240)
    return {"case": case.index, "status": "lost", "results": {}, "warnings": [],
            "elapsed_s": None, "error": f"lost: the worker could not run the case ({why})"}


def _lost(case: Case, exc: Exception) -> dict:
    why = clean(str(exc), 200) or type(exc).__name__
    return {"case": case.index, "status": "lost", "results": {}, "warnings": [],
            "elapsed_s": None, "error": f"lost: its worker died twice ({type(exc).__name__}: {why})"}


# --------------------------------------------------------------------------- the results
def _write_results(result: SweepResult, cases, names, folder) -> None:
    """results.nc, the rerun files, summary.json and report.html. The report's figures (most
    of this work) are drawn meanwhile by a forked copy of this process where that is safe
    and a core is free (:mod:`flexlift.sweep.aside`; the convergence figures here), else
    here: the same figures either way."""
    from flexlift.plumbing.atomic import write_json, write_text
    from flexlift.sweep import aside
    from flexlift.sweep.report import figure_makers, render_figures, render_report

    spec = result.spec
    summary = summarize(result)
    result.summary = summary
    makers = figure_makers(result, summary)
    here = {k: f for k, f in makers.items() if k.startswith("convergence:")}
    copy = None
    if aside.spare_core():  # else a copy would share this process's core: no faster
        copy = aside.start(render_figures, {k: f for k, f in makers.items() if k not in here})
    try:
        _write_dataset(result, cases, names, folder, summary)
        rerun = _write_reruns(spec, cases, names, summary, folder)
        write_json(folder.path / "summary.json", summary)
        pngs = render_figures(here)
        if copy is not None:
            pngs.update(copy.result() or {})  # what it did not draw is drawn here
    finally:
        if copy is not None:
            copy.close()
    write_text(folder.path / "report.html", render_report(result, summary, rerun, pngs))


def _write_dataset(result: SweepResult, cases, names, folder, summary) -> None:
    """results.nc: the sweep as one dataset (:func:`flexlift.sweep.aggregate.build_dataset`)."""
    from flexlift.plumbing.atomic import atomic_file
    from flexlift.sweep.nodask import without_dask

    spec, records = result.spec, result.records
    attrs = {"title": f"flexlift sweep of {spec.base.name}", "flexlift_version": __version__,
             "spec_checksum": spec.checksum(), "base_checksum": spec.base.checksum(),
             "method": spec.method, "engine": result.engine,
             "failure_probability": json.dumps(summary["by_control"])}
    if spec.seed is not None:
        attrs.update(seed=str(spec.seed), samples=int(spec.samples))
    with without_dask():  # no Dask in this process: xarray need not import it to hear so
        ds = agg.build_dataset(spec, cases, names, records, attrs)
        folder.claim("results.nc", "summary.json", "report.html")
        with atomic_file(folder.path / "results.nc", suffix=".nc") as tmp:
            ds.to_netcdf(tmp, engine="scipy")


def _write_reruns(spec, cases, names, summary, folder) -> dict[int, str]:
    """The scenario files of the worst and the failed cases, ``rerun/case_NNNN.yaml``; those
    of an earlier run of this sweep that are no longer wanted are removed (only files the
    folder's marker lists as this sweep's)."""
    from flexlift.plumbing.atomic import write_text

    wanted = set()
    for mode_worst in summary["worst"].values():
        wanted |= {w["case"] for w in mode_worst}
    wanted |= {w["case"] for w in summary["failures"][: spec.worst]}
    out = {i: f"rerun/{names[i]}.yaml" for i in sorted(wanted)}
    if out:
        folder.claim("rerun", *out.values())
    by_index = {c.index: c for c in cases}
    for i, rel in out.items():
        write_text(folder.path / rel, case_scenario(spec, by_index[i]).to_yaml())
    index_of = {f"rerun/{names[c.index]}.yaml": c.index for c in cases}
    for rel in sorted(folder.listed()):
        i = index_of.get(rel)
        if i is not None and rel not in out.values():  # an earlier run's, no longer wanted
            folder.remove_own(rel, case_scenario(spec, by_index[i]).to_yaml().encode())
    return out


def summarize(result: SweepResult) -> dict:
    """summary.json: the counts, the failure probabilities, the influences, the worst cases."""
    spec, records = result.spec, result.records
    modes, keys = spec.controls, spec.keys
    fp = agg.failure_probability(records, modes)
    op = agg.outcome_probability(records, modes)
    sens = agg.sensitivity(records, modes, keys)
    one = len(modes) == 1
    flat_fp = {(c if one else f"{m}.{c}"): v for m in modes for c, v in fp[m].items()}
    flat_sens = {(c if one else f"{m}.{c}"): v for m in modes for c, v in sens[m].items()}
    worst = {m: [{"case": i, "name": case_name(spec, i), "values": records[i]["values"],
                  "failed": agg.failed_criteria(records[i]["results"][m], agg.criteria_names(records, m)),
                  "error": records[i]["results"][m].get("error"),
                  "outcome": agg.outcome_of(records[i]["results"][m]),
                  "cause": records[i]["results"][m].get("cause"),
                  "reasons": records[i]["results"][m].get("reasons", {}),
                  "headline": records[i]["results"][m].get("headline", {})}
                 for i in agg.worst_cases(records, m, spec.worst, spec.base)] for m in modes}
    failures = [{"case": i, "name": case_name(spec, i), "status": records[i]["status"],
                 "message": failure_message(records[i]), "values": records[i].get("values", {})}
                for i in sorted(records) if records[i]["status"] != "completed"][:MAX_LISTED]
    warnings = collections.Counter(w for r in records.values() for w in r.get("warnings", []))
    extra = {"convergence": agg.convergence(records, modes)}
    if spec.method == "sobol":  # its rows are not independent draws: no probability
        from flexlift.sweep.sobol import sobol_summary

        fp = {m: {} for m in modes}
        op = {m: {} for m in modes}
        flat_fp = {}
        extra = {"sobol": sobol_summary(spec, records)}
    if spec.study is not None:
        extra["study"] = {"name": spec.study.name, "sources": dict(spec.study.sources)}
    if spec.halfwidth is not None:
        extra.update(until_halfwidth=spec.halfwidth, block=spec.block,
                     stopped_at=len(records), halfwidths=halfwidths(records, modes))
    n_cases = spec.n_cases if spec.halfwidth is None else len(records)  # run to a stop
    return {**extra,
        "cases": n_cases, "completed": result.completed, "failed": result.failed,
        "lost": sum(r["status"] == "lost" for r in records.values()),
        "engine": result.engine, "failure_probability": flat_fp, "sensitivity": flat_sens,
        "out": str(result.out), "skipped": result.skipped, "ran": result.ran,
        "elapsed_s": result.elapsed_s, "base": spec.base.name, "base_ref": spec.base_ref,
        "method": spec.method, "samples": spec.samples, "seed": spec.seed,
        "controls": list(modes), "keys": list(keys), "spec_checksum": spec.checksum(),
        "outcome_probability": {(k if one else f"{m}.{k}"): v for m in modes
                                for k, v in op[m].items()},
        "by_control": fp, "outcomes_by_control": op, "sensitivity_by_control": sens,
        "headline_sensitivity": agg.headline_sensitivity(records, modes, keys),
        "worst": worst, "failures": failures,
        "warnings": [[w, n] for w, n in warnings.most_common(20)],
    }
