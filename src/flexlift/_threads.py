"""One BLAS thread where flexlift's own work is small or already one per core.

Numpy's and scipy's OpenBLAS start a thread per core for their products and solves. On the
small dense problems of a plan (the balanced layout's SLSQP refinement: tens of unknowns) those
threads only wait on each other, and on a busy machine each wait is a time slice: a 25-bag plan
built up to 20 times slower with both cores busy. Two ways to keep to one thread, neither of
which touches the calling process's environment:

- :func:`one_blas_thread`: a context manager that sets the OpenBLAS libraries already loaded
  in this process to one thread through their own ``*_set_num_threads`` (found by name in
  ``/proc/self/maps``, as threadpoolctl does; elsewhere, or with no OpenBLAS, it does
  nothing) and restores their counts after;
- :data:`WORKER_ENV` and :func:`pin_worker_environment`: the variables every BLAS reads when it
  loads, set in a process flexlift starts itself (the sweep's fork server, before it imports
  numpy: :mod:`flexlift.sweep.executors`), so its workers run one thread each.

This module imports nothing heavy (no numpy): it runs before numpy loads.
"""

from __future__ import annotations

import contextlib
import ctypes
import os

#: the thread-count variables of OpenBLAS, OpenMP, MKL, BLIS, Accelerate and numexpr
WORKER_ENV = {name: "1" for name in (
    "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")}

#: (get, set) symbol names of the OpenBLAS builds: upstream, numpy's ILP64 and scipy's
_SYMBOLS = (("openblas_get_num_threads", "openblas_set_num_threads"),
            ("openblas_get_num_threads64_", "openblas_set_num_threads64_"),
            ("scipy_openblas_get_num_threads64_", "scipy_openblas_set_num_threads64_"),
            ("scipy_openblas_get_num_threads", "scipy_openblas_set_num_threads"))


def pin_worker_environment() -> None:
    """Set :data:`WORKER_ENV` in this process: only in a process flexlift started for its own
    work, before numpy is imported there (the BLAS reads them when it loads)."""
    os.environ.update(WORKER_ENV)


def _openblas() -> list[tuple]:
    """(get, set) functions of each OpenBLAS library loaded in this process."""
    try:
        with open("/proc/self/maps") as f:
            paths = sorted({line.split(None, 5)[5].strip() for line in f
                            if line.count(" ") >= 5 and "openblas" in line.lower()})
    except OSError:
        return []
    found = []
    for path in paths:
        try:
            lib = ctypes.CDLL(path)
        except OSError:
            continue
        for get_name, set_name in _SYMBOLS:
            get, put = getattr(lib, get_name, None), getattr(lib, set_name, None)
            if get is not None and put is not None:
                get.restype, put.argtypes = ctypes.c_int, [ctypes.c_int]
                found.append((get, put))
                break
    return found


def blas_threads() -> list[int]:
    """The thread count of each OpenBLAS library loaded in this process."""
    return [int(get()) for get, _ in _openblas()]


@contextlib.contextmanager
def one_blas_thread():
    """Run the block with every loaded OpenBLAS on one thread; their counts restored after."""
    libs = _openblas()
    before = [int(get()) for get, _ in libs]
    for _, put in libs:
        put(1)
    try:
        yield
    finally:
        for (_, put), n in zip(libs, before):
            put(n)
