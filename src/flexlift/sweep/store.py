"""The folder of a sweep: resumable, and still only ever flexlift's own.

A sweep cannot be built aside and swapped in whole like the other commands' outputs
(:mod:`flexlift.output.folders`): it must keep every finished case where a rerun finds it.
So its folder is written in place, under the same rules otherwise:

- It carries the marker ``.flexlift-output`` from the start, with ``command: sweep``, the
  SPEC's checksum, and ``complete: false`` until the final files are written. Other commands
  refuse an incomplete folder; a rerun of the same SPEC resumes it; a different SPEC is
  refused (one line), as is a folder holding anything flexlift did not write or the output of
  another command.
- Each finished case is one file ``cases/case_NNNN.json`` (and, with ``keep: histories``,
  ``cases/case_NNNN_<mode>.nc``), written atomically (temporary file, then rename) by the
  coordinating process as the case finishes: a kill at any moment leaves whole case files, and
  perhaps a hidden temporary file of ours, which the next run removes.
- ``spec.yaml`` (the SPEC as run, with ``base: base.yaml``) and ``base.yaml`` (the base
  scenario with ``set`` applied) are written first; ``results.nc``, ``summary.json``,
  ``report.html`` and ``rerun/case_NNNN.yaml`` at the end, each atomically; then the marker
  lists every file and says ``complete: true``.
- The lock file ``.NAME.lock`` beside the folder (the one every flexlift command takes) refuses
  a second run on the same folder while one is writing it.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import time
from collections.abc import Iterator
from pathlib import Path

from flexlift import __version__
from flexlift.errors import clean
from flexlift.output.files import dir_mode, write_json, write_text
from flexlift.output.folders import MARKER, OutputError, _locked, read_marker
from flexlift.sweep.spec import SweepSpec

COMMAND = "sweep"
#: the files a sweep writes at its top level, beside cases/ and rerun/
TOP_FILES = {MARKER, "spec.yaml", "base.yaml", "results.nc", "summary.json", "report.html"}
_CASE = re.compile(r"case_\d{4,7}(\.json|_[a-z-]+\.nc)")
_RERUN = re.compile(r"case_\d{4,7}\.yaml")
#: the hidden temporary files of :func:`flexlift.output.files.atomic_file`
_TEMP = re.compile(r"\.[^/]+\.[A-Za-z0-9_]{6,}(\.tmp|\.nc|\.png)")


def _refuse(shown: str, why: str) -> OutputError:
    return OutputError("--out", shown, why)


class SweepFolder:
    """The output folder of one sweep (module docstring); use :meth:`open`."""

    def __init__(self, final: Path, shown: str, spec: SweepSpec, run_id: str):
        self.path, self.shown, self.spec, self.run_id = final, shown, spec, run_id
        self.checksum = spec.checksum()
        self.cases = final / "cases"

    # ------------------------------------------------------------------ opening
    @classmethod
    @contextlib.contextmanager
    def open(cls, target: str | os.PathLike, spec: SweepSpec, run_id: str) -> Iterator[SweepFolder]:
        """Lock ``target``, check that it is new, empty or this SPEC's sweep, and prepare it
        (raises :class:`~flexlift.output.folders.OutputError`, one line, otherwise)."""
        shown = os.fspath(target)
        final = Path(os.path.abspath(shown))
        folder = cls(final, shown, spec, run_id)
        folder._check_place()
        try:
            final.parent.mkdir(parents=True, exist_ok=True)
            with _locked(final, shown):
                folder._prepare()
                yield folder
        except OSError as exc:
            reason = exc.strerror or str(exc)
            raise _refuse(shown, f"could not be written: {reason}"
                          f"{f' ({exc.filename})' if exc.filename else ''}; the finished cases "
                          "are kept (free some space or check the permissions, then rerun)") from None

    def _check_place(self) -> None:
        final, shown = self.path, self.shown
        cwd = Path.cwd().resolve()
        if final == cwd or cwd.is_relative_to(final):
            raise _refuse(shown, "is the current folder (or holds it); choose a sub-folder")
        if final.is_symlink():
            raise _refuse(shown, "is a symbolic link; give the folder itself or a new name")
        if final.exists() and not final.is_dir():
            raise _refuse(shown, "is a file, not a folder; choose a new or empty folder")

    def _prepare(self) -> None:
        final, shown = self.path, self.shown
        if final.exists() and os.listdir(final):
            marker = read_marker(final)
            if marker is None:
                raise _refuse(shown, f"holds files flexlift did not write (no {MARKER} marker); "
                                     "choose a new or empty folder")
            if marker.get("command") != COMMAND:
                raise _refuse(shown, f"holds the output of `flexlift {clean(str(marker.get('command')), 20)}`, "
                                     "not a sweep; choose another --out")
            if marker.get("spec_checksum") != self.checksum:
                raise _refuse(shown, "holds a sweep of another SPEC (or another base scenario); "
                                     "rerun with the SPEC it was started with to resume it, or "
                                     "choose another --out")
            self._check_contents(marker)
        final.mkdir(mode=0o700, exist_ok=True)
        os.chmod(final, dir_mode())
        self.cases.mkdir(exist_ok=True)
        self._marker(complete=False)
        write_text(final / "spec.yaml", self.spec.to_yaml())
        write_text(final / "base.yaml", self.spec.base.to_yaml())

    def _check_contents(self, marker: dict) -> None:
        """Refuse anything flexlift did not write; remove our own leftover temporary files."""
        listed = set(marker.get("files", []))
        temps = []
        for root, dirs, files in os.walk(self.path):
            rel = Path(root).relative_to(self.path)
            for n in dirs + files:
                p = (rel / n).as_posix()
                full = self.path / p
                if full.is_symlink() or not (full.is_dir() or full.is_file()):
                    raise _refuse(self.shown, f"holds {p[:60]!r}, which flexlift did not write; "
                                              "move it away or choose another --out")
                if _TEMP.fullmatch(n) and full.is_file() and rel.as_posix() in (".", "cases", "rerun"):
                    temps.append(full)
                elif not (p in listed or _ours(p)):
                    raise _refuse(self.shown, f"holds {p[:60]!r}, which flexlift did not write; "
                                              "move it away or choose another --out")
        for t in temps:  # an atomic write cut short by a kill: our own temporary file
            with contextlib.suppress(OSError):
                t.unlink()

    # ------------------------------------------------------------------ cases
    def case_path(self, name: str) -> Path:
        return self.cases / f"{name}.json"

    def finished(self, names: dict[int, str]) -> dict[int, dict]:
        """The records of the cases already finished here (``names``: index -> case name).
        A record that cannot be read or belongs to another SPEC is not finished; a lost case
        is not finished either (a rerun tries it again)."""
        out = {}
        for i, name in names.items():
            p = self.case_path(name)
            try:
                rec = json.loads(p.read_text(encoding="utf-8"))
            except (OSError, ValueError):
                continue
            if (isinstance(rec, dict) and rec.get("spec_checksum") == self.checksum
                    and rec.get("case") == i and rec.get("status") in ("completed", "failed")):
                out[i] = rec
        return out

    def write_case(self, name: str, record: dict, datasets: dict) -> None:
        """The case's files, atomically: its histories first, its record last (the record's
        presence is what makes a case finished)."""
        from flexlift.ascent import Result
        from flexlift.output.results import save_netcdf

        for mode, ds in datasets.items():
            save_netcdf(Result(ds), self.cases / f"{name}_{mode}.nc")
        write_json(self.case_path(name), {**record, "spec_checksum": self.checksum})

    # ------------------------------------------------------------------ the end
    def finish(self) -> None:
        """Mark the folder complete, listing every file in it."""
        files = set()
        for root, dirs, names in os.walk(self.path):
            rel = Path(root).relative_to(self.path)
            files |= {(rel / n).as_posix() for n in dirs + names}
        self._marker(complete=True, files=sorted(files - {MARKER}))

    def _marker(self, complete: bool, files=()) -> None:
        write_json(self.path / MARKER, {
            "flexlift_output": 1, "flexlift_version": __version__, "run_id": self.run_id,
            "command": COMMAND, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "complete": complete, "spec_checksum": self.checksum, "files": list(files)})


def _ours(p: str) -> bool:
    """A path a sweep writes (relative to its folder)."""
    parts = p.split("/")
    if len(parts) == 1:
        return p in TOP_FILES or p in ("cases", "rerun")
    if len(parts) == 2 and parts[0] == "cases":
        return bool(_CASE.fullmatch(parts[1]))
    if len(parts) == 2 and parts[0] == "rerun":
        return bool(_RERUN.fullmatch(parts[1]))
    return False

