"""Output folders: built aside, swapped in whole, and only ever replacing flexlift's own.

Every command that writes (``modes``, ``loads``, ``reduce``, ``fuzzy``, ``simulate``, ``run``)
writes through :func:`output_folder`:

1. **Refuse what is not ours.** The target may be missing, an empty folder, or a folder that
   flexlift wrote: one that carries the marker file :data:`MARKER` and holds nothing but the
   files that marker lists. Anything else (a folder with the user's files, a file, a symbolic
   link, the current folder or one that holds it) is refused with one line naming the folder
   and the fix; nothing is touched.
2. **Lock.** A lock file ``.NAME.lock`` beside the target, created new by this run and never
   opened through a link (:mod:`flexlift.plumbing.lock`): a second run on the same folder at
   the same time is refused, never a silent race; anything at that name that is not the
   stale lock of a killed flexlift run is refused and left as it is.
3. **Recover.** A run killed by SIGKILL (or a power cut) can leave hidden ``.NAME.partial-*``
   folders, or be killed inside the swap with the target missing and the previous output
   parked as ``.NAME.old-*``. The next run on that folder finishes or undoes such a swap and
   removes the leftovers' files that their marker or journal lists
   (:mod:`flexlift.plumbing.marker`: every name is journaled before it is created), and says
   so; a file listed nowhere is left where it is, with a warning naming it.
4. **Build aside.** The new output is written into a hidden sibling ``.NAME.partial-RUN``,
   with the marker written first (so a leftover is recognisable as ours) and every name
   journaled before it is created.
5. **Swap.** When complete, the marker is finalised with the list of files written, the old
   folder is renamed aside, the new one renamed into place and the old one removed. A failure
   or interruption before that leaves the previous folder exactly as it was.

A command whose output grows piece by piece and must survive an interruption (``sweep``: one
file per finished case) cannot be built aside and swapped in whole; it writes in place through
:func:`incremental_folder` instead, under the same rules: the marker is written first
(``complete: false``, with the command and an ``identity`` saying what is being built), a rerun
with the same identity continues the folder, and nothing that is neither listed in the marker
or its journal nor recognised by the command as its own (by its content) is ever touched.

Folders get 0777 and files 0666 less the umask (0755 / 0644 usually), not the 0700 / 0600 of
bare temporary files. Locking uses ``fcntl`` (Linux, macOS).
"""

from __future__ import annotations

import contextlib
import errno
import logging
import os
import re
import secrets
import stat
import time
from collections.abc import Iterator
from pathlib import Path

from flexlift.errors import InputError
from flexlift.plumbing.atomic import dir_mode, file_mode, write_json
from flexlift.plumbing.lock import held_lock
from flexlift.plumbing.marker import (
    JOURNAL,
    MARKER,
    Journal,
    _real_parents,
    journaled,
    read_marker,
    remove_listed,
)
from flexlift.plumbing.marker import _contents as _all_contents
from flexlift.plumbing.marker import marker as _marker

log = logging.getLogger(__name__)

__all__ = ["MARKER", "OutputError", "incremental_folder", "output_folder", "read_marker"]

PARTIAL, OLD = ".partial-", ".old-"


class OutputError(InputError):
    """The output folder cannot be used or written (one line; the CLI exits with 2)."""


def _refuse(shown: str, why: str) -> OutputError:
    return OutputError("--out", shown, why)


def _contents(folder: Path) -> set[str]:
    """Every file and folder under ``folder`` but the journal (relative POSIX paths)."""
    return _all_contents(folder) - {JOURNAL}


#: the longest name of the output folder and of each folder above it [bytes, UTF-8]: the
#: system's 255 less the hidden siblings' ``.NAME.partial-RUN`` (and lock) decorations
NAME_MAX = 200
#: the longest absolute path of the output folder [bytes, UTF-8]: the system's 4096 less room
#: for the files and folders written inside it
PATH_MAX = 3000


def check_length(final: Path, shown: str) -> None:
    """Raise :class:`OutputError` when the absolute ``final`` or one of its names is longer
    than :data:`PATH_MAX` / :data:`NAME_MAX` (the system would refuse it mid-run)."""
    size = len(os.fsencode(final))
    if size > PATH_MAX:
        raise _refuse(shown[:60] + "...", f"is a path of {size} bytes; at most {PATH_MAX} "
                                          "bytes are allowed; choose a shorter --out")
    for part in final.parts:
        if len(os.fsencode(part)) > NAME_MAX:
            raise _refuse(shown[:60] + "...", f"holds a name of {len(os.fsencode(part))} bytes; "
                                              f"at most {NAME_MAX} bytes per name are allowed; "
                                              "choose a shorter --out")


def check_target(final: Path, shown: str) -> None:
    """Raise :class:`OutputError` unless ``final`` may be (re)placed by a flexlift output."""
    check_length(final, shown)
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


def _locked(final: Path, shown: str):
    """Hold the lock file ``.NAME.lock`` beside ``final`` (:mod:`flexlift.plumbing.lock`)."""
    return held_lock(final, lambda why: _refuse(shown, why), file_mode())


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


def _remove_own(folder: Path, shown: str) -> list[str]:
    """Remove what a folder of this module lists as flexlift's (its marker's files and its
    journal's names); anything else is left, and a warning says so. Returns the notes."""
    mark = read_marker(folder)
    if not folder.is_dir() or folder.is_symlink() or mark is None:
        return []
    listed = [f for f in mark.get("files", []) if isinstance(f, str)]
    left = remove_listed(folder, listed + Journal(folder).entries())
    if not left:
        return []
    return [f"{shown}: left {folder.name} beside it: it holds {len(left)} file(s) flexlift did "
            f"not write (e.g. {left[0][:60]!r}); move them away, then remove the folder"]


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
    kept = []
    for p in partials + olds:
        kept += _remove_own(p, shown)
    if len(partials) + len(olds) > len(kept):
        notes.append(f"{shown}: removed {len(partials) + len(olds) - len(kept)} unfinished "
                     "output folder(s) left beside it by killed runs")
    notes += kept
    return notes


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
        for note in _remove_own(old, os.fspath(final.name)):
            log.warning(note)
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
                with journaled(tmp) as journal:  # names listed before they are created
                    write_json(tmp / MARKER, _marker(run_id, command, complete=False))
                    yield tmp
                    written = set(journal.entries()) & _contents(tmp) - {MARKER}
                    write_json(tmp / MARKER, _marker(run_id, command, True, written))
                journal.remove()
                check_target(final, shown)  # the user may have put files there meanwhile
                _swap(tmp, final, run_id)
            except BaseException:
                for note in _remove_own(tmp, shown):  # what this run listed; nothing else
                    log.warning(note)
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
    paths, kept across reruns); journal : the folder's journal of names claimed before they
    are created (:mod:`flexlift.plumbing.marker`). :meth:`claim` lists files in the marker
    before they are written (so that a kill halfway leaves only files the next run knows as its
    own); :meth:`finish` marks the folder complete, listing what this command wrote in it.
    """

    def __init__(self, final: Path, shown: str, command: str, identity: str, run_id: str,
                 listed: set[str]):
        self.path, self.shown, self.command = final, shown, command
        self.identity, self.run_id, self.listed = identity, run_id, set(listed)
        self.journal: Journal | None = None
        self.complete = False

    def claim(self, *relpaths: str) -> None:
        new = set(relpaths) - self.listed
        if new:
            self.listed |= new
            self._marker(complete=False)

    def remove_own(self, rel: str, expected: bytes) -> bool:
        """Remove the file ``rel`` only when it is this command's and unchanged: listed by the
        marker, a regular file (not a link, nor reached through one) and holding exactly
        ``expected`` (what the command wrote there). Anything else is left as it is. Returns
        whether it was removed."""
        full = self.path / rel
        if rel not in self.listed or not _real_parents(self.path, rel):
            return False
        try:
            if not stat.S_ISREG(os.lstat(full).st_mode) or full.read_bytes() != expected:
                return False  # a link, or edited since it was written: the user's now
            full.unlink()
        except OSError:
            return False
        self.listed.discard(rel)
        self._marker(complete=False)
        return True

    def finish(self, compact=None) -> None:
        """Mark the folder complete, listing what this command wrote in it (the marker's and
        the journal's names that exist); when that list would make the marker too large to be
        read back (:func:`read_marker`), the paths ``compact(relpath)`` selects are left out
        (the command recognises them by their content; other commands then refuse to replace
        the folder rather than guess)."""
        journaled_names = set(self.journal.entries()) if self.journal else set()
        self.listed = (self.listed | journaled_names) & _contents(self.path) - {MARKER}
        if compact is not None and sum(len(p) + 8 for p in self.listed) > MARKER_LISTING_MAX:
            self.listed = {p for p in self.listed if not compact(p)}
        self._marker(complete=True)
        self.complete = True

    def _marker(self, complete: bool) -> None:
        write_json(self.path / MARKER, {**_marker(self.run_id, self.command, complete,
                                                  self.listed), "identity": self.identity})


def _check_place(final: Path, shown: str) -> None:
    check_length(final, shown)
    cwd = Path.cwd().resolve()
    if final == cwd or cwd.is_relative_to(final):
        raise _refuse(shown, "is the current folder (or holds it); choose a sub-folder")
    if final.is_symlink():
        raise _refuse(shown, "is a symbolic link; give the folder itself or a new name")
    if final.exists() and not final.is_dir():
        raise _refuse(shown, "is a file, not a folder; choose a new or empty folder")


def _kind(full: Path) -> str:
    """'dir', 'file' or '' (a link, or anything else) without following links."""
    try:
        mode = os.lstat(full).st_mode
    except OSError:
        return ""
    return "dir" if stat.S_ISDIR(mode) else "file" if stat.S_ISREG(mode) else ""


def _check_own(inc: Incremental, owns, previous: dict, journaled_names: set[str]
               ) -> tuple[list[Path], set[str]]:
    """Refuse a folder holding anything the command did not write. Returns the temporary
    leftovers to remove (files of an atomic write cut short by a kill: hidden temporaries the
    journal lists) and the other names the journal lists that exist (the command's own)."""
    shown, command = inc.shown, inc.command
    if previous.get("command") != command:
        other = str(previous.get("command"))[:20]
        raise _refuse(shown, f"holds the output of `flexlift {other}`, not of `flexlift "
                             f"{command}`; choose another --out")
    if previous.get("identity") != inc.identity:
        raise _refuse(shown, f"holds another `flexlift {command}` (its input differs); rerun "
                             "with the input it was started with to continue it, or choose "
                             "another --out")
    temps, own = [], set()
    for p in sorted(_contents(inc.path) - {MARKER}):
        full = inc.path / p
        kind = _kind(full) if _real_parents(inc.path, p) else ""
        if kind and (p in inc.listed or owns(p, full)):
            continue
        if kind and p in journaled_names:  # claimed by a run of this command before it wrote
            if kind == "file" and atomic_leftover(p.rpartition("/")[2]):
                temps.append(full)
            else:
                own.add(p)
            continue
        raise _refuse(shown, f"holds {p[:60]!r}, which flexlift did not write; move it away "
                             "or choose another --out")
    return temps, own


@contextlib.contextmanager
def incremental_folder(target: str | os.PathLike, command: str, identity: str,
                       owns=lambda rel, path: False) -> Iterator[Incremental]:
    """Open ``target`` to be written in place by ``command``, piece by piece (module docstring).

    identity : what the folder is the output of (e.g. a checksum of the input); a folder of
        the same command and identity is continued, any other refused
    owns : ``owns(relpath, path)`` is True for a file the command recognises as its own by its
        content (it carries the input's checksum) though the marker does not list it

    The folder is locked while open (a second run is refused). Nothing is removed but the
    temporary files of the command's own atomic writes that its journal lists (a kill cut them
    short) and, through :meth:`Incremental.remove_own`, its own files left unchanged since it
    wrote them; a file that merely looks like one of flexlift's is refused, never removed. An
    exception leaves everything written so far, with the marker saying ``complete: false``
    (other commands refuse such a folder; a rerun of the same command and identity continues
    it).
    """
    shown = os.fspath(target)
    final = Path(os.path.abspath(shown))
    _check_place(final, shown)
    run_id = f"{time.strftime('%Y%m%dT%H%M%S')}-{os.getpid()}-{secrets.token_hex(2)}"
    try:
        final.parent.mkdir(parents=True, exist_ok=True)
        with _locked(final, shown):
            _check_place(final, shown)
            previous, temps, own = {}, [], set()
            if final.exists() and os.listdir(final):
                previous = read_marker(final)
                if previous is None:
                    raise _refuse(shown, f"holds files flexlift did not write (no {MARKER} "
                                         "marker); choose a new or empty folder")
            listed = {p for p in previous.get("files", []) if isinstance(p, str)}
            inc = Incremental(final, shown, command, identity, run_id, listed)
            if previous:
                temps, own = _check_own(inc, owns, previous, set(Journal(final).entries()))
            final.mkdir(mode=0o700, exist_ok=True)
            os.chmod(final, dir_mode())
            for t in temps:
                with contextlib.suppress(OSError):
                    t.unlink()
            own = {p for p in own if not owns(p, final / p)}  # those by content need no listing
            inc.listed = {p for p in inc.listed | own if (final / p).exists()}
            inc._marker(complete=False)  # the journal's names are in the marker: start anew
            with journaled(final) as journal:
                inc.journal = journal
                yield inc
            if inc.complete:
                journal.remove()
    except OSError as exc:
        what = f" ({exc.filename})" if getattr(exc, "filename", None) else ""
        reason = exc.strerror or errno.errorcode.get(exc.errno or 0, str(exc))
        raise _refuse(shown, f"could not be written: {reason}{what}; what was finished is kept "
                             "(free some space or check the permissions, then rerun)") from None
