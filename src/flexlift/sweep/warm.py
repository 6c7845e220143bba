"""Importing this module loads the compiled ascent (from numba's on-disk cache) in this process.

The local worker pool preloads it in its fork server (:mod:`.executors`), so every worker
forked from there starts with the machine code in memory: the load (about a second, more
on a busy machine) is paid once per sweep instead of once per worker and per new pool (a
pool is renewed after a worker dies). A failure here only means each worker loads the code
itself on its first case.

The server's xarray is also told that no Dask array exists (:func:`no_dask_arrays`): with Dask
installed, xarray otherwise imports ``dask.array`` (half a second, more than a third of the
warm-up) at its first Dataset only to ask whether each array is one.
"""

from __future__ import annotations

import logging
import sys

log = logging.getLogger(__name__)


def no_dask_arrays() -> bool:
    """Tell this process's xarray that Dask arrays do not exist here, unless ``dask.array`` is
    imported already; True when done. A Dask array cannot exist in a process that never
    imported ``dask.array``, and the sweep's workers build their results from numpy arrays
    only: xarray's answer ("not a Dask array") is the same, without the import. Harmless when
    xarray's internals differ (then nothing is changed)."""
    if "dask.array" in sys.modules:
        return False
    try:
        from packaging.version import Version
        from xarray.namedarray import pycompat

        none = object.__new__(pycompat.DuckArrayModule)  # "not installed", as xarray says it
        none.module, none.version, none.type, none.available = None, Version("0.0.0"), (), False
        return pycompat._cached_duck_array_modules.setdefault("dask", none) is none
    except Exception:  # another xarray: it imports dask.array itself, as before
        log.debug("xarray's Dask check left as it is", exc_info=True)
        return False


def warm_up() -> bool:
    """Run a one-second ascent of the tanker in each control mode's plant; True when done."""
    try:
        from flexlift.ascent import simulate
        from flexlift.scenario import load_scenario

        no_dask_arrays()
        tanker = load_scenario("tanker")
        for mode in ("coordinated", "paper"):
            simulate(tanker, control=mode, duration=1.0)
    except Exception:  # never stop a sweep for this: the workers load the code themselves
        log.debug("warm-up failed", exc_info=True)
        return False
    return True


WARM = warm_up()
