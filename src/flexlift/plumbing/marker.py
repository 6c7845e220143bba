"""What in a folder is flexlift's: the marker, and the journal of names claimed before writing.

Every folder flexlift writes carries the marker file :data:`MARKER` (JSON: the command, the
run, whether it is complete, the files it lists as flexlift's). While a run writes a folder,
every name it is about to create there (a file, a sub-folder, the hidden temporary file of an
atomic write) is first appended to the folder's journal :data:`JOURNAL`, one JSON string a
line. So whatever a killed run leaves behind is listed, and flexlift removes only what the
marker or the journal lists: a file that merely *looks* like one of flexlift's (a hidden name
like a temporary's) and is listed nowhere is the user's, and is left where it is.

:func:`journaled` registers a folder for the duration of a run; :func:`claim` (called by
:func:`flexlift.plumbing.atomic.atomic_file` before it creates anything) appends to the
journal of the registered folder that holds the path, if any. A process forked while a folder
is registered inherits the registration (the figure processes).
"""

from __future__ import annotations

import contextlib
import json
import os
import stat
import time
from collections.abc import Iterable, Iterator
from pathlib import Path

from flexlift import __version__

__all__ = ["JOURNAL", "MARKER", "Journal", "active_roots", "adopted", "claim", "journaled",
           "marker", "read_marker", "remove_listed"]

#: the marker file in every folder flexlift writes
MARKER = ".flexlift-output"
#: the journal of names claimed before they are created (beside the marker)
JOURNAL = ".flexlift-claims"
#: the largest marker read back [bytes]
MARKER_MAX = 1_000_000
#: the largest journal read back [bytes] (about 300,000 names)
JOURNAL_MAX = 32_000_000
_NOFOLLOW = os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)


def read_regular(path: Path, limit: int) -> bytes | None:
    """The bytes of a regular file (not through a link, at most ``limit``), else None."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | _NOFOLLOW)
    except OSError:
        return None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return None
        chunks, size = [], 0
        while size <= limit:
            b = os.read(fd, min(1 << 20, limit + 1 - size))
            if not b:
                break
            chunks.append(b)
            size += len(b)
        return None if size > limit else b"".join(chunks)
    except OSError:
        return None
    finally:
        os.close(fd)


def read_marker(folder: Path) -> dict | None:
    """The marker of ``folder`` as a dict, or None when it has none (or not a readable one)."""
    data = read_regular(Path(folder) / MARKER, MARKER_MAX)
    if data is None:
        return None
    try:
        obj = json.loads(data.decode("utf-8"))
    except (UnicodeDecodeError, ValueError):
        return None
    return obj if isinstance(obj, dict) and obj.get("flexlift_output") == 1 else None


def marker(run_id: str, command: str, complete: bool, files: Iterable[str] = ()) -> dict:
    """The content of a marker."""
    return {"flexlift_output": 1, "flexlift_version": __version__, "run_id": run_id,
            "command": command, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "complete": complete, "files": sorted(files)}


class Journal:
    """The journal of the folder ``root``: names claimed (relative POSIX paths) before they are
    created. :meth:`start` creates it new; :meth:`entries` reads one a killed run left.

    ``ident`` is the (device, inode) of the file :meth:`start` created: every append checks
    that the name still refers to it (opened without following a link), so a file planted or
    linked in its place is never written; a journal adopted by another process
    (:func:`adopted`) carries the same identity."""

    def __init__(self, root: Path, ident: tuple[int, int] | None = None):
        self.root = Path(root)
        self.path = self.root / JOURNAL
        self.ident = ident
        self._fd: int | None = None

    def start(self) -> Journal:
        """Create the journal anew. One left by an earlier run of this command (read before)
        is replaced only when it is provably flexlift's: a regular file with one link, owned
        by this user; anything else there raises FileExistsError (the folder is refused)."""
        with contextlib.suppress(FileNotFoundError):
            st = os.lstat(self.path)
            if not self._provably_ours(st):
                raise FileExistsError(f"{self.path} is not a flexlift journal (a link, another "
                                      "file, another user's, or not a list of names)")
            if _same_file(os.lstat(self.path), st):
                os.unlink(self.path)
        fd = os.open(self.path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_APPEND | _NOFOLLOW,
                     0o644)
        st = os.fstat(fd)
        # held open until close(): while it is, no other file can take its inode number, so
        # the identity a claim checks cannot be met by a file planted after it was removed
        self._fd = fd
        self.ident = (st.st_dev, st.st_ino)
        return self

    def close(self) -> None:
        """Let go of the journal :meth:`start` created (idempotent)."""
        fd, self._fd = getattr(self, "_fd", None), None
        if fd is not None:
            os.close(fd)

    def claim(self, *relpaths: str) -> None:
        """Append ``relpaths`` before they are created (one write: whole lines or none), to
        the file :meth:`start` created and to nothing else."""
        if not relpaths:
            return
        line = "".join(json.dumps(r) + "\n" for r in relpaths).encode("utf-8")
        if self._fd is not None:
            # the process that created it appends through its own descriptor, never opening
            # the name again, and only while the name is still that file
            st = os.lstat(self.path)
            if (st.st_dev, st.st_ino) != self.ident or not stat.S_ISREG(st.st_mode):
                raise FileExistsError(f"{self.path} was replaced during the run; nothing "
                                      "written to it")
            os.write(self._fd, line)
            return
        # an adopted journal (another process, :func:`adopted`) is opened by name. No O_CREAT:
        # a claim never creates a file (start() made the journal with O_EXCL);
        # O_NOFOLLOW: never through a link; O_NONBLOCK: a FIFO planted under the name fails
        # here instead of blocking the run; and nothing is written unless the file opened is
        # the one start() created (a hard link or another file in its place is refused)
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_NONBLOCK | _NOFOLLOW)
        try:
            st = os.fstat(fd)
            if (st.st_dev, st.st_ino) != self.ident or not stat.S_ISREG(st.st_mode):
                raise FileExistsError(f"{self.path} was replaced during the run; nothing "
                                      "written to it")
            os.write(fd, line)
        finally:
            os.close(fd)

    def entries(self) -> list[str]:
        """The names claimed so far (a torn last line is dropped)."""
        data = read_regular(self.path, JOURNAL_MAX)
        out = []
        for line in (data or b"").splitlines():
            try:
                name = json.loads(line.decode("utf-8"))
            except (UnicodeDecodeError, ValueError):
                continue
            if isinstance(name, str) and _relative(name):
                out.append(name)
        return out

    def remove(self) -> None:
        """Remove the journal when it is provably flexlift's (:meth:`_provably_ours`: never a
        link, a name of another file, another user's file or one that is not a journal)."""
        with contextlib.suppress(FileNotFoundError):
            st = os.lstat(self.path)
            if self._provably_ours(st) and _same_file(os.lstat(self.path), st):
                os.unlink(self.path)

    def _provably_ours(self, st: os.stat_result) -> bool:
        """The file under the journal's name (``st`` its lstat) is a journal flexlift wrote: a
        regular file with one link, owned by this user, whose every whole line is a JSON
        string naming a relative path (a torn last line is allowed: a killed run's)."""
        if not (stat.S_ISREG(st.st_mode) and st.st_nlink == 1 and st.st_uid == os.geteuid()):
            return False
        data = read_regular(self.path, JOURNAL_MAX)
        if data is None:
            return False
        lines = data.split(b"\n")
        for line in lines[:-1]:  # the part after the last newline may be torn
            try:
                name = json.loads(line.decode("utf-8"))
            except (UnicodeDecodeError, ValueError):
                return False
            if not (isinstance(name, str) and _relative(name)):
                return False
        return True


def _same_file(a: os.stat_result, b: os.stat_result) -> bool:
    """Two stats of one file (device and inode)."""
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _relative(name: str) -> bool:
    """A plain relative path inside the folder (no '..', not absolute, no empty parts)."""
    parts = name.split("/")
    return bool(name) and not name.startswith("/") and all(p not in ("", ".", "..") for p in parts)


#: the folders being written by this process (and inherited by its forked children)
_ACTIVE: dict[Path, Journal] = {}


@contextlib.contextmanager
def journaled(root: Path) -> Iterator[Journal]:
    """Register ``root``'s journal (created anew) while the block writes the folder."""
    journal = Journal(root).start()
    _ACTIVE[journal.root] = journal
    try:
        yield journal
    finally:
        _ACTIVE.pop(journal.root, None)
        journal.close()


def active_roots() -> tuple[tuple[str, tuple[int, int] | None], ...]:
    """The folders this process is writing now, each with its journal's identity (to hand to
    a process that writes for it)."""
    return tuple((str(r), j.ident) for r, j in _ACTIVE.items())


@contextlib.contextmanager
def adopted(roots) -> Iterator[None]:
    """In a helper process (e.g. a figure process started before the run opened its folder):
    journal into the folders ``roots`` (:func:`active_roots`) of the process it writes for,
    while the block runs."""
    added = [(Path(r), ident) for r, ident in roots if Path(r) not in _ACTIVE]
    for r, ident in added:
        _ACTIVE[r] = Journal(r, tuple(ident) if ident else None)
    try:
        yield
    finally:
        for r, _ in added:
            _ACTIVE.pop(r, None)


def claim(*paths: Path) -> None:
    """Journal ``paths`` in the registered folder that holds them (if any) before creating
    them. Called by every write of :mod:`flexlift.plumbing.atomic`."""
    for root, journal in list(_ACTIVE.items()):
        rel = []
        for p in paths:
            with contextlib.suppress(ValueError):
                r = Path(os.path.abspath(p)).relative_to(root)
                if r.parts:
                    rel.append(r.as_posix())
        if rel:
            journal.claim(*rel)


def remove_listed(root: Path, listed: Iterable[str]) -> list[str]:
    """Remove from ``root`` the regular files and (then empty) folders named in ``listed``, the
    journal and the marker, and ``root`` itself when nothing else is left. Nothing unlisted is
    touched, and no link is followed or removed. Returns what was left (relative paths)."""
    root = Path(root)
    names = {n for n in listed if isinstance(n, str) and _relative(n)}
    folders = []
    for rel in sorted(names, key=lambda n: -n.count("/")):
        p = root / rel
        if not _real_parents(root, rel):
            continue  # a folder on the way was replaced by a link: never go through it
        try:
            mode = os.lstat(p).st_mode
        except OSError:
            continue
        if stat.S_ISREG(mode):
            with contextlib.suppress(OSError):
                os.unlink(p)
        elif stat.S_ISDIR(mode):
            folders.append(p)
    for p in sorted(folders, key=lambda q: -len(q.parts)):
        with contextlib.suppress(OSError):
            os.rmdir(p)  # only when empty: a user's file inside keeps it
    left = sorted(_contents(root) - {MARKER, JOURNAL})
    if not left:
        Journal(root).remove()
        with contextlib.suppress(OSError):
            st = os.lstat(root / MARKER)
            if stat.S_ISREG(st.st_mode) and st.st_nlink == 1 and st.st_uid == os.geteuid():
                os.unlink(root / MARKER)
        with contextlib.suppress(OSError):
            os.rmdir(root)
    return left


def _real_parents(root: Path, rel: str) -> bool:
    """Whether every folder between ``root`` and ``root/rel`` is a real folder (no link)."""
    p = root
    for part in rel.split("/")[:-1]:
        p = p / part
        try:
            if not stat.S_ISDIR(os.lstat(p).st_mode):
                return False
        except OSError:
            return False
    return True


def _contents(folder: Path) -> set[str]:
    """Every file and folder under ``folder``, as POSIX paths relative to it (links are not
    followed)."""
    out = set()
    for top, dirs, files in os.walk(folder):
        rel = Path(top).relative_to(folder)
        for n in dirs + files:
            out.add((rel / n).as_posix())
    return out
