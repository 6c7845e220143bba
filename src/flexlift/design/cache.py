"""The evaluations of a search, one JSON line per candidate (docs/theory/design.md#resume).

``evaluations.jsonl`` in the output folder: each finished evaluation is appended as one
line, written by a single ``write`` on a file opened for appending and flushed to the disk
(a line is there whole or, cut by a kill, is an unreadable last line that is ignored). Each
line carries the search's identity (what the candidates are evaluated against: the scenario,
the target, the ladder) and the candidate's key (:meth:`~flexlift.design.space.Candidate.key`);
a rerun answers a candidate it finds from the line instead of running it again. The identity
includes the code (:meth:`flexlift.design.search.Options.identity`): a line written by
another flexlift is kept in the file but answers nothing (counted as ``stale``).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

NAME = "evaluations.jsonl"


class Cache:
    """The evaluations of one search identity kept in ``folder`` (module docstring)."""

    def __init__(self, folder: Path, identity: str):
        self.path = Path(folder) / NAME
        self.identity = identity
        self.entries: dict[str, dict] = {}
        self.hits = 0
        self.stale = 0  # lines of another identity (another input or code): not answered
        if self.path.is_file():
            for line in self.path.read_text(errors="replace").splitlines():
                try:
                    row = json.loads(line)
                except ValueError:  # a line cut short by a kill
                    continue
                if isinstance(row, dict) and row.get("identity") == identity:
                    self.entries[row["key"]] = row["result"]
                elif isinstance(row, dict):
                    self.stale += 1

    def get(self, key: str) -> dict | None:
        hit = self.entries.get(key)
        if hit is not None:
            self.hits += 1
        return hit

    def put(self, key: str, result: dict) -> None:
        """Append ``result`` as one line (one write, flushed and synced)."""
        line = json.dumps({"identity": self.identity, "key": key, "result": result},
                          sort_keys=True, allow_nan=False) + "\n"
        # never through a link planted in the folder (the cache is flexlift's own file)
        fd = os.open(self.path, os.O_WRONLY | os.O_APPEND | os.O_CREAT | os.O_NOFOLLOW
                     | getattr(os, "O_CLOEXEC", 0), 0o666)
        try:
            os.write(fd, line.encode())
            os.fsync(fd)
        finally:
            os.close(fd)
        self.entries[key] = result
