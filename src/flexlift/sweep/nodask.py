"""xarray without importing Dask only to hear that there is no Dask object about.

With Dask installed, xarray imports it where it asks whether an array is a Dask array
(``dask`` and ``dask.array``, at a process's first Dataset) and whether a Dask scheduler
is running (``dask.distributed``, in ``to_netcdf``): 0.8 s of CPU in a sweep's coordinator,
0.1 s in the fork server's warm-up, for an answer known beforehand where Dask was never
imported: no Dask array, collection or scheduler can exist in a process that has not
imported ``dask``. The answers given here are xarray's own without Dask installed ("not a
Dask array", no scheduler), and only while ``dask`` is not imported: each guarded question
goes to xarray's own code once it is.

:func:`without_dask` does it for a block (the sweep's results, in a process that may be the
user's own: xarray is as it was afterwards); :func:`forget_dask` for the rest of a process
flexlift started itself (the fork server). Harmless when xarray's internals differ: what is
not found is left alone, and xarray imports Dask itself, as before.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import logging
import sys

log = logging.getLogger(__name__)

#: (module, function, its answer without Dask): xarray's questions that import Dask
GUARDED = (("xarray.namedarray.utils", "is_dask_collection", False),
           ("xarray.backends.locks", "get_dask_scheduler", None),
           ("xarray.backends.writers", "get_dask_scheduler", None))


def _no_dask_module():
    """xarray's record of Dask arrays as not installed (its duck-array module cache)."""
    from packaging.version import Version
    from xarray.namedarray import pycompat

    none = object.__new__(pycompat.DuckArrayModule)  # "not installed", as xarray says it
    none.module, none.version, none.type, none.available = None, Version("0.0.0"), (), False
    return pycompat._cached_duck_array_modules, none


def _guard(fn, answer):
    @functools.wraps(fn)
    def guarded(*args, **kwargs):
        if "dask" not in sys.modules:  # nothing of Dask can exist here
            return answer
        return fn(*args, **kwargs)

    guarded.__flexlift_guarded__ = fn
    return guarded


def _apply() -> list:
    """Install the guards; returns what to undo (empty when Dask is imported already)."""
    if "dask" in sys.modules:
        return []
    undo = []
    try:
        cache, none = _no_dask_module()
        if cache.setdefault("dask", none) is none:
            undo.append(("cache", cache, none))
        for module, name, answer in GUARDED:
            mod = importlib.import_module(module)
            fn = getattr(mod, name, None)
            if fn is None or hasattr(fn, "__flexlift_guarded__"):
                continue
            guarded = _guard(fn, answer)
            setattr(mod, name, guarded)
            undo.append(("attr", mod, name, fn, guarded))
    except Exception:  # another xarray: it imports Dask itself, as before
        log.debug("xarray's Dask questions left as they are", exc_info=True)
    return undo


def _restore(undo: list) -> None:
    for item in reversed(undo):
        if item[0] == "cache":
            _, cache, none = item
            if cache.get("dask") is none:
                del cache["dask"]
        else:
            _, mod, name, fn, guarded = item
            if getattr(mod, name, None) is guarded:
                setattr(mod, name, fn)


@contextlib.contextmanager
def without_dask():
    """Within the block, xarray does not import Dask to ask about Dask objects while Dask
    is not imported in this process (module docstring); as it was afterwards."""
    undo = _apply()
    try:
        yield
    finally:
        _restore(undo)


def forget_dask() -> bool:
    """For the rest of this process (one flexlift started for its own work): xarray does not
    import Dask to ask about Dask objects while Dask is not imported; True when done."""
    return bool(_apply())
