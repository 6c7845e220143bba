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


def _band(b: dict | None) -> str:
    return "-" if not b else f"{b['p50']:.0f} s ({b['p5']:.0f}-{b['p95']:.0f})"


def estimate_text(est: dict | None) -> str:
    """The estimator's part of the report (Markdown): its alarms, then its forecasts."""
    if est is None:
        return ""
    out = ["## What the estimator made of the readings", ""]
    out += [f"- {a['time_s']:.1f} s: **{a['kind']}** at {a['bag']} (confidence "
            f"{a['confidence']:.2f}): {a['message']}; {a['advice']}" for a in est["alarms"]]
    if not est["alarms"]:
        out.append("No fault detected.")
    out += ["", "Forecasts (5-95 %): under the commands as they stand, held; and under the "
                "controller's advice (the coordinated laws taking over at the forecast's time).",
            "", "| forecast at [s] | breakout | last arrival | P(unsafe) still to come | "
                "advice: breakout | advice: last arrival | advice: P(unsafe) |",
            "|---|---|---|---|---|---|---|"]
    for f in est["forecasts"]:
        a = f.get("advice")
        out.append(f"| {f['time_s']:.0f} | {_band(f['breakout_time_s'])} | "
                   f"{_band(f['arrival_time_s'])} | {f['p_unsafe']:.2f} | "
                   + (f"{_band(a['breakout_time_s'])} | {_band(a['arrival_time_s'])} | "
                      f"{a['p_unsafe']:.2f} |" if a else "- | - | - |"))
    c = est["filter"]
    out += ["", f"Estimated to {est['estimated_to_s']} s, {est['behind_s']} s behind the latest "
                f"reading; readings assimilated {c['assimilated']}, gated {c['gated']}, late "
                f"{c['late']}; left unread {est['unread']}, dropped (queue full) "
                f"{est['dropped_queue_full']}."
            + (f" The estimator stopped: {est['error']}." if est["error"] else ""), ""]
    return "\n".join(out)
