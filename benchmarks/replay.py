"""``flexlift replay`` on the built-in tanker's ``simulate --sensor-log`` log, as a user runs
it (a child process), with a time limit.

Measured: the log's making (``simulate``), the replay's wall time and its speed over real
time (the goal of issue 43: >= 100x for the tanker on one core), the filter's counts
(readings assimilated, gated, late; resamplings, widenings) and the alarms raised on this
fault-free log (each one a false alarm). The load average before and after is recorded: the
machine may be shared.

Usage: ``python benchmarks/replay.py [--members 16] [--forecast-every 300] [--limit 1800]``;
writes ``benchmarks/replay.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
GOAL_X = 100.0  # times real time, the tanker (issue 43)


def _run(cmd: list[str], limit: float) -> tuple[float, subprocess.CompletedProcess]:
    env = dict(os.environ, PYTHONPATH=str(ROOT / "src"), MPLBACKEND="Agg")
    t0 = time.perf_counter()
    done = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=limit)
    return time.perf_counter() - t0, done


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=16)
    ap.add_argument("--forecast-every", type=float, default=300.0)
    ap.add_argument("--limit", type=float, default=1800.0)
    ap.add_argument("--json", default=str(ROOT / "benchmarks" / "replay.json"))
    args = ap.parse_args()
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        log = Path(tmp) / "tanker.jsonl"
        t_log, done = _run([sys.executable, "-m", "flexlift", "simulate", "tanker",
                            "--sensor-log", str(log), "--out", str(Path(tmp) / "sim")],
                           args.limit)
        if done.returncode != 0:
            sys.stderr.write(done.stderr)
            return 1
        out = Path(tmp) / "replay"
        t_replay, done = _run([sys.executable, "-m", "flexlift", "replay", str(log), "tanker",
                               "--out", str(out), "--members", str(args.members),
                               "--forecast-every", str(args.forecast_every), "--json"],
                              args.limit)
        if done.returncode not in (0, 1):
            sys.stderr.write(done.stderr)
            return 1
        s = json.loads(done.stdout)
    record = {
        "command": f"python benchmarks/replay.py --members {args.members} "
                   f"--forecast-every {args.forecast_every:g}",
        "members": args.members, "forecast_every_s": args.forecast_every,
        "log_seconds": round(t_log, 1), "readings": s["log_report"]["readings"],
        "lift_time_s": s["lift_time_s"], "replay_wall_s": round(t_replay, 1),
        "replay_inside_s": s["wall_time_s"], "speed_x_real_time": s["speed_x_real_time"],
        "goal_x": GOAL_X, "meets_goal": s["speed_x_real_time"] >= GOAL_X,
        "filter": s["filter"], "forecasts": len(s["forecasts"]),
        "false_alarms": [(a["time_s"], a["kind"], a["bag"]) for a in s["alarms"]],
        "load_before": [round(x, 2) for x in load_before],
        "load_after": [round(x, 2) for x in os.getloadavg()],
    }
    Path(args.json).write_text(json.dumps(record, indent=2) + "\n")
    sys.stdout.write(json.dumps(record, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
