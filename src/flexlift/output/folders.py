"""Output folders: built aside, swapped in whole, and only ever replacing flexlift's own.

Every command that writes (``modes``, ``loads``, ``reduce``, ``fuzzy``, ``simulate``, ``run``)
writes through :func:`output_folder`:

1. **Refuse what is not ours.** The target may be missing, an empty folder, or a folder that
   flexlift wrote: one that carries the marker file :data:`MARKER` and holds nothing but the
   files that marker lists. Anything else (a folder with the user's files, a file, a symbolic
   link, the current folder or one that holds it) is refused with one line naming the folder
   and the fix; nothing is touched.
2. **Lock.** A lock file ``.NAME.lock`` beside the target (an ``flock``): a second run on the
   same folder at the same time is refused, never a silent race.
3. **Recover.** A run killed by SIGKILL (or a power cut) can leave hidden ``.NAME.partial-*``
   folders, or be killed inside the swap with the target missing and the previous output
   parked as ``.NAME.old-*``. The next run on that folder finishes or undoes such a swap and
   removes the leftovers (each is flexlift's: it carries the marker), and says so.
4. **Build aside.** The new output is written into a hidden sibling ``.NAME.partial-RUN``,
   with the marker written first (so a leftover is recognisable as ours).
5. **Swap.** When complete, the marker is finalised with the list of files written, the old
   folder is renamed aside, the new one renamed into place and the old one removed. A failure
   or interruption before that leaves the previous folder exactly as it was.

A command whose output grows piece by piece and must survive an interruption (``sweep``: one
file per finished case) cannot be built aside and swapped in whole; it writes in place through
:func:`incremental_folder` instead, under the same rules: the marker is written first
(``complete: false``, with the command and an ``identity`` saying what is being built), a rerun
with the same identity continues the folder, and nothing that is neither listed in the marker
nor recognised by the command as its own (by its content) is ever touched.

Folders get 0777 and files 0666 less the umask (0755 / 0644 usually), not the 0700 / 0600 of
bare temporary files. Locking uses ``fcntl`` (Linux, macOS).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import logging
import os
import re
import secrets
import shutil
import time
from collections.abc import Iterator
from pathlib import Path

from flexlift import __version__
from flexlift.errors import InputError
from flexlift.plumbing.atomic import dir_mode, file_mode, write_json

log = logging.getLogger(__name__)

#: the marker file in every folder flexlift writes
MARKER = ".flexlift-output"
PARTIAL, OLD, LOCK = ".partial-", ".old-", ".lock"


class OutputError(InputError):
    """The output folder cannot be used or written (one line; the CLI exits with 2)."""


def _refuse(shown: str, why: str) -> OutputError:
    return OutputError("--out", shown, why)


def read_marker(folder: Path) -> dict | None:
    """The marker of ``folder`` as a dict, or None when it has none (or not a readable one)."""
    p = folder / MARKER
    try:
        if not p.is_file() or p.is_symlink() or p.stat().st_size > 1_000_000:
            return None
        data = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return data if isinstance(data, dict) and data.get("flexlift_output") == 1 else None


def _contents(folder: Path) -> set[str]:
    """Every file and folder under ``folder``, as POSIX paths relative to it."""
    out = set()
    for root, dirs, files in os.walk(folder):
        rel = Path(root).relative_to(folder)
        for n in dirs + files:
            out.add((rel / n).as_posix())
    return out


def check_target(final: Path, shown: str) -> None:
    """Raise :class:`OutputError` unless ``final`` may be (re)placed by a flexlift output."""
    cwd = Path.cwd().resolve()
    if final == cwd or cwd.is_relative_to(final):
        raise _refuse(shown, "is the current folder (or holds it); choose a sub-folder, "
                             "e.g. --out results")
    if final.is_symlink():
        raise _refuse(shown, "is a symbolic link; give the folder itself or a new name")
    if not final.exists():
        return
    if not final.is_dir():
        raise _refuse(shown, "is a file, not a folder; choose a new or empty folder")
    try:
        entries = os.listdir(final)
    except OSError as exc:
        raise _refuse(shown, f"cannot be read ({exc.strerror}); choose another folder") from None
    if not entries:
        return
    marker = read_marker(final)
    if marker is None or not marker.get("complete"):
        raise _refuse(shown, f"holds files flexlift did not write (no complete {MARKER} "
                             "marker); choose a new or empty folder")
    extra = sorted(_contents(final) - set(marker.get("files", [])) - {MARKER})
    if extra:
        raise _refuse(shown, f"holds {len(extra)} file(s) flexlift did not write (e.g. "
                             f"{extra[0][:60]!r}); move them away or choose another folder")


@contextlib.contextmanager
def _locked(final: Path, shown: str) -> Iterator[None]:
    """Hold the lock file ``.NAME.lock`` beside ``final`` (refuse if another run holds it)."""
    path = final.parent / f".{final.name}{LOCK}"
    for _ in range(20):  # retry if the file we opened was unlinked by its previous holder
        fd = os.open(path, os.O_RDWR | os.O_CREAT, file_mode())
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = os.read(fd, 32).decode(errors="replace").strip() or "?"
            os.close(fd)
            raise _refuse(shown, f"another flexlift run (pid {pid}) is writing this folder; "
                                 "wait for it to finish or choose another --out") from None
        try:
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    else:  # pragma: no cover - 20 lost races in a row
        raise _refuse(shown, "could not be locked; try again")
    try:
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        yield
    finally:
        with contextlib.suppress(OSError):
            os.unlink(path)  # ours, still locked: the next run creates a fresh one
        os.close(fd)


def _leftovers(final: Path, kind: str) -> list[Path]:
    """flexlift's own hidden ``.NAME<kind>*`` folders beside ``final``, newest first."""
    prefix = f".{final.name}{kind}"
    found = []
    with contextlib.suppress(OSError):
        for n in os.listdir(final.parent):
            p = final.parent / n
            if n.startswith(prefix) and p.is_dir() and not p.is_symlink() and read_marker(p):
                found.append(p)
    return sorted(found, key=lambda p: p.stat().st_mtime, reverse=True)


def _remove_own(folder: Path) -> None:
    """Remove a folder this module made (it carries the marker); anything else is left."""
    if folder.is_dir() and not folder.is_symlink() and read_marker(folder) is not None:
        shutil.rmtree(folder, ignore_errors=True)


def recover(final: Path, shown: str) -> list[str]:
    """Finish or undo what a killed run left beside ``final``; returns what was done."""
    notes = []
    partials, olds = _leftovers(final, PARTIAL), _leftovers(final, OLD)
    if not final.exists():
        done = [p for p in partials if read_marker(p).get("complete")]
        if done:
            os.replace(done[0], final)
            partials.remove(done[0])
            notes.append(f"{shown}: finished the swap of a run that was killed while "
                         "replacing this folder")
        elif olds:
            os.replace(olds[0], final)
            olds.pop(0)
            notes.append(f"{shown}: restored the previous output, which a killed run had "
                         "moved aside")
    for p in partials + olds:
        _remove_own(p)
    if partials or olds:
        notes.append(f"{shown}: removed {len(partials) + len(olds)} unfinished output "
                     "folder(s) left beside it by killed runs")
    return notes


def _marker(run_id: str, command: str, complete: bool, files=()) -> dict:
    return {"flexlift_output": 1, "flexlift_version": __version__, "run_id": run_id,
            "command": command, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "complete": complete, "files": sorted(files)}


def _swap(tmp: Path, final: Path, run_id: str) -> None:
    if final.exists() and not os.listdir(final):
        os.rmdir(final)  # an empty folder (ours or the user's): nothing in it is lost
    if final.exists():
        old = final.parent / f".{final.name}{OLD}{run_id}"
        os.replace(final, old)
        try:
            os.replace(tmp, final)
        except BaseException:
            os.replace(old, final)  # put the previous output back
            raise
        _remove_own(old)
    else:
        os.replace(tmp, final)


def _write_error(shown: str, exc: OSError) -> OutputError:
    what = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
    reason = exc.strerror or errno.errorcode.get(exc.errno or 0, str(exc))
    return _refuse(shown, f"could not be written: {reason}{what}; the previous output is left "
                          "as it was (free some space, check the permissions, or choose "
                          "another --out)")


@contextlib.contextmanager
def output_folder(target: str | os.PathLike, command: str = "run") -> Iterator[Path]:
    """Build an output folder for ``target`` and swap it in whole (module docstring).

    Yields the (hidden, temporary) folder to write into. Raises :class:`OutputError` (one
    line) when ``target`` is not flexlift's to replace, is locked by another run, or cannot
    be written; any other exception (including KeyboardInterrupt) removes the temporary
    folder and leaves the previous output untouched.
    """
    shown = os.fspath(target)
    final = Path(os.path.abspath(shown))
    check_target(final, shown)
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _write_error(shown, exc) from None
    run_id = f"{time.strftime('%Y%m%dT%H%M%S')}-{os.getpid()}-{secrets.token_hex(2)}"
    try:
        with _locked(final, shown):
            for note in recover(final, shown):
                log.warning(note)
            tmp = final.parent / f".{final.name}{PARTIAL}{run_id}"
            tmp.mkdir(mode=0o700)
            try:
                os.chmod(tmp, dir_mode())
                write_json(tmp / MARKER, _marker(run_id, command, complete=False))
                yield tmp
                write_json(tmp / MARKER, _marker(run_id, command, True, _contents(tmp) - {MARKER}))
                check_target(final, shown)  # the user may have put files there meanwhile
                _swap(tmp, final, run_id)
            except BaseException:
                shutil.rmtree(tmp, ignore_errors=True)  # made by this run just now: ours
                raise
    except OSError as exc:
        raise _write_error(shown, exc) from None


# --------------------------------------------------------------------------- written in place
#: hidden temporary file of :func:`flexlift.plumbing.atomic.atomic_file` for the file NAME:
#: ``.NAME.<8 characters of mkstemp>`` and its suffix
_TEMP_TAIL = re.compile(r"\.[a-z0-9_]{8}(\.[a-z0-9]{1,4})$")


#: the longest file listing a marker may hold [bytes] (read_marker refuses markers over 1 MB)
MARKER_LISTING_MAX = 900_000


def atomic_leftover(name: str) -> str | None:
    """The name of the file an interrupted :func:`~flexlift.plumbing.atomic.atomic_file` was
    writing, when ``name`` is one of its hidden temporary files; else None."""
    if not name.startswith("."):
        return None
    m = _TEMP_TAIL.search(name)
    return name[1:m.start()] if m and m.start() > 1 else None


class Incremental:
    """A folder being written in place (:func:`incremental_folder`).

    path : the folder; listed : the files the marker lists as this command's (relative POSIX
    paths, kept across reruns). :meth:`claim` lists files before they are written (so that a
    kill halfway leaves only files the next run knows as its own); :meth:`finish` marks the
    folder complete, listing everything in it.
    """

    def __init__(self, final: Path, shown: str, command: str, identity: str, run_id: str,
                 listed: set[str]):
        self.path, self.shown, self.command = final, shown, command
        self.identity, self.run_id, self.listed = identity, run_id, set(listed)

    def claim(self, *relpaths: str) -> None:
        new = set(relpaths) - self.listed
        if new:
            self.listed |= new
            self._marker(complete=False)

    def remove_own(self, rel: str, expected: bytes) -> bool:
        """Remove the file ``rel`` only when it is this command's and unchanged: listed by the
        marker, a regular file (not a link) and holding exactly ``expected`` (what the command
        wrote there). Anything else is left as it is. Returns whether it was removed."""
        full = self.path / rel
        if rel not in self.listed or full.is_symlink() or not full.is_file():
            return False
        try:
            if full.read_bytes() != expected:
                return False  # edited since it was written: the user's now
            full.unlink()
        except OSError:
            return False
        self.listed.discard(rel)
        self._marker(complete=False)
        return True

    def finish(self, compact=None) -> None:
        """Mark the folder complete, listing everything in it; when that list would make the
        marker too large to be read back (:func:`read_marker`), the paths ``compact(relpath)``
        selects are left out (the command recognises them by their content; other commands
        then refuse to replace the folder rather than guess)."""
        self.listed = _contents(self.path) - {MARKER}
        if compact is not None and sum(len(p) + 8 for p in self.listed) > MARKER_LISTING_MAX:
            self.listed = {p for p in self.listed if not compact(p)}
        self._marker(complete=True)

    def _marker(self, complete: bool) -> None:
        write_json(self.path / MARKER, {**_marker(self.run_id, self.command, complete,
                                                  self.listed), "identity": self.identity})


def _check_place(final: Path, shown: str) -> None:
    cwd = Path.cwd().resolve()
    if final == cwd or cwd.is_relative_to(final):
        raise _refuse(shown, "is the current folder (or holds it); choose a sub-folder")
    if final.is_symlink():
        raise _refuse(shown, "is a symbolic link; give the folder itself or a new name")
    if final.exists() and not final.is_dir():
        raise _refuse(shown, "is a file, not a folder; choose a new or empty folder")


def _check_own(inc: Incremental, owns, previous: dict) -> list[Path]:
    """Refuse a folder holding anything the command did not write; its temporary leftovers
    (files of an atomic write of one of its own files, cut short by a kill) are returned."""
    shown, command = inc.shown, inc.command
    if previous.get("command") != command:
        other = str(previous.get("command"))[:20]
        raise _refuse(shown, f"holds the output of `flexlift {other}`, not of `flexlift "
                             f"{command}`; choose another --out")
    if previous.get("identity") != inc.identity:
        raise _refuse(shown, f"holds another `flexlift {command}` (its input differs); rerun "
                             "with the input it was started with to continue it, or choose "
                             "another --out")
    temps = []
    for p in sorted(_contents(inc.path) - {MARKER}):
        full = inc.path / p
        kind_ok = full.is_dir() or full.is_file()
        if not full.is_symlink() and kind_ok and (p in inc.listed or owns(p, full)):
            continue
        parent, _, name = p.rpartition("/")
        target = atomic_leftover(name)
        sibling = f"{parent}/{target}" if parent else target
        if (target and full.is_file() and not full.is_symlink()
                and (sibling in inc.listed or owns(sibling, None))):
            temps.append(full)
            continue
        raise _refuse(shown, f"holds {p[:60]!r}, which flexlift did not write; move it away "
                             "or choose another --out")
    return temps


@contextlib.contextmanager
def incremental_folder(target: str | os.PathLike, command: str, identity: str,
                       owns=lambda rel, path: False) -> Iterator[Incremental]:
    """Open ``target`` to be written in place by ``command``, piece by piece (module docstring).

    identity : what the folder is the output of (e.g. a checksum of the input); a folder of
        the same command and identity is continued, any other refused
    owns : ``owns(relpath, path)`` is True for a file the command recognises as its own by its
        content though the marker does not list it (``path`` None: by its name alone, for a
        temporary leftover of it)

    The folder is locked while open (a second run is refused). Nothing is removed but the
    temporary leftovers of the command's own atomic writes and, through
    :meth:`Incremental.remove_own`, its own files left unchanged since it wrote them; an exception leaves everything
    written so far, with the marker saying ``complete: false`` (other commands refuse such a
    folder; a rerun of the same command and identity continues it).
    """
    shown = os.fspath(target)
    final = Path(os.path.abspath(shown))
    _check_place(final, shown)
    run_id = f"{time.strftime('%Y%m%dT%H%M%S')}-{os.getpid()}-{secrets.token_hex(2)}"
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        with _locked(final, shown):
            _check_place(final, shown)
            previous, temps = {}, []
            if final.exists() and os.listdir(final):
                previous = read_marker(final)
                if previous is None:
                    raise _refuse(shown, f"holds files flexlift did not write (no {MARKER} "
                                         "marker); choose a new or empty folder")
            listed = {p for p in previous.get("files", []) if isinstance(p, str)}
            inc = Incremental(final, shown, command, identity, run_id, listed)
            if previous:
                temps = _check_own(inc, owns, previous)
            final.mkdir(mode=0o700, exist_ok=True)
            os.chmod(final, dir_mode())
            for t in temps:
                with contextlib.suppress(OSError):
                    t.unlink()
            inc.listed = {p for p in inc.listed if (final / p).exists()}
            inc._marker(complete=False)
            yield inc
    except OSError as exc:
        what = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        reason = exc.strerror or errno.errorcode.get(exc.errno or 0, str(exc))
        raise _refuse(shown, f"could not be written: {reason}{what}; what was finished is kept "
                             "(free some space or check the permissions, then rerun)") from None
