"""The report at the end of a live run: the lift as it happened (what live saw) beside the
plan's simulation of the same scenario (coordinated control)."""

from __future__ import annotations

import math


def plan_summary(scenario) -> dict:
    """The coordinated simulation's summary (``flexlift simulate --json``'s keys)."""
    from flexlift.ascent.loop import simulate

    return simulate(scenario, control="coordinated", summary_only=True).summary()


def _r(v, nd=3):
    return None if v is None or not math.isfinite(v) else round(float(v), nd)


def lift_summary(outcome, lift: str, control: str) -> dict:
    """What live saw, as a JSON-ready dict."""
    kinds: dict[str, int] = {}
    for _, kind, _, _ in outcome.alarms:
        kinds[kind] = kinds.get(kind, 0) + 1
    return {"lift": lift, "control": control, "ended": outcome.reason,
            "end_time_s": _r(outcome.t_end, 1), "arrived_s": _r(outcome.arrived_s, 1),
            "max_ascent_velocity_ms": _r(outcome.max_speed),
            "max_pitch_deg": _r(math.degrees(outcome.max_pitch), 3),
            "readings": outcome.readings, "late_readings": outcome.late,
            "malformed": outcome.dropped, "commands": outcome.commands,
            "alarms": kinds, "stale_periods": outcome.stale_periods}


def report_text(lift: dict, plan: dict | None) -> str:
    """The report as Markdown: a table of the lift as it happened beside the plan."""
    arr = None
    if plan is not None:
        times = [v for v in plan["arrival_time_s"].values() if v is not None]
        arr = max(times) if times else None
    rows = [("ended", lift["ended"], plan and plan["outcome"]),
            ("last arrival [s]", lift["arrived_s"], arr),
            ("largest ascent speed [m/s]", lift["max_ascent_velocity_ms"],
             plan and plan["max_ascent_velocity_ms"]),
            ("largest pitch [deg]", lift["max_pitch_deg"], plan and plan["max_pitch_deg"])]
    out = [f"# Lift {lift['lift']} ({lift['control']})", "",
           "| | as it happened | the plan's simulation |", "|---|---|---|"]
    out += [f"| {name} | {a if a is not None else '-'} | {b if b is not None else '-'} |"
            for name, a, b in rows]
    out += ["", f"Readings {lift['readings']} ({lift['late_readings']} late), "
                f"malformed messages {sum(lift['malformed'].values())} "
                f"{lift['malformed'] or ''}, commands {lift['commands']}, "
                f"alarms {lift['alarms'] or 'none'}, control periods with stale readings "
                f"{lift['stale_periods']}.", ""]
    return "\n".join(out)
