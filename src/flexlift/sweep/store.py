"""The folder of a sweep: resumable, and still only ever flexlift's own.

A sweep cannot be built aside and swapped in whole like the other commands' outputs: it must
keep every finished case where a rerun finds it. It is written in place through
:func:`flexlift.output.folders.incremental_folder`, under the same rules otherwise:

- The marker ``.flexlift-output`` is written first, with ``command: sweep``, the SPEC's
  checksum as its ``identity`` and ``complete: false`` until the final files are written.
  Other commands refuse an incomplete folder; a rerun of the same SPEC continues it; another
  SPEC, another command's output, or a folder holding anything flexlift did not write is
  refused (one line) and nothing in it is touched.
- Each finished case is one file ``cases/case_NNNN.json`` (and, with ``keep: histories``,
  ``cases/case_NNNN_<mode>.nc`` first), written atomically (temporary file, then rename) by
  the coordinating process as the case finishes. A case file is recognised as this sweep's
  by its content (it carries the SPEC's checksum), so the marker need not be rewritten per
  case; a kill at any moment leaves whole case files and perhaps a hidden temporary file of
  one, which the next run removes.
- ``spec.yaml`` (the SPEC as run, ``base: base.yaml``) and ``base.yaml`` (the base scenario
  with ``set`` applied) are written first; ``results.nc``, ``summary.json``, ``report.html``
  and ``rerun/case_NNNN.yaml`` at the end, each listed in the marker before it is written; then
  the marker lists every file and says ``complete: true``.
- The lock file ``.NAME.lock`` beside the folder refuses a second run on it while one writes.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
from collections.abc import Iterator
from pathlib import Path

from flexlift.output.folders import incremental_folder
from flexlift.plumbing.atomic import write_json
from flexlift.plumbing.marker import read_regular

COMMAND = "sweep"
#: a case's record, and its histories (one netCDF per control mode)
_RECORD = re.compile(r"case_\d{4,7}\.json")
_HISTORY = re.compile(r"(case_\d{4,7})_([a-z-]+)\.nc")
#: the attribute of a history file naming the sweep it belongs to
OWNER_ATTR = "flexlift_sweep_checksum"


def _read_json(path: Path):
    """A case record of this folder, or None: read only from a regular file (no link, FIFO or
    device: a planted one never blocks a resume), at most 10 MB."""
    data = read_regular(path, 10_000_000)
    try:
        return None if data is None else json.loads(data.decode("utf-8"))
    except ValueError:  # UnicodeDecodeError is one
        return None


def _nc_owner(path: Path) -> str | None:
    """The sweep checksum in a netCDF file's global attributes (None if it has none)."""
    from scipy.io import netcdf_file

    try:
        with netcdf_file(path, "r", mmap=False, maskandscale=False) as f:
            v = f._attributes.get(OWNER_ATTR)
    except Exception:  # not a netCDF 3 file: not ours
        return None
    return v.decode() if isinstance(v, bytes) else (str(v) if v is not None else None)


class SweepFolder:
    """The output folder of one sweep (module docstring); use :meth:`open`."""

    def __init__(self, inc, checksum: str):
        self.inc, self.checksum = inc, checksum
        self.path = inc.path
        self.cases = self.path / "cases"

    @classmethod
    @contextlib.contextmanager
    def open(cls, target: str | os.PathLike, spec, command: str = COMMAND
             ) -> Iterator[SweepFolder]:
        """Lock ``target``, check that it is new, empty or this SPEC's sweep, and prepare it
        (raises :class:`~flexlift.output.folders.OutputError`, one line, otherwise).
        ``command`` is the command whose folder it is (``sweep``, ``contingency``): the name
        a refusal gives it."""
        checksum = spec.checksum()
        with incremental_folder(target, command, checksum, _Owns(checksum)) as inc:
            folder = cls(inc, checksum)
            inc.claim("spec.yaml", "base.yaml", "cases")
            from flexlift.plumbing.atomic import write_text

            write_text(folder.path / "spec.yaml", spec.to_yaml())
            write_text(folder.path / "base.yaml", spec.base.to_yaml())
            folder.cases.mkdir(exist_ok=True)
            yield folder

    # ------------------------------------------------------------------ cases
    def case_path(self, name: str) -> Path:
        return self.cases / f"{name}.json"

    def finished(self, names: dict[int, str]) -> dict[int, dict]:
        """The records of the cases already finished here (``names``: index -> case name).
        A record that cannot be read or belongs to another SPEC is not finished; a lost case
        is not finished either (a rerun tries it again)."""
        out = {}
        for i, name in names.items():
            rec = _read_json(self.case_path(name))
            if (isinstance(rec, dict) and rec.get("spec_checksum") == self.checksum
                    and rec.get("case") == i and rec.get("status") in ("completed", "failed")
                    and all((self.cases / f).is_file() for f in rec.get("histories", []))):
                out[i] = rec
        return out

    def write_case(self, name: str, record: dict, datasets: dict) -> dict:
        """The case's files, atomically: its histories first, its record last (the record's
        presence is what makes a case finished). Returns the record as written."""
        files = []
        if datasets:  # (not imported for a summary only: the ascent package loads the compiled
            # code's module, a second or more in the coordinator, at its first case)
            from flexlift.ascent import Result
            from flexlift.output.results import save_netcdf
        for mode, ds in datasets.items():
            ds = ds.copy()
            ds.attrs[OWNER_ATTR] = self.checksum
            save_netcdf(Result(ds), self.cases / f"{name}_{mode}.nc")
            files.append(f"{name}_{mode}.nc")
        record = {**record, "histories": files, "spec_checksum": self.checksum}
        write_json(self.case_path(name), record)
        return record

    # ------------------------------------------------------------------ the end
    def claim(self, *relpaths: str) -> None:
        """List files in the marker before writing them (see the module docstring)."""
        self.inc.claim(*relpaths)

    def listed(self) -> set[str]:
        return set(self.inc.listed)

    def remove_own(self, rel: str, expected: bytes) -> bool:
        """Remove a file of this sweep left unchanged since it wrote it (nothing else)."""
        return self.inc.remove_own(rel, expected)

    def finish(self) -> None:
        """Mark the folder complete, listing every file in it (but the case files of a sweep
        too large for the marker to list them: they carry the SPEC's checksum)."""
        self.inc.finish(compact=lambda rel: rel.startswith("cases/"))


class _Owns:
    """Which unlisted files of a folder are this sweep's, by their content."""

    def __init__(self, checksum: str):
        self.checksum = checksum

    def __call__(self, rel: str, path: Path | None) -> bool:
        parts = rel.split("/")
        if len(parts) != 2 or parts[0] != "cases":
            return False
        name = parts[1]
        record, history = _RECORD.fullmatch(name), _HISTORY.fullmatch(name)
        if path is None:  # a temporary leftover of one of these: by its name
            return bool(record or history)
        if record:
            rec = _read_json(path)
            return isinstance(rec, dict) and rec.get("spec_checksum") == self.checksum
        if history:
            return _nc_owner(path) == self.checksum
        return False
