"""A user's controller files (MATLAB ``.fis``) copied into an output folder with their
checksums, and the scenario as written there pointing at the copies: ``flexlift run
scenario.yaml`` in the output folder repeats the run with the same files and checksum."""

from __future__ import annotations

import hashlib
from pathlib import Path

from flexlift.errors import clean
from flexlift.plumbing import reading
from flexlift.plumbing.atomic import write_bytes

#: the output folder's subfolder for the copies
FOLDER = "controllers"


def copy_controller_files(scenario, folder: Path) -> tuple[object, list[dict]]:
    """Copy each of ``scenario``'s .fis files into ``folder/controllers/``; returns the scenario
    pointing at the copies (relative paths) and a record per file: key, source, copy, sha256."""
    files = scenario.controller_files()
    if not files:
        return scenario, []
    records, moved = [], {}
    for key, src in files.items():
        data = reading.read_bytes(src, f"{key} {clean(str(src), 120)}", reading.FIS)
        role = key.split(".")[1]
        name = f"{role}_{Path(src).name}"
        write_bytes(folder / FOLDER / name, data)
        digest = hashlib.sha256(data).hexdigest()
        write_bytes(folder / FOLDER / f"{name}.sha256", f"{digest}  {name}\n".encode())
        moved[key] = f"{FOLDER}/{name}"
        records.append({"key": key, "source": str(src), "copy": f"{FOLDER}/{name}",
                        "sha256": digest})
    return scenario.with_changes(**moved), records
