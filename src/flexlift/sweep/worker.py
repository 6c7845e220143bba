"""One case, run where a worker runs it: every control mode's ascent, reduced to a record.

What a case can do is data: a scenario whose combination of values is invalid
(:class:`~flexlift.errors.InputError`), numerics that fail
(:class:`~flexlift.errors.SimulationError`, with the partial results) and a case too large for
the memory (``MemoryError``, with the case's size) are recorded in the case's record
(``status`` and the mode's ``error``) and the sweep goes on. Any other exception is a
programming error, not a failure of the lift: :func:`run_case` raises :class:`CaseError` (the
case, the mode and the traceback, picklable for any engine), and the sweep stops with the
finished cases kept. The loss of the worker itself (a killed process, a lost machine) reaches
the caller, which retries the case once.

A record (JSON-ready)::

    {"case": 42, "values": {...}, "status": "completed" | "failed",
     "results": {"coordinated": {"status": "completed" | "failed", "error": None | "...",
                                 "outcome": "safe" | "unsafe" | "not_achieved" |
                                            "incomplete" | "failed", "cause": "...",
                                 "criteria": {...}, "headline": {...}, "reasons": {...},
                                 "events": [...], "arrival_s": 3900.1 | None,
                                 "scenario_checksum": "..."}},
     "warnings": [...], "elapsed_s": 0.14, "pid": 1234, "host": "..."}

A mode whose numerics failed has every criterion ``False`` and the outcome ``failed``
(whether the lift was safe is not known) and the headline numbers of its partial result.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
import time
import traceback
from dataclasses import dataclass

from flexlift.errors import InputError, SimulationError, clean

log = logging.getLogger(__name__)

#: events a sweep does not keep (one per bag); of every other kind it keeps the first
ROUTINE = ("arrival",)
#: most distinct warnings kept per case
MAX_WARNINGS = 5


class CaseError(Exception):
    """A programming error while running a case (not a result of the lift): the sweep stops.
    ``case`` its index, ``mode`` the control mode (None: building the scenario), ``trace``
    the worker's formatted traceback."""

    def __init__(self, case: int, mode: str | None, trace: str):
        super().__init__(case, mode, trace)
        self.case, self.mode, self.trace = case, mode, trace

    def __str__(self) -> str:
        last = self.trace.strip().splitlines()[-1] if self.trace.strip() else "an exception"
        where = f"case {self.case}" + (f" ({self.mode} control)" if self.mode else "")
        return (f"{where} raised {clean(last, 200)}: a programming error, not a result of the "
                "lift; the sweep stopped")


@dataclass(frozen=True)
class Task:
    """What a worker needs for one case: the base scenario, the case's dotted changes, the
    control modes, and whether to return the full datasets (``keep: histories``)."""

    index: int
    base: object  # Scenario (pickled once per task: ~4 kB)
    changes: dict
    controls: tuple
    histories: bool
    stop_beyond: bool = False  # end each run once beyond the model's validity (simulate's)


class _Collect(logging.Handler):
    """The warnings of one case: those logged by its own thread (a Dask worker may run
    several cases at once in threads)."""

    def __init__(self):
        super().__init__(level=logging.WARNING)
        self.lines: list[str] = []
        self.thread = threading.get_ident()

    def emit(self, record):
        if record.thread != self.thread:
            return
        line = clean(record.getMessage(), 300)
        if line not in self.lines and len(self.lines) < MAX_WARNINGS:
            self.lines.append(line)


_state = threading.local()


class OutsideCases(logging.Filter):
    """A filter for a terminal's log handler: drops the records a case logs while it runs in
    this process (``--workers 1``, Dask threads); they are in the case's record instead."""

    def filter(self, record) -> bool:
        return not getattr(_state, "in_case", False)


_own = {"process": False, "forgot_dask": False}


def own_process() -> None:
    """Called in each worker process flexlift starts for itself (the local pool's
    initializer): before its first xarray Dataset (a sweep keeping histories), xarray is told
    that Dask is not about (:func:`flexlift.sweep.nodask.forget_dask`; with Dask installed it
    would import it to ask); never done in the user's own process (``--workers 1``)."""
    _own["process"] = True


def _before_dataset() -> None:
    if _own["process"] and not _own["forgot_dask"]:
        from flexlift.sweep.nodask import forget_dask

        _own["forgot_dask"] = True
        forget_dask()


def _quiet_child() -> None:
    """In a worker process nobody configured (a Dask worker), flexlift's warnings would reach
    Python's last-resort handler and the terminal: they belong to the case's record only."""
    import multiprocessing

    root = logging.getLogger("flexlift")
    if multiprocessing.parent_process() is not None and not root.handlers:
        root.addHandler(logging.NullHandler())
        root.propagate = False


def run_case(task: Task) -> tuple[dict, dict]:
    """Run one case; returns (record, {mode: xarray Dataset} when histories are kept)."""
    t0 = time.perf_counter()
    _quiet_child()
    collect = _Collect()
    root = logging.getLogger("flexlift")
    root.addHandler(collect)
    _state.in_case = True
    record = {"case": task.index, "values": dict(task.changes), "status": "completed",
              "results": {}, "warnings": [], "elapsed_s": None, "pid": os.getpid(),
              "host": socket.gethostname()}
    datasets = {}
    try:
        try:
            scenario = task.base.with_changes(**task.changes)
        except InputError as exc:
            msg = f"invalid scenario: {clean(str(exc), 300)}"
            record["status"] = "failed"
            record["results"] = {m: _failed(msg) for m in task.controls}
            return record, datasets
        except Exception:
            raise CaseError(task.index, None, traceback.format_exc()) from None
        for mode in task.controls:
            try:
                res, ds = _one_mode(scenario, mode, task.stop_beyond, not task.histories)
            except Exception:
                raise CaseError(task.index, mode, traceback.format_exc()) from None
            record["results"][mode] = res
            if task.histories and ds is not None:
                datasets[mode] = ds
            if res["status"] != "completed":
                record["status"] = "failed"
    finally:
        _state.in_case = False
        root.removeHandler(collect)
        record["warnings"] = collect.lines
        record["elapsed_s"] = round(time.perf_counter() - t0, 4)
    return record, datasets


def _failed(msg: str, partial=None) -> dict:
    out = {"status": "failed", "error": msg, "criteria": {}, "headline": {}, "reasons": {},
           "events": [], "scenario_checksum": None}
    if partial is not None:
        out.update(_digest(partial))
        out["criteria"] = {k: False for k in out["criteria"]}
    out.update(outcome="failed", cause=msg)
    return out


def _size(scenario) -> str:
    """The size of a case, for an out-of-memory record."""
    sim = scenario.simulation
    steps = sim.run_length_s / sim.time_step_s
    bags = scenario.lift.bags
    n_bags = (sum(b.count for b in bags) if bags is not None else
              "the layout's") if scenario.pipe is None else "the pipe's"
    return (f"{scenario.hull.elements:,} elements, {n_bags} bags, {steps:,.0f} time steps of "
            f"{sim.time_step_s:g} s, {sim.retained_flexible_modes} retained flexible modes")


def _one_mode(scenario, mode: str, stop_beyond: bool = False,
              summary_only: bool = False) -> tuple[dict, object]:
    """One control mode's ascent of a case: (its result's digest, its dataset; a plain
    :class:`~flexlift.ascent.result.Frame` when ``summary_only``, for ``keep: summary``)."""
    from flexlift.ascent import simulate
    from flexlift.sweep.plants import plant_for

    if not summary_only:
        _before_dataset()
    try:
        result = simulate(scenario, control=mode, plant=plant_for(scenario, mode),
                          stop_beyond=stop_beyond, summary_only=summary_only)
    except SimulationError as exc:
        partial = exc.partial
        return _failed(clean(str(exc), 300), partial), getattr(partial, "dataset", None)
    except InputError as exc:
        return _failed(f"invalid scenario: {clean(str(exc), 300)}"), None
    except MemoryError:
        return _failed(f"out of memory ({_size(scenario)})"), None
    out = {"status": "completed", "error": None, **_digest(result)}
    return out, result.dataset


def _digest(result) -> dict:
    seen, events = set(), []
    for e in result.events:
        if e["kind"] not in ROUTINE and e["kind"] not in seen:
            seen.add(e["kind"])
            events.append({"time_s": e["time_s"], "kind": e["kind"], "bag": e["bag"]})
    outcome = result.outcome
    return {"outcome": outcome.get("kind"), "cause": outcome.get("cause"),
            "criteria": dict(result.criteria), "headline": dict(result.headline),
            "reasons": dict(result.reasons), "events": events, "arrival_s": _arrival(result),
            "scenario_checksum": result.dataset.attrs.get("scenario_checksum")}


def _arrival(result) -> float | None:
    """When the last bag first came within the tolerance of the target [s]; None unless
    every bag did."""
    import numpy as np

    arr = getattr(result.dataset, "arrival_time", None)
    values = None if arr is None else np.asarray(arr.values)
    if values is None or values.size == 0 or not np.all(np.isfinite(values)):
        return None
    return round(float(np.max(values)), 3)
