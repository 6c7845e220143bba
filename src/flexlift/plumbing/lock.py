"""The lock file beside an output folder: created by this run, never opened through a link.

A writing command holds ``.NAME.lock`` beside its output folder ``NAME`` while it writes, so a
second run on the same folder is refused rather than racing it (runs on different folders in
one parent use different lock files and never block each other). The rules, in the order they
are applied:

- The lock file is created new (``O_CREAT | O_EXCL | O_NOFOLLOW``), given the content
  ``flexlift-lock <pid>`` and held with ``flock``; at the end this run removes it, having
  checked that the name still refers to the file it created.
- Something already at that name is never written, truncated or removed unless it is the
  stale lock of a killed flexlift run, recognised only when *all* of these hold: a regular
  file (opened with ``O_NOFOLLOW``: a symbolic link is refused), one hard link, owned by this
  user, content exactly ``flexlift-lock <pid>``, nobody holding its ``flock``, and that pid
  not alive. Such a file is removed and a new lock created in its place.
- Anything else at that name (a link, a FIFO, a folder, another user's file, a file of the
  user's, a live run's lock) makes the run refuse with one line naming it; nothing is touched.

Locking uses ``fcntl.flock`` (Linux, macOS).
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import re
import stat
import time
from collections.abc import Callable, Iterator
from pathlib import Path

__all__ = ["CONTENT", "held_lock", "lock_path"]

#: what a lock file holds: this word, a space, and the pid of the run holding it
CONTENT = "flexlift-lock"
_CONTENT = re.compile(rb"flexlift-lock ([1-9][0-9]{0,9})")
#: the most bytes read from a file found at the lock's name
_READ = 64
#: a just-created lock is written at once; one found empty or partial is re-read this often
_SETTLE_TRIES, _SETTLE_S = 10, 0.02

Refuse = Callable[[str], Exception]


def lock_path(final: Path) -> Path:
    """The lock file of the output folder ``final``: ``.NAME.lock`` beside it."""
    return final.parent / f".{final.name}.lock"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # another user's process: alive
        return True
    except OverflowError:
        return False
    return True


def _same(a: os.stat_result, b: os.stat_result) -> bool:
    """Whether two stat results are of one file (device and inode): a name is unlinked only
    while it still refers to the file this run created or examined."""
    return (a.st_dev, a.st_ino) == (b.st_dev, b.st_ino)


def _create(path: Path, mode: int) -> int | None:
    """A new lock file at ``path``, held and written; None when something is already there."""
    flags = os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags, mode)
    except FileExistsError:
        return None
    try:
        os.write(fd, f"{CONTENT} {os.getpid()}".encode())  # first: a racing run reads it
        for _ in range(50):  # a racing run may hold it for a moment while it reads it
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                time.sleep(_SETTLE_S)
        else:
            raise BlockingIOError(errno.EWOULDBLOCK, "the new lock file stayed locked")
    except BaseException:
        with contextlib.suppress(OSError):
            if _same(os.fstat(fd), os.lstat(path)):
                os.unlink(path)  # created just now by this run
        os.close(fd)
        raise
    return fd


def _describe(mode: int) -> str:
    for test, name in ((stat.S_ISLNK, "a symbolic link"), (stat.S_ISDIR, "a folder"),
                       (stat.S_ISFIFO, "a FIFO"), (stat.S_ISSOCK, "a socket"),
                       (stat.S_ISCHR, "a device"), (stat.S_ISBLK, "a device")):
        if test(mode):
            return name
    return "a file"


def _examine(path: Path, refuse: Refuse) -> bool:
    """Decide about something found at the lock's name: True when it was a stale flexlift
    lock and has been removed (try creating again), False when it vanished meanwhile (try
    again); raises ``refuse(why)`` for anything else, touching nothing."""
    shown = path.name
    flags = os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        return False
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise refuse(f"its lock file {shown} is a symbolic link, which flexlift never "
                         "follows; remove the link (it is not flexlift's) and run again") from None
        try:
            kind = _describe(os.lstat(path).st_mode)
        except OSError:
            kind = "a file"
        raise refuse(f"its lock file {shown} is {kind} flexlift cannot open "
                     f"({exc.strerror}); remove it (it is not flexlift's) and run again") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise refuse(f"its lock file {shown} is {_describe(st.st_mode)}, not a flexlift "
                         "lock; remove it (it is not flexlift's) and run again")
        if st.st_nlink != 1:
            raise refuse(f"its lock file {shown} has {st.st_nlink} hard links, so it is "
                         "another file too and not a flexlift lock; remove that name (the "
                         "other stays) and run again")
        if st.st_uid != os.geteuid():
            raise refuse(f"its lock file {shown} belongs to another user (uid {st.st_uid}); "
                         "ask them, or choose another --out")
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            pid = _pid(fd)
            raise refuse(f"another flexlift run (pid {pid or '?'}) is writing this folder; wait "
                         "for it to finish or choose another --out") from None
        pid = _pid(fd)
        for _ in range(_SETTLE_TRIES):  # a run that has just created its lock writes it at once
            if pid is not None:
                break
            time.sleep(_SETTLE_S)
            pid = _pid(fd)
        if pid is None:
            raise refuse(f"its lock file {shown} does not hold '{CONTENT} <pid>', so it is not "
                         "a flexlift lock; move it away and run again")
        if _alive(pid):
            raise refuse(f"its lock file {shown} names pid {pid}, which is running; if that is "
                         f"not a flexlift run writing this folder, remove {shown} and run again")
        # a stale lock of a killed run: ours to replace, if the name still refers to it
        if not _same(os.lstat(path), st):
            return False
        os.unlink(path)
        return True
    finally:
        os.close(fd)


def _pid(fd: int) -> int | None:
    os.lseek(fd, 0, os.SEEK_SET)
    m = _CONTENT.fullmatch(os.read(fd, _READ))
    return int(m.group(1)) if m else None


@contextlib.contextmanager
def held_lock(final: Path, refuse: Refuse, mode: int = 0o644) -> Iterator[Path]:
    """Hold the lock of the output folder ``final`` (module docstring) while the block runs.

    refuse : ``refuse(why)`` builds the exception raised when the lock cannot be taken
        (``why`` is a sentence naming the lock file and the fix).
    Yields the lock file's path.
    """
    path = lock_path(final)
    for _ in range(20):  # each round: create, or examine what is there (a race may repeat it)
        fd = _create(path, mode)
        if fd is not None:
            break
        _examine(path, refuse)
    else:
        raise refuse(f"its lock file {path.name} could not be created; try again")
    try:
        yield path
    finally:
        with contextlib.suppress(OSError):
            if _same(os.lstat(path), os.fstat(fd)):
                os.unlink(path)  # the file this run created, still ours
        os.close(fd)
