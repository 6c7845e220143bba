"""The one compiler switch: ``@jit`` compiles a function with numba, cached on disk.

Every compiled function stays an ordinary Python function to its callers: tests call the same
law the simulation runs. The physical laws are written with NumPy's element-wise operations,
so one function serves floats (inside the compiled loop) and whole arrays (from Python);
numba compiles each kind of argument once.

The cache lives in a folder named by a hash of *all* of flexlift's compiled modules
(:func:`sources_stamp`), not only stamped by the function's own file as numba does: the loop
inlines the laws of other modules, so a change to one law must recompile the loop (it does:
a changed law means a new, empty folder; the mutation check relies on it). The folder,
``numba-<16 hex digits>``, is made in the first writable one of: ``$NUMBA_CACHE_DIR/flexlift``
(numba's documented cache option, respected when set), ``__pycache__`` beside this file, the
user's cache folder (``$XDG_CACHE_HOME`` or ``~/.cache``, ``~/Library/Caches`` on macOS,
``%LOCALAPPDATA%`` on Windows) ``/flexlift`` for a read-only install; where none is writable,
nothing is cached. Folders of other stamps older than a day, or beyond the newest
:data:`KEEP` of them, are removed when a new one is made. The compile cost is stated in the
README; ``NUMBA_DISABLE_JIT=1`` runs everything interpreted.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numba

__all__ = ["jit", "inline_jit", "cache_folder", "sources_stamp"]

_PACKAGE = Path(__file__).resolve().parent
#: the modules whose code the compiled loop contains
_COMPILED = ("_jit.py", "_struct.py", "fuzzy/tables.py", "physics", "control", "ascent")
#: the cache folders' names: this prefix and the first 16 hex digits of the stamp
PREFIX = "numba-"
#: how many folders of other stamps are kept besides the one in use (those of the last day)
KEEP = 3
_DAY_S = 86400.0


def sources_stamp(package: Path = _PACKAGE) -> str:
    """SHA-256 of numba's version and the compiled modules' sources (the cache is valid while
    it is unchanged)."""
    h = hashlib.sha256(numba.__version__.encode())
    for name in _COMPILED:
        p = package / name
        for f in sorted(p.rglob("*.py")) if p.is_dir() else [p]:
            h.update(f.relative_to(package).as_posix().encode())
            h.update(f.read_bytes())
    return h.hexdigest()


def _user_cache_home() -> Path:
    """The user's folder for caches (the platform's convention)."""
    if sys.platform == "win32":
        return Path(os.environ.get("LOCALAPPDATA") or Path.home() / "AppData" / "Local")
    if sys.platform == "darwin":
        return Path.home() / "Library" / "Caches"
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")


def _bases() -> list[Path]:
    """Where a cache folder may go, in order (module docstring). The user's NUMBA_CACHE_DIR
    as the environment says it now, else as numba read it (the environment or its
    ``.numba_config.yaml``) into ``numba.config.CACHE_DIR``."""
    user = os.environ.get("NUMBA_CACHE_DIR") or numba.config.CACHE_DIR
    bases = [Path(user) / "flexlift"] if user else []
    return [*bases, _PACKAGE / "__pycache__", _user_cache_home() / "flexlift"]


def _prune(base: Path, keep: Path) -> None:
    """Remove the cache folders in ``base`` other than ``keep`` that are older than a day or
    beyond the newest :data:`KEEP` (another process may still use a recent one)."""
    now = time.time()
    try:
        others = [p for p in base.iterdir()
                  if p.name.startswith(PREFIX) and p.is_dir() and p != keep]
        others.sort(key=lambda p: p.stat().st_mtime, reverse=True)
    except OSError:
        return
    for k, p in enumerate(others):
        try:
            old = now - p.stat().st_mtime > _DAY_S
        except OSError:
            continue
        if old or k >= KEEP:
            shutil.rmtree(p, ignore_errors=True)


def cache_folder(stamp: str, bases: list[Path] | None = None) -> Path | None:
    """The cache folder for ``stamp`` in the first writable of ``bases`` (default: the
    module docstring's), made if needed (then older ones are pruned); None if none is
    writable."""
    for base in _bases() if bases is None else bases:
        folder = base / f"{PREFIX}{stamp[:16]}"
        try:
            new = not folder.is_dir()
            folder.mkdir(parents=True, exist_ok=True)
            tempfile.TemporaryFile(dir=folder).close()  # writable (numba checks the same)
        except OSError:
            continue
        if new:
            _prune(base, folder)
        return folder
    return None


#: this process's cache folder (None: nothing cached; nothing compiled under NUMBA_DISABLE_JIT)
_FOLDER = None if numba.config.DISABLE_JIT else cache_folder(sources_stamp())


def cache_is_warm(entry: str = "kernel.advance") -> bool:
    """Whether the compiled ``entry`` (module.function of the loop) is in this process's cache
    folder, so that the first call loads it instead of compiling (85-125 s measured); True when
    nothing is compiled (``NUMBA_DISABLE_JIT``) or nothing can be cached (nothing to say)."""
    if numba.config.DISABLE_JIT or _FOLDER is None:
        return True
    return any(_FOLDER.glob(f"*/{entry}-*.nbi"))


@contextlib.contextmanager
def _numba_cache_dir(folder: Path):
    """numba's ``NUMBA_CACHE_DIR`` (``numba.config.CACHE_DIR``) set to ``folder`` within the
    block only. numba fixes a function's cache folder when ``njit(cache=True)`` decorates it,
    so flexlift's functions are cached in ``folder`` while every other numba function of the
    process keeps the user's setting (the environment is not touched). That numba reads the
    option at decoration is tested (tests/test_jit.py): if it ever stopped, the cache would
    be numba's default, stamped by each file alone, and that test fails."""
    saved = numba.config.CACHE_DIR
    numba.config.CACHE_DIR = str(folder)
    try:
        yield
    finally:
        numba.config.CACHE_DIR = saved


def jit(fn, inline: str = "never"):
    """numba ``njit`` with the on-disk cache (module docstring) and NumPy's error model
    (arithmetic raises no Python exceptions: callers guard their divisions)."""
    options = {"nogil": True, "error_model": "numpy", "inline": inline}
    if _FOLDER is None:  # nowhere to write: compiled in every process
        return numba.njit(**options)(fn)
    with _numba_cache_dir(_FOLDER):
        return numba.njit(cache=True, **options)(fn)


def inline_jit(fn):
    """:func:`jit` for the small functions the compiled loop calls at every step: their code
    is compiled into each compiled caller (numba's ``inline="always"``: the same operations
    in the same order, so the same numbers). A call between compiled functions takes a
    reference on every array it passes, a few ns each; for a function of a few dozen
    operations taking several of the loop's arrays that was most of its cost (a bag's
    motion, two 7 x 5 products: 185 ns called, 55 ns inlined). Called from Python, it is
    an ordinary compiled function. Also for a large function with one compiled caller (the
    step's parts: each call took a reference on each of its structs). Not for a large
    function called from several places: each caller compiles its own copy (inlining the
    strip loads and the implicit step too made the first compile twice as long, for
    nothing)."""
    return jit(fn, inline="always")
