"""One case, run where a worker runs it: every control mode's ascent, reduced to a record.

:func:`run_case` never raises for anything a case can do: a scenario whose combination of
values is invalid, numerics that fail, or a bug in a control mode are recorded in the case's
record (``status`` and the mode's ``error``) and the sweep goes on. Only the loss of the worker
itself (a killed process, a lost machine) reaches the caller, which retries the case once.

A record (JSON-ready)::

    {"case": 42, "values": {...}, "status": "completed" | "failed",
     "results": {"coordinated": {"status": "completed" | "failed", "error": None | "...",
                                 "criteria": {...}, "headline": {...}, "reasons": {...},
                                 "events": [...],
                                 "scenario_checksum": "..."}},
     "warnings": [...], "elapsed_s": 0.14, "pid": 1234, "host": "..."}

A mode whose numerics failed has every criterion ``False`` (whether the lift was safe is not
known) and the headline numbers of its partial result.
"""

from __future__ import annotations

import logging
import os
import socket
import threading
import time
from dataclasses import dataclass

from flexlift.errors import InputError, SimulationError, clean

log = logging.getLogger(__name__)

#: events a sweep does not keep (one per bag); of every other kind it keeps the first
ROUTINE = ("arrival",)
#: most distinct warnings kept per case
MAX_WARNINGS = 5


@dataclass(frozen=True)
class Task:
    """What a worker needs for one case: the base scenario, the case's dotted changes, the
    control modes, and whether to return the full datasets (``keep: histories``)."""

    index: int
    base: object  # Scenario (pickled once per task: ~4 kB)
    changes: dict
    controls: tuple
    histories: bool


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
        for mode in task.controls:
            res, ds = _one_mode(scenario, mode)
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
    return out


def _one_mode(scenario, mode: str) -> tuple[dict, object]:
    from flexlift.ascent import simulate
    from flexlift.sweep.plants import plant_for

    try:
        result = simulate(scenario, control=mode, plant=plant_for(scenario, mode))
    except SimulationError as exc:
        partial = exc.partial
        return _failed(clean(str(exc), 300), partial), getattr(partial, "dataset", None)
    except InputError as exc:
        return _failed(f"invalid scenario: {clean(str(exc), 300)}"), None
    except MemoryError:
        return _failed("out of memory"), None
    except Exception as exc:  # a bug in one mode must not stop the sweep: recorded, logged
        log.debug("case failed", exc_info=True)
        return _failed(f"internal error: {type(exc).__name__}: {clean(str(exc), 200)}"), None
    out = {"status": "completed", "error": None, **_digest(result)}
    return out, result.dataset


def _digest(result) -> dict:
    seen, events = set(), []
    for e in result.events:
        if e["kind"] not in ROUTINE and e["kind"] not in seen:
            seen.add(e["kind"])
            events.append({"time_s": e["time_s"], "kind": e["kind"], "bag": e["bag"]})
    return {"criteria": dict(result.criteria), "headline": dict(result.headline),
            "reasons": dict(result.reasons), "events": events,
            "scenario_checksum": result.dataset.attrs.get("scenario_checksum")}
