"""Imported first in a process flexlift starts for its own work (the sweep's fork server,
:class:`flexlift.sweep.executors.Processes`), before numpy loads there: one BLAS thread per
process (:func:`flexlift._threads.pin_worker_environment`), the workers being one per core
already. Never imported in the user's own process: it sets that process's environment.

The fork server ends when the sweep's process has gone: its exit freezes the garbage
collector's objects first (:func:`gc.freeze`, an atexit handler), so that tearing down its
modules (numba, xarray, pandas) does not run collections over its whole heap (over half a
second of CPU after the sweep, holding the sweep's standard streams open meanwhile). Its
workers leave with ``os._exit`` and run no atexit handler.
"""

import atexit
import gc

from flexlift._threads import pin_worker_environment

pin_worker_environment()
atexit.register(gc.freeze)
