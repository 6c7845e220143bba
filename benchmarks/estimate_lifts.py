"""Issue 43's benchmark: the estimator and the fault detector over many synthetic lifts.

The lifts: the built-in tanker (every fault kind at three phases, each on another bag, and
fault-free lifts with other sensor seeds), the 73-bag plan (``benchmarks/bags_tanker.yaml``
with 50 t bags) and the built-in pipeline (a few faults and fault-free lifts). Each lift's log
is made as ``flexlift simulate --sensor-log`` makes it (``run_with_log``, the sensors of
:data:`SENSORS`: noise, 2 % dropouts, latency), then replayed by the estimator in this
process (:class:`flexlift.estimate.watch.Watch`, the engine of ``flexlift replay``). A faulted
lift is replayed to ``FOLLOW_S`` after its fault (what the detector must do is done by then);
a fault-free one to its end, with forecasts at 25, 50 and 75 % of its ascent.

Measured: per fault kind, detection (an alarm of that kind at that bag after the fault), the
delay (median, max), the isolation right; the false alarms (every alarm on a fault-free lift,
every alarm before the fault on a faulted one) per lift-hour; the arrival forecast's error at
25 / 50 / 75 % of the ascent and whether the truth lies in its 5-95 % band; the replay's
speed over real time (one process, one core). The load average before and after is recorded.

Usage: ``python benchmarks/estimate_lifts.py [--members 16] [--cases tanker,bags73,pipeline]
[--limit 5400] [--only N]``; writes ``benchmarks/estimate_lifts.json`` after every lift.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from flexlift import load_scenario  # noqa: E402
from flexlift.ascent.loop import prepare  # noqa: E402
from flexlift.estimate.forecast import forecast  # noqa: E402
from flexlift.estimate.watch import Settings, Watch  # noqa: E402
from flexlift.scenario.schema import parse_scenario  # noqa: E402
from flexlift.sensors import LogReader  # noqa: E402
from flexlift.sensors.tap import run_with_log  # noqa: E402

#: every lift's sensors: the defaults' noise, 2 % dropouts, the hull's inclinometer
SENSORS = {"depth": {"dropout": 0.02}, "pitch": {"at": ["hull"], "dropout": 0.02},
           "sling_force": {"dropout": 0.02}, "fill_flow": {"dropout": 0.02},
           "purge": {"dropout": 0.02}, "supply_pressure": {"dropout": 0.02}}
KINDS = {"bag_rupture": {}, "sling_break": {}, "supply_failure": {},
         "sensor_drift": {"rate_m_s": 0.01}, "sensor_stuck": {},
         "sensor_dropout": {"duration_s": 60.0}, "dump_valve_stuck_closed": {},
         "fill_valve_stuck_open": {}}
#: the issue's goals: the detection delay by kind [s]
GOAL_DELAY_S = {"bag_rupture": 30.0, "sling_break": 30.0}
GOAL_DELAY_OTHER_S = 120.0
#: a faulted lift is replayed this long past its fault [s]
FOLLOW_S = 300.0
#: the 73-bag plan's members (its replay is about ten times the tanker's work per member)
BAGS73_MEMBERS = 8
#: forecasts at these fractions of the ascent (separation to the last arrival)
AT = (0.25, 0.50, 0.75)


def scenario_of(case: str, seed: int, faults=()):
    if case == "bags73":
        base = load_scenario(ROOT / "benchmarks" / "bags_tanker.yaml")
        base = base.with_changes(**{"lift.catalogue_bag.lift_t": 50.0})
    else:
        base = load_scenario(case)
    d = base.model_dump(mode="json")
    d["sensors"] = {"seed": seed, **SENSORS}
    d["faults"] = list(faults)
    return parse_scenario(d)


def phases(case: str) -> dict:
    """The fault times [s] of a lift: held (the bags filled, the hull on the seabed), at
    breakout (just before separation) and in the ascent (30 % of the way up), from the
    nominal run's separation and last arrival."""
    res = prepare(scenario_of(case, 0)).run(summary_only=True)
    sep = float(res.headline["separation_time_s"])
    last = float(np.nanmax(res.dataset.arrival_time.values))
    return {"held": round(0.4 * sep), "breakout": round(sep - 25.0),
            "ascent": round(sep + 0.3 * (last - sep)), "separation": sep, "arrival": last}


def lifts(cases: list[str], times: dict) -> list[dict]:
    """The benchmark's lifts: (case, fault or None, seed), the cases taken in turn (a run
    stopped at its limit has some of each)."""
    per, seed = {}, 100
    for case in cases:
        out = per.setdefault(case, [])
        names = list(prepare(scenario_of(case, 0)).plant.names)
        kinds = list(KINDS) if case == "tanker" else ["bag_rupture", "sling_break",
                                                      "sensor_drift"]
        which = ("held", "breakout", "ascent") if case == "tanker" else ("held", "ascent")
        k = 0
        for kind in kinds:
            for phase in which:
                bag = names[(3 * k + 1) % len(names)]
                k += 1
                seed += 1
                out.append({"case": case, "seed": seed, "phase": phase, "fault": {
                    "kind": kind, "bag": bag, "time_s": float(times[case][phase]),
                    **KINDS[kind]}})
        for j in range(4 if case == "tanker" else 3):
            seed += 1  # the fault-free lifts spread through the list
            out.insert(j * (len(out) // 3 + 1), {"case": case, "seed": seed, "phase": None,
                                                  "fault": None})
    turns = [per[c] for c in cases]
    return [lift for k in range(max(map(len, turns))) for t in turns if k < len(t)
            for lift in [t[k]]]


def one_lift(lift: dict, times: dict, members: int, folder: Path) -> dict:
    case, fault = lift["case"], lift["fault"]
    sc = scenario_of(case, lift["seed"], [fault] if fault else [])
    end = (fault["time_s"] + FOLLOW_S) if fault else None
    log = folder / f"{case}-{lift['seed']}.jsonl"
    t0 = time.perf_counter()
    truth, _ = run_with_log(prepare(sc, duration=end), log, summary_only=True)
    t_log = time.perf_counter() - t0
    plan = scenario_of(case, lift["seed"])  # the estimator's scenario: the plan, no faults
    watch = Watch(plan, Settings(members=members, forecast_every_s=0.0))
    ascent = (times[case]["separation"], times[case]["arrival"])
    due = [] if fault else [ascent[0] + a * (ascent[1] - ascent[0]) for a in AT]
    fc = []
    t0 = time.perf_counter()
    for reading in LogReader(log, known=watch.known):
        watch.add(reading)
        while due and watch.est.t >= due[0]:
            fc.append(forecast(watch.est))
            due.pop(0)
    watch.flush()
    wall = time.perf_counter() - t0
    t_end = watch.history[-1][0] if watch.history else 0.0
    row = {**lift, "lift_s": round(t_end, 1), "log_wall_s": round(t_log, 2),
           "replay_wall_s": round(wall, 2), "x_real_time": round(t_end / max(wall, 1e-9), 1),
           "alarms": [(round(a.time_s, 1), a.kind, a.bag) for a in watch.alarms],
           "filter": {k: v for k, v in vars(watch.est.counts).items()
                      if k != "by_sensor_gated"}}
    t_fault = fault["time_s"] if fault else float("inf")
    row["false_alarms"] = sum(a.time_s < t_fault for a in watch.alarms)
    row["watched_fault_free_s"] = round(min(t_end, t_fault), 1)
    if fault:
        hit = [a for a in watch.alarms if a.time_s >= t_fault and a.bag == fault["bag"]
               and a.kind == fault["kind"]]
        row["detected"] = bool(hit)
        row["delay_s"] = round(hit[0].time_s - t_fault, 1) if hit else None
        after = [a for a in watch.alarms if a.time_s >= t_fault]
        row["first_after"] = (after[0].kind, after[0].bag) if after else None
    else:
        last = float(np.nanmax(truth.dataset.arrival_time.values))
        row["truth_arrival_s"] = round(last, 1)
        row["forecasts"] = [_judge(f, last) for f in fc]
    return row


def _judge(f: dict, truth: float) -> dict:
    b = f["arrival_time_s"]
    out = {"time_s": f["time_s"], "band": b, "p_unsafe": f["p_unsafe"]}
    if b:
        out["error_s"] = round(b["p50"] - truth, 1)
        out["error_of_remaining"] = round(abs(b["p50"] - truth) / max(truth - f["time_s"],
                                                                      1.0), 3)
        out["inside"] = b["p5"] <= truth <= b["p95"]
    return out


def summarise(rows: list[dict]) -> dict:
    by_kind: dict[str, list] = {}
    for r in rows:
        if r["fault"]:
            by_kind.setdefault(r["fault"]["kind"], []).append(r)
    kinds = {}
    for kind, rs in by_kind.items():
        delays = [r["delay_s"] for r in rs if r["delay_s"] is not None]
        goal = GOAL_DELAY_S.get(kind, GOAL_DELAY_OTHER_S)
        kinds[kind] = {"cases": len(rs), "named_right": sum(r["detected"] for r in rs),
                       "within_goal": sum(d <= goal for d in delays), "goal_s": goal,
                       "delay_median_s": statistics.median(delays) if delays else None,
                       "delay_max_s": max(delays) if delays else None}
    hours = sum(r["watched_fault_free_s"] for r in rows) / 3600.0
    false = sum(r["false_alarms"] for r in rows)
    fc = [f for r in rows if not r["fault"] for f in r.get("forecasts", [])]
    by_at = {}
    for k, a in enumerate(AT):
        at = [r["forecasts"][k] for r in rows if not r["fault"] and len(r.get("forecasts",
                                                                             [])) > k]
        with_band = [f for f in at if f.get("band")]
        by_at[f"{int(a * 100)}%"] = {
            "forecasts": len(at), "with_arrival": len(with_band),
            "median_error_of_remaining": statistics.median(
                [f["error_of_remaining"] for f in with_band]) if with_band else None,
            "inside_band": sum(f["inside"] for f in with_band)}
    speeds = {}
    for case in {r["case"] for r in rows}:
        free = [r["x_real_time"] for r in rows if r["case"] == case and not r["fault"]]
        speeds[case] = statistics.median(free) if free else None
    return {"lifts": len(rows), "by_kind": kinds, "false_alarms": false,
            "fault_free_hours_watched": round(hours, 2),
            "false_alarms_per_hour": round(false / hours, 2) if hours else None,
            "arrival_forecasts": by_at, "forecasts": len(fc),
            "replay_x_real_time_fault_free_median": speeds}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--members", type=int, default=16)
    ap.add_argument("--cases", default="tanker,bags73,pipeline")
    ap.add_argument("--limit", type=float, default=5400.0, help="wall time [s], all lifts")
    ap.add_argument("--only", type=int, default=None, help="the first N lifts only")
    ap.add_argument("--out", default=str(ROOT / "benchmarks" / "estimate_lifts.json"))
    args = ap.parse_args(argv)
    start = time.perf_counter()
    cases = args.cases.split(",")
    result = {"load_before": os.getloadavg(), "members": args.members, "rows": []}
    times = {case: phases(case) for case in cases}
    result["phases"] = times
    todo = lifts(cases, times)[: args.only]
    result["planned"] = len(todo)
    with tempfile.TemporaryDirectory(prefix="flexlift-bench-estimate-") as tmp:
        for lift in todo:
            if time.perf_counter() - start > args.limit:
                result["stopped"] = f"the {args.limit:g} s limit: {len(result['rows'])} done"
                break
            members = min(args.members, BAGS73_MEMBERS) if lift["case"] == "bags73" \
                else args.members
            row = one_lift(lift, times, members, Path(tmp))
            row["members"] = members
            result["rows"].append(row)
            result["summary"] = summarise(result["rows"])
            Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
            print(json.dumps({k: row.get(k) for k in ("case", "phase", "fault", "detected",
                                                      "delay_s", "false_alarms",
                                                      "x_real_time")}), flush=True)
            Path(tmp, f"{lift['case']}-{lift['seed']}.jsonl").unlink()
    result["load_after"] = os.getloadavg()
    result["wall_s"] = round(time.perf_counter() - start, 1)
    Path(args.out).write_text(json.dumps(result, indent=1) + "\n")
    return result


if __name__ == "__main__":
    main()
