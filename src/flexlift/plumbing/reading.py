"""Reading a user's file without trusting it: every file flexlift reads goes through here.

A file is read only if it is a regular file (not a FIFO, a device, a socket or a folder),
opened without blocking (opening a FIFO does not wait for a writer), and at most
:data:`MAX_BYTES` long: at most ``MAX_BYTES + 1`` bytes are ever read, whatever its size says
(``/dev/zero``, a sparse file of many GB, a file growing meanwhile). Its text must be UTF-8 (a
UTF-8 byte-order mark is allowed and dropped). Anything else, and every path that cannot be
opened (no such file, a symbolic link that loops, a name longer than the system allows, a NUL
character), is one :class:`~flexlift.errors.InputError` line naming the file, what is wrong
and what to do. :class:`FileKind` holds the words that differ between the kinds of file (a
scenario, a sweep SPEC, a controller ``.fis``), so each message reads right for its file.
"""

from __future__ import annotations

import codecs
import errno
import os
import stat
from dataclasses import dataclass
from pathlib import Path

from flexlift.errors import InputError, clean

#: largest file flexlift reads [bytes] (1 MB): a scenario or a .fis file is a few kB
MAX_BYTES = 1_000_000


@dataclass(frozen=True)
class FileKind:
    """The words of the messages about one kind of file.

    file : the file, after "a"/"the" ("scenario file")
    thing : what it holds, with its article ("a scenario"): "... is read only from ..."
    text : its format ("YAML"): "a regular YAML file", "not YAML text"
    missing : what to do when there is no such file
    typical : how large such a file usually is, after the size limit
    convert : how to make it UTF-8; ``{enc}`` / ``{ENC}`` stand for the encoding it may be in
    """

    file: str
    thing: str
    text: str
    missing: str
    typical: str
    convert: str

    def with_missing(self, missing: str) -> FileKind:
        return FileKind(self.file, self.thing, self.text, missing, self.typical, self.convert)


#: a scenario file (``missing`` is completed with the built-in names by the loader)
SCENARIO = FileKind("scenario file", "a scenario", "YAML", "give a YAML path or a built-in name",
                    "a scenario is a few kB of YAML", "save the scenario as UTF-8")
#: a sweep's SPEC file
SPEC = FileKind("SPEC file", "a SPEC", "YAML", "give the path of a sweep SPEC (a YAML file)",
                "a SPEC is a few lines of YAML", "save the SPEC as UTF-8")
#: a MATLAB .fis file of a controller
FIS = FileKind(
    ".fis file", "a fuzzy system", "MATLAB .fis",
    "give the path of a MATLAB .fis file (relative paths in a scenario or SPEC are relative "
    "to its folder)", "a .fis file is a few kB of text",
    'save it as UTF-8 (in MATLAB: writelines(readlines("old.fis", Encoding="{enc}"), '
    '"new.fis", Encoding="UTF-8"); or `iconv -f {ENC} -t UTF-8 old.fis > new.fis`)')


def _fail(source: str, what: str) -> InputError:
    return InputError.from_line(f"{source}: {what}")


def kind_of(mode: int) -> str:
    """What a file that is not regular is, in words ("a FIFO (named pipe)")."""
    for test, name in ((stat.S_ISFIFO, "a FIFO (named pipe)"), (stat.S_ISCHR, "a character device"),
                       (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "a special file"


def read_bytes(path: str | os.PathLike, source: str, kind: FileKind = SCENARIO,
               limit: int = MAX_BYTES) -> bytes:
    """The bytes of the regular file ``path`` (at most ``limit``; at most ``limit + 1`` are
    read); ``source`` names it in messages, ``kind`` words them."""
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        fd = os.open(path, flags)  # non-blocking: opening a FIFO must not wait for a writer
    except (FileNotFoundError, NotADirectoryError):
        where = clean(os.path.abspath(os.fspath(path)), 160)
        looked = "" if where == source else f" (looked for {where})"
        raise _fail(source, f"no such file{looked}; {kind.missing}") from None
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise _fail(source, "a symbolic link that loops (it never reaches a file); "
                        f"give the path of the {kind.text} file itself") from None
        if exc.errno == errno.EACCES:
            raise _fail(source, f"permission denied; the {kind.file} must be readable") from None
        if exc.errno == errno.ENAMETOOLONG:
            raise _fail(source, f"cannot be opened ({exc.strerror or 'File name too long'}): "
                        f"{len(os.fspath(path)):,} characters, more than the system allows; "
                        f"give a shorter path of the {kind.text} file") from None
        raise _fail(source, f"cannot be opened ({exc.strerror or exc}); give a {kind.text} "
                    "file") from None
    except ValueError:  # a NUL character in the path
        raise _fail(source, "not a valid path (it holds a NUL character)") from None
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise _fail(source, f"a folder, not a {kind.file}; give the path of a {kind.text} "
                        "file")
        if not stat.S_ISREG(mode):
            raise _fail(source, f"{kind_of(mode)}, not a regular file; {kind.thing} is read only "
                        f"from a regular {kind.text} file")
        chunks, size = [], 0
        while size <= limit:  # not trusting st_size: the file may grow meanwhile
            chunk = os.read(fd, min(limit + 1 - size, 1 << 16))
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
    except OSError as exc:
        raise _fail(source, f"cannot be read ({exc.strerror or exc})") from None
    finally:
        os.close(fd)
    if size > limit:
        raise _fail(source, f"larger than {limit:,} bytes ({limit / 1e6:g} MB), the limit for a "
                    f"{kind.file}; {kind.typical}")
    return b"".join(chunks)


def decode(data: bytes, source: str, kind: FileKind = SCENARIO) -> str:
    """The text of a UTF-8 file (a UTF-8 byte-order mark is allowed and dropped)."""
    for bom, name in ((codecs.BOM_UTF32_LE, "UTF-32"), (codecs.BOM_UTF32_BE, "UTF-32"),
                      (codecs.BOM_UTF16_LE, "UTF-16"), (codecs.BOM_UTF16_BE, "UTF-16")):
        if data.startswith(bom):
            raise _fail(source, f"{name} text (it starts with a {name} byte-order mark); "
                        + kind.convert.format(enc=name, ENC=name))
    nul = data.find(b"\x00")
    if nul >= 0:
        line, col = _line_col_bytes(data, nul)
        raise _fail(source, f"a binary file, not {kind.text} text (a NUL byte at line {line}, "
                    f"column {col}); give a UTF-8 {kind.text} file")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line, col = _line_col_bytes(data, exc.start)
        raise _fail(source, f"not UTF-8 text: byte 0x{data[exc.start]:02x} at line {line}, "
                    f"column {col} is not UTF-8 (Latin-1 or Windows-1252 text?); "
                    + kind.convert.format(enc="windows-1252", ENC="WINDOWS-1252")) from None


def read_text(path: str | os.PathLike, source: str, kind: FileKind = SCENARIO) -> str:
    """The UTF-8 text of the regular file ``path`` of at most :data:`MAX_BYTES` (see
    :func:`read_bytes` and :func:`decode`)."""
    return decode(read_bytes(path, source, kind), source, kind)


def _line_col_bytes(data: bytes, pos: int) -> tuple[int, int]:
    start = data.rfind(b"\n", 0, pos) + 1
    return data.count(b"\n", 0, pos) + 1, len(data[start:pos].decode("utf-8", "ignore")) + 1


def exists(path: str | os.PathLike) -> bool:
    """Whether ``path`` names something (``False`` also for a path that cannot be looked at: a
    name too long, a symbolic link that loops, a NUL character), never an exception."""
    return os.path.exists(path)


def absolute(path: str | os.PathLike) -> str:
    """``path`` made absolute: the folders on its way resolved (symbolic links followed), its
    own name kept as written, so that a link to a device or a link that loops is still named
    by the user's name when reading it is refused. Never an exception (``Path.resolve`` raises
    RuntimeError for a loop before Python 3.13): a folder that cannot be resolved is kept too."""
    p = Path(path)
    try:
        return str(p.parent.resolve() / p.name)
    except (OSError, RuntimeError, ValueError):
        return str(p.absolute())
