"""Importing this module loads the compiled ascent (from numba's on-disk cache) in this process.

The local worker pool preloads it in its fork server (:mod:`.executors`), so every worker
forked from there starts with the machine code in memory: the load (about a second, more
on a busy machine) is paid once per sweep instead of once per worker and per new pool (a
pool is renewed after a worker dies). A failure here only means each worker loads the code
itself on its first case.

The warm-up's runs record summaries only (no xarray Dataset), so the server never imports
xarray or pandas (0.4 s): a worker whose sweep keeps summaries never needs them; one that keeps
histories imports xarray at its first Dataset (:func:`flexlift.sweep.worker.own_process`).

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
        from flexlift.loads.scenario import load_scenario

        tanker = load_scenario("tanker")
        for mode in ("coordinated", "paper"):
            simulate(tanker, control=mode, duration=1.0, summary_only=True)
    except Exception:  # never stop a sweep for this: the workers load the code themselves
        log.debug("warm-up failed", exc_info=True)
        return False
    return True


WARM = warm_up()
gc.freeze()
