"""Atomic file writes: a reader never sees a half-written file.

Every file flexlift writes goes through :func:`atomic_file` (or :func:`write_text` /
:func:`write_json` built on it): the content is written to a hidden temporary sibling
``.NAME.<8 hex digits><suffix>``, created new (never through a link, never an existing file)
and renamed into place, so an interrupted write leaves the previous file (or none) as it was.
Inside a folder being written by a run (:func:`flexlift.plumbing.marker.journaled`), the
folders it creates, the temporary and the final name are journaled before they are created,
so the leftovers of a killed run are known by their listing, never by the look of their name.
Files get the permissions an ordinary ``open()`` would give them (0644 under the usual umask
022), not the 0600 of a bare temporary file: outputs are meant to be archived and sent on.
"""

from __future__ import annotations

import contextlib
import json
import os
import secrets
import stat
from collections.abc import Iterator
from pathlib import Path

from flexlift.plumbing.marker import claim


def current_umask() -> int:
    """The process's umask (read without changing it for more than an instant)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def file_mode() -> int:
    """Permissions of a new file: 0666 less the umask (0644 under umask 022)."""
    return 0o666 & ~current_umask()


def dir_mode() -> int:
    """Permissions of a new folder: 0777 less the umask (0755 under umask 022)."""
    return 0o777 & ~current_umask()


def make_folders(folder: Path) -> None:
    """Create ``folder`` and its missing parents, each journaled before it is made."""
    missing = []
    p = Path(os.path.abspath(folder))
    while not p.is_dir():
        missing.append(p)
        if p.parent == p:
            break
        p = p.parent
    for d in reversed(missing):
        claim(d)
        with contextlib.suppress(FileExistsError):
            d.mkdir()


@contextlib.contextmanager
def atomic_file(path: str | os.PathLike, suffix: str = "") -> Iterator[Path]:
    """Yield a new temporary path beside ``path``; when the block ends without an exception,
    the temporary file is renamed to ``path``, otherwise removed (it is this function's own)."""
    path = Path(path)
    make_folders(path.parent)
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
    for _ in range(100):
        tmp = path.parent / f".{path.name}.{secrets.token_hex(4)}{suffix or '.tmp'}"
        claim(tmp, path)
        try:
            # held open until the end, so that no other file can take its inode number: the
            # name is removed at the end only while it is still this file
            fd = os.open(tmp, flags, 0o600)
            break
        except FileExistsError:
            continue
    else:  # pragma: no cover - 100 collisions of 32 random bits
        raise FileExistsError(f"no free temporary name beside {path}")
    try:
        yield tmp
        if not stat.S_ISREG(os.lstat(tmp).st_mode):  # never chmod or rename through a link
            raise FileExistsError(f"{tmp} was replaced by something not a file during the write")
        os.chmod(tmp, file_mode())
        os.replace(tmp, path)
    finally:
        try:
            with contextlib.suppress(FileNotFoundError):
                now, mine = os.lstat(tmp), os.fstat(fd)  # left only when the write failed
                if (now.st_dev, now.st_ino) == (mine.st_dev, mine.st_ino):
                    tmp.unlink()
        finally:
            os.close(fd)


def write_text(path: str | os.PathLike, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically; returns the path."""
    with atomic_file(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def write_bytes(path: str | os.PathLike, data: bytes) -> Path:
    """Write ``data`` to ``path`` atomically; returns the path."""
    with atomic_file(path) as tmp:
        tmp.write_bytes(data)
    return Path(path)


def write_json(path: str | os.PathLike, obj) -> Path:
    """Write ``obj`` as indented JSON, atomically."""
    return write_text(path, json.dumps(obj, indent=2, sort_keys=False) + "\n")
