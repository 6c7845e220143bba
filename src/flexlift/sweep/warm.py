"""Importing this module loads the compiled ascent (from numba's on-disk cache) in this process.

The local worker pool preloads it in its fork server (:mod:`.executors`), so every worker
forked from there starts with the machine code in memory: the load (about a second, more
on a busy machine) is paid once per sweep instead of once per worker and per new pool (a
pool is renewed after a worker dies). A failure here only means each worker loads the code
itself on its first case.

The server's xarray is also told that Dask is not about (:func:`flexlift.sweep.nodask.
forget_dask`): with Dask installed, xarray otherwise imports ``dask`` and ``dask.array`` at its
first Dataset only to ask whether each array is a Dask array (0.1-0.5 s of the warm-up).

Last, the server's objects are frozen (:func:`gc.freeze`): the workers forked from it never
scan them in their own garbage collections, nor write to their pages.
"""

from __future__ import annotations

import gc
import logging

log = logging.getLogger(__name__)


def warm_up() -> bool:
    """Run a one-second ascent of the tanker in each control mode's plant; True when done."""
    try:
        from flexlift.ascent import simulate
        from flexlift.scenario import load_scenario
        from flexlift.sweep.nodask import forget_dask

        forget_dask()
        tanker = load_scenario("tanker")
        for mode in ("coordinated", "paper"):
            simulate(tanker, control=mode, duration=1.0)
    except Exception:  # never stop a sweep for this: the workers load the code themselves
        log.debug("warm-up failed", exc_info=True)
        return False
    return True


WARM = warm_up()
gc.freeze()
