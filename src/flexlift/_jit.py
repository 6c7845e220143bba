"""The one compiler switch: ``@jit`` compiles a function with numba, cached on disk.

Every compiled function stays an ordinary Python function to its callers: tests call the same
law the simulation runs. The physical laws are written with NumPy's element-wise operations,
so one function serves floats (inside the compiled loop) and whole arrays (from Python);
numba compiles each kind of argument once.

The cache (``__pycache__`` beside the source, or numba's user-wide folder for a read-only
install) is stamped with a hash of *all* of flexlift's compiled modules, not only the
function's own file as numba does by default: the loop inlines the laws of other modules, so a
change to one law must recompile the loop (it does; the mutation check relies on it). The
compile cost is stated in the README; ``NUMBA_DISABLE_JIT=1`` runs everything interpreted.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba
from numba.core import caching

__all__ = ["jit"]

_PACKAGE = Path(__file__).resolve().parent
#: the modules whose code the compiled loop contains
_COMPILED = ("_jit.py", "_struct.py", "fuzzy/tables.py", "physics", "control", "ascent")


def _sources_stamp() -> str:
    """SHA-256 of the compiled modules' sources (the cache is valid while it is unchanged)."""
    h = hashlib.sha256(numba.__version__.encode())
    for name in _COMPILED:
        p = _PACKAGE / name
        for f in sorted(p.rglob("*.py")) if p.is_dir() else [p]:
            h.update(f.relative_to(_PACKAGE).as_posix().encode())
            h.update(f.read_bytes())
    return h.hexdigest()


_STAMP = _sources_stamp()


def _package_locator(base):
    class Locator(base):
        """numba's cache locator for flexlift's files, stamped with :func:`_sources_stamp`."""

        @classmethod
        def from_function(cls, py_func, py_file):
            if not os.path.abspath(py_file).startswith(str(_PACKAGE)):
                return None
            return super().from_function(py_func, py_file)

        def get_source_stamp(self):
            return _STAMP

    Locator.__name__ = f"Flexlift{base.__name__}"
    return Locator


_impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
_classes = _impl._locator_classes  # NUMBA_CACHE_DIR, when set, stays first
_at = _classes.index(caching.InTreeCacheLocator)
_classes[_at:_at] = [_package_locator(caching.InTreeCacheLocator),
                     _package_locator(caching.UserWideCacheLocator)]


def jit(fn):
    """numba ``njit`` with the on-disk cache and NumPy's error model (arithmetic raises no
    Python exceptions: callers guard their divisions)."""
    return numba.njit(cache=True, nogil=True, error_model="numpy")(fn)
