"""Record which Python versions every pin of the locks installs on: requirements/python-support.json.

For each supported Python (SUPPORTED: the oldest, Debian 12's 3.11.2, and the first release of
each newer minor), pip itself resolves both locks as it would install them on that Python
(``pip install --dry-run --report --python-version X --no-deps --require-hashes``): a pin
whose own Requires-Python excludes X, or with no file for X, fails here. The table keeps, for
each pin, the version and the Requires-Python that pip read from the distribution's metadata;
tests/test_python_support.py checks it against the locks, pyproject.toml and the installed
distributions, offline.

Usage (``./dev lock`` runs it after compiling the locks)::

    python requirements/support.py --write
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
LOCKS = ("run.lock", "test.lock")
# The versions flexlift is tested on (keep in step with ./dev and pyproject's requires-python).
SUPPORTED = ("3.11.2", "3.12.0", "3.13.0")
TABLE = HERE / "python-support.json"


def resolve(lock: Path, python: str) -> dict[str, dict[str, str | None]]:
    """{pin: {version, requires_python}} of LOCK as pip resolves it for PYTHON."""
    with tempfile.TemporaryDirectory() as tmp:
        report = Path(tmp) / "report.json"
        subprocess.run(
            [sys.executable, "-m", "pip", "install", "--dry-run", "--quiet", "--ignore-installed",
             "--no-deps", "--require-hashes", "--disable-pip-version-check",
             "--python-version", python, "--target", str(Path(tmp) / "target"),
             "--report", str(report), "-r", str(lock)],
            check=True)
        installs = json.loads(report.read_text())["install"]
    return {item["metadata"]["name"].lower().replace("_", "-"): {
                "version": item["metadata"]["version"],
                "requires_python": item["metadata"].get("requires_python")}
            for item in installs}


def table() -> dict:
    """The whole table: the supported versions, and per lock each pin's version and range."""
    out: dict = {"supported": list(SUPPORTED), "locks": {}}
    for name in LOCKS:
        pins: dict = {}
        for python in SUPPORTED:
            for pin, meta in resolve(HERE / name, python).items():
                if pins.setdefault(pin, meta) != meta:
                    raise SystemExit(f"{name}: {pin} resolves differently on Python {python}")
        out["locks"][name] = dict(sorted(pins.items()))
    return out


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--write", action="store_true", help=f"write {TABLE.name}")
    args = parser.parse_args()
    text = json.dumps(table(), indent=1) + "\n"
    if args.write:
        TABLE.write_text(text)
    else:
        sys.stdout.write(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
