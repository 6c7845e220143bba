"""A newcomer's first minutes: ``python benchmarks/bench_first_run.py [--keep DIR]``.

Clones this checkout's HEAD into a fresh folder (no ``.venv``), then, as a new user would,
runs ``DIR/dev run --out first`` from another folder and times every line it prints: the
install, the compile of the ascent loop (the install step does it, saying so at least every
10 s) and the first ``flexlift run``; then a second, warm ``flexlift run`` for comparison.
Writes ``benchmarks/first_run.json``: the largest silence between two lines [s] (goal
<= 10 s), the install, compile and first-run times, the warm run's time and the ratio of
the first run to it (goal <= 2), with the load average.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent


def timed_lines(cmd: list[str], cwd: Path) -> tuple[int, list[tuple[float, str]]]:
    """Run ``cmd``; every line of its output (stdout and stderr) with its time [s]."""
    t0 = time.monotonic()
    p = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True, bufsize=1, env={**os.environ, "MPLBACKEND": "Agg"})
    lines = [(0.0, "(start)")]
    for line in p.stdout:
        lines.append((time.monotonic() - t0, line.rstrip()))
    p.wait()
    lines.append((time.monotonic() - t0, "(end)"))
    return p.returncode, lines


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--keep", type=Path, help="clone into this (new) folder and keep it")
    args = ap.parse_args()
    base = args.keep or Path(tempfile.mkdtemp(prefix="flexlift-first-"))
    clone, user = base / "flexlift", base / "user"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    user.mkdir()
    rc, lines = timed_lines([str(clone / "dev"), "run", "--out", "first"], user)
    gaps = [b[0] - a[0] for a, b in zip(lines, lines[1:])]
    at = {key: next((t for t, s in lines if re.search(pat, s)), None) for key, pat in (
        ("ready", r"environment ready"), ("compiled", r"compiled and cached"),
        ("stage_1", r"^\[1/"), ("done", r"^done in"))}
    first_run = float(re.search(r"done in ([0-9.]+) s", next(
        (s for _, s in lines if s.startswith("done in")), "done in nan s")).group(1))
    t0 = time.monotonic()
    warm_rc = subprocess.run([str(clone / ".venv" / "bin" / "flexlift"), "run", "--out", "warm",
                              "--quiet"], cwd=user, env={**os.environ, "MPLBACKEND": "Agg"}).returncode
    warm = time.monotonic() - t0
    out = {"commit": subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT,
                                    capture_output=True, text=True).stdout.strip(),
           "load_average": os.getloadavg(), "exit_codes": [rc, warm_rc],
           "largest_silence_s": round(max(gaps), 1), "goal_largest_silence_s": 10.0,
           "install_done_at_s": at["ready"], "compile_done_at_s": at["compiled"],
           "first_run_done_at_s": lines[-1][0], "first_run_s": first_run,
           "warm_run_s": round(warm, 1),
           "first_over_warm": round(first_run / warm, 2) if warm else None,
           "goal_first_over_warm": 2.0,
           "lines": [[round(t, 1), s[:120]] for t, s in lines if "WARNING: Location" not in s]}
    (HERE / "first_run.json").write_text(json.dumps(out, indent=1) + "\n")
    print(json.dumps({k: v for k, v in out.items() if k != "lines"}, indent=1))
    return 0 if rc == 0 and warm_rc == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
