"""One BLAS thread where flexlift's own work is small or already one per core.

Numpy's and scipy's OpenBLAS start a thread per core for their products and solves. On the
small dense problems of a plan (the balanced layout's SLSQP refinement: tens of unknowns) those
threads only wait on each other, and on a busy machine each wait is a time slice: a 25-bag plan
built up to 20 times slower with both cores busy. Two ways to keep to one thread, neither of
which touches the calling process's environment:

- :func:`one_blas_thread`: a context manager that limits the BLAS libraries loaded in this
  process to one thread (threadpoolctl's ``threadpool_limits``) and restores their counts after;
- :data:`WORKER_ENV` and :func:`pin_worker_environment`: the variables every BLAS reads when it
  loads, set in a process flexlift starts itself (the sweep's fork server, before it imports
  numpy: :mod:`flexlift.sweep.executors`), so its workers run one thread each.

This module imports nothing heavy at import time (threadpoolctl is imported when used): it
runs before numpy loads.
"""

from __future__ import annotations

import os

#: the thread-count variables of OpenBLAS, OpenMP, MKL, BLIS, Accelerate and numexpr
WORKER_ENV = {name: "1" for name in (
    "OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS", "BLIS_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")}


def pin_worker_environment() -> None:
    """Set :data:`WORKER_ENV` in this process: only in a process flexlift started for its own
    work, before numpy is imported there (the BLAS reads them when it loads)."""
    os.environ.update(WORKER_ENV)


def blas_threads() -> list[int]:
    """The thread count of each BLAS library loaded in this process."""
    from threadpoolctl import threadpool_info

    return [int(i["num_threads"]) for i in threadpool_info() if i.get("user_api") == "blas"]


def one_blas_thread():
    """A context manager: the block runs with every loaded BLAS on one thread; their counts
    are restored after (threadpoolctl)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")
