"""Several runs of the compiled loop advanced together: one compiled call per chunk for all
of them (docs/theory/loop.md#batch).

An estimator's ensemble or a designer's batch of candidates is many runs of one loop. Run one
by one, each chunk of each run is a call from Python into the compiled loop, and each call
checks the types of its records (~45 µs; :data:`flexlift.ascent.loop.QUIET_CHUNK_STEPS`).
:func:`run_batch` takes the steps of :meth:`flexlift.ascent.loop.Ascent.run` for every run
of a batch at once: between chunks each run applies its faults, draws its noise and grows its
record (:meth:`~flexlift.ascent.loop.Ascent.next_stop`), then
:func:`flexlift.ascent.kernel.advance_many` advances all of them, each to its own stop, in
one compiled call. Runs whose records have the same numba type (the same plant kind and
control: any number of bags, elements or modes) share a call; others go in a call of their
own. The numbers are those of the runs one by one, to the last bit (tests/test_batch.py).
"""

from __future__ import annotations

import weakref

import numba
import numpy as np

from flexlift.ascent import kernel
from flexlift.ascent.loop import Ascent
from flexlift.ascent.result import Result
from flexlift.ascent.state import RET_NEED_U
from flexlift.errors import SimulationError

__all__ = ["advance_batch", "loop_type", "run_batch"]

#: each run's loop inputs and their numba type as last found (:func:`loop_type`), by run
_TYPES: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def run_batch(runs: list[Ascent], summary_only: bool = True) -> list[Result | SimulationError]:
    """Run every :class:`~flexlift.ascent.loop.Ascent` of ``runs`` to its end, advancing
    them together.

    Parameters
    ----------
    runs : list of Ascent
        The runs, each made as :func:`flexlift.ascent.simulate` makes its own (its scenario,
        plant, control mode, duration and supervisor), not yet run.
    summary_only : bool, optional
        Results as plain frames, not xarray Datasets (default True: what a batch reads).

    Returns
    -------
    list
        Per run, in order, its :class:`~flexlift.ascent.result.Result`, or the
        :class:`~flexlift.errors.SimulationError` it ended with (its ``partial`` the result
        up to then).
    """
    for run in runs:
        run.start()
    advance_batch(runs)
    out: list[Result | SimulationError] = []
    for run in runs:
        try:
            out.append(run.finish(summary_only))
        except SimulationError as error:
            out.append(error)
    return out


def advance_batch(runs: list[Ascent], until: int | None = None,
                  ended: list[bool] | None = None) -> list[bool]:
    """Advance every started run of ``runs`` (:meth:`~flexlift.ascent.loop.Ascent.start`)
    to step ``until`` (exclusive; default: to its end), together, chunk by chunk; returns,
    per run, whether it has ended (a stop, its last step). Runs flagged in ``ended`` are
    left as they are. An estimator advances its ensemble from one set of readings to the
    next so: ``until`` one past the step of the readings' row."""
    done = [False] * len(runs) if ended is None else list(ended)
    active = [i for i in range(len(runs)) if not done[i]]
    while active:
        stops = {i: runs[i].next_stop(until) for i in active}
        for i in active:
            if stops[i] is None and runs[i].state.counters[0] > runs[i].settings.n_steps:
                done[i] = True
        active = [i for i in active if stops[i] is not None]
        codes = _advance_together(runs, {i: stops[i] for i in active})
        for i in list(active):
            if runs[i].after_chunk(codes[i]):
                done[i] = True
                active.remove(i)
    return done


def _advance_together(runs: list[Ascent], stops: dict[int, int]) -> dict[int, int]:
    """Each run ``i`` of ``stops`` advanced to ``stops[i]``, those of one numba type in one
    compiled call; a run whose loop asks for its external supervisor (``RET_NEED_U``) is
    given it and goes on in the next call. Returns each run's code."""
    done: dict[int, int] = {}
    pending = list(stops)
    while pending:
        groups: dict[object, list[int]] = {}
        inputs = {}
        for i in pending:
            inputs[i], kind = loop_type(runs[i])
            groups.setdefault(kind, []).append(i)
        pending = []
        for members in groups.values():
            loops = kernel.loops_of(inputs[members[0]])  # compiled, cached: not List's own
            for i in members[1:]:
                kernel.loops_append(loops, inputs[i])
            k_stops = np.array([stops[i] for i in members], dtype=np.int64)
            codes = np.zeros(len(members), dtype=np.int64)
            kernel.advance_many(loops, k_stops, codes)
            for i, code in zip(members, codes.tolist()):
                if code == RET_NEED_U:
                    runs[i].external_supervisor()
                    pending.append(i)
                else:
                    done[i] = code
    return done


def loop_type(run: Ascent) -> tuple:
    """``run``'s :meth:`~flexlift.ascent.loop.Ascent.inputs` and their numba type.

    ``numba.typeof`` walks the inputs' ~150 arrays in Python (about a millisecond: on the
    tanker's ensemble more than its compiled chunks take). The inputs are seven records,
    each an immutable tuple of arrays and numbers, and a run changes one only by putting a
    new record in its place (a grown record, a chunk's noise, a fork's copies): inputs whose
    seven records are the very objects of the last call have the last call's type. (An
    array's type also holds its flags; one made read-only in place would keep a stale type
    here, and the compiled call then refuses it: nothing in flexlift does so.)"""
    inputs = run.inputs()
    known = _TYPES.get(run)
    if known is not None and all(a is b for a, b in zip(known[0], inputs, strict=True)):
        return inputs, known[1]
    kind = numba.typeof(inputs)
    _TYPES[run] = (inputs, kind)
    return inputs, kind
