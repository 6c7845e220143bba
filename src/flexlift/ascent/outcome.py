"""What happened in an ascent, in one word and one sentence (the criteria: docs/theory/factors.md#criteria).

- ``safe``: every criterion held, the target held for ``simulation.hold_time_s``;
- ``unsafe``: a limit broken (any criterion but ``reached_target``), with its cause; or the
  numerics failed, so that whether the lift was safe is not known;
- ``not_achieved``: every limit held but the plan cannot finish: the hull never separates (no
  net pull, or one so weak it would take longer than the longest run), the bags stall short of
  the target, or they arrive and do not settle (an oscillation, with its amplitude and
  period);
- ``incomplete``: every limit held and the ascent converges, but the run ended first; with
  the further time it needs (the remaining distance at the planned, valve-limited speed plus
  the remaining hold).

A failure probability counts ``unsafe`` and ``not_achieved``; ``incomplete`` is a run too
short to say, never an unsafe lift.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from flexlift import constants as C

OUTCOMES = ("safe", "unsafe", "not_achieved", "incomplete")
#: a bag still short of the target is converging while it rises at least this fraction of the
#: planned speed over the last :data:`WINDOW_S`
RISING_FRACTION = 0.05
#: the stretch at the end of a run over which the motion is judged [s]
WINDOW_S = 120.0
#: an oscillation is decaying (converging) when its last third (of the time since the last
#: arrival) is at most this fraction of the third before
DECAY = 0.7


@dataclass(frozen=True)
class Outcome:
    """``kind`` (one of :data:`OUTCOMES`), ``cause`` (one sentence with numbers) and, when
    incomplete, ``needs_s``: about how much longer the run must go on [s]."""

    kind: str
    cause: str
    needs_s: float | None = None

    def as_dict(self) -> dict:
        return asdict(self)


def judge(run, ds, events: list[dict], crit: dict, reasons: dict, error) -> Outcome:
    """The outcome of a finished run (``ds`` its dataset, ``reasons`` the failed criteria's
    causes from :func:`flexlift.ascent.result.explain`)."""
    if error:
        return Outcome("unsafe", f"{error}: whether the lift was safe is not known")
    broken = [k for k, ok in crit.items() if k != "reached_target" and not ok]
    if broken:
        return Outcome("unsafe", "; ".join(f"{k.replace('_', ' ')}: {reasons.get(k, 'failed')}"
                                          for k in broken))
    if crit.get("reached_target", True):
        return Outcome("safe", f"every limit held and the target was held for "
                               f"{run.settings.hold_time:.0f} s")
    if not any(e["kind"] == "separation" for e in events):
        return _not_separated(run, ds, reasons.get("reached_target", "never separated"))
    att = np.asarray(run.switches.attached) > 0
    arrived = np.isfinite(run.state.arrival) & att
    if not arrived[att].all():
        return _short_of_target(run, ds, att & ~arrived)
    return _not_held(run, ds, att)


# --------------------------------------------------------------------------- estimates
def remaining_ascent_s(scenario, plant, z_from: float, from_rest: bool = True) -> float:
    """Time [s] to rise from ``z_from`` to the target [m] at the planned speed, slowed where
    the purge valves cannot keep up (:func:`flexlift.control.profile.speed_limit`), plus the
    time lost decelerating, v / 2a, and accelerating (``from_rest``), another v / 2a."""
    from flexlift.control.profile import speed_limit

    c, a = scenario.control, plant.bags
    dist = c.target_height_m - z_from
    if dist <= 0:
        return 0.0
    z = np.linspace(z_from, c.target_height_m, 401)
    v = np.full(z.size, c.ascent_speed_m_s)
    for i in np.flatnonzero(plant.external):
        v = np.minimum(v, speed_limit(z, plant.neutral_volume[i], a.capacity[i], a.purge_max[i],
                                      c.purge_margin, a.water_depth, a.p_atm, a.rho_g))
    v = np.maximum(v, 1e-6)
    inv = 1.0 / v
    return float(np.sum(0.5 * (inv[1:] + inv[:-1]) * np.diff(z))
                 + (1.0 if from_rest else 0.5) * c.ascent_speed_m_s / c.ascent_acceleration_m_s2)


def longest_run_s(scenario) -> float:
    """The longest run the scenario's limits allow [s] (``simulation.duration_s: auto``)."""
    return float(scenario.simulation.longest_run_s)


def _set_duration(end: float, needs: float, scenario) -> str:
    total = end + needs
    step = 10 ** max(int(math.log10(max(total, 1.0))) - 1, 0)
    if total > longest_run_s(scenario):
        return (f"longer than the longest run the scenario allows "
                f"({longest_run_s(scenario):,.0f} s)")
    return (f"set simulation.duration_s to at least {math.ceil(total / step) * step:,.0f} s, "
            "or auto")


def _incomplete(run, ds, what: str, needs: float) -> Outcome:
    end = float(ds.time.values[-1])
    return Outcome("incomplete", f"{what}; every limit held, but the run ended at {end:,.0f} s,"
                   f" about {needs:,.0f} s too soon ({_set_duration(end, needs, run.scenario)})",
                   round(needs, 1))


def _not_separated(run, ds, why: str) -> Outcome:
    sc, P = run.scenario, run.plant
    end = float(ds.time.values[-1])
    g_t = P.gravity * C.TONNE
    U, H = float(ds.uplift.values[-1]), float(ds.holding_force.values[-1])
    if U <= 0.01 * g_t:
        return Outcome("not_achieved", f"{why}; the net uplift at the end is "
                       f"{max(U, 0.0) / g_t:.1f} t: "
                       "the bags never pull against the suction, so it never breaks out")
    t_sep = sc.seabed.breakout_time_s * max(H / U - 1.0, 0.0)
    needs = t_sep + remaining_ascent_s(sc, P, 0.0) + sc.simulation.hold_time_s
    if end + t_sep > longest_run_s(sc):
        return Outcome("not_achieved", f"{why}; under the {U / g_t:.0f} t of net uplift at the "
                       f"end it would separate ~{end + t_sep:,.0f} s after the start, beyond the "
                       f"longest run the scenario allows ({longest_run_s(sc):,.0f} s)")
    return _incomplete(run, ds, f"{why}; under the {U / g_t:.0f} t of net uplift at the end it "
                       f"separates in ~{t_sep:,.0f} s more, then rises and holds", needs)


def _short_of_target(run, ds, behind: np.ndarray) -> Outcome:
    sc = run.scenario
    t, z = ds.time.values, ds.height.values
    end, target, tol = float(t[-1]), sc.control.target_height_m, sc.limits.arrival_tolerance_m
    w = t >= end - WINDOW_S
    span = max(float(t[w][-1] - t[w][0]), 1e-9)
    speed = (z[-1] - z[w][0]) / span
    idx = np.flatnonzero(behind)
    low = idx[np.argmin(z[-1, idx])]
    names = [str(b) for b in ds.bag.values]
    n, N = idx.size, int(np.count_nonzero(np.asarray(run.switches.attached) > 0))
    plan = sc.control.ascent_speed_m_s
    rising = bool(np.all(speed[idx] >= RISING_FRACTION * plan))
    ref = ds.reference_height.values[-1, idx] if "reference_height" in ds else np.full(n, np.nan)
    plan_running = bool(np.any(np.isfinite(ref) & (ref < target - tol)))
    if rising or plan_running:
        needs = (remaining_ascent_s(sc, run.plant, float(z[-1, low]), from_rest=not rising)
                 + sc.simulation.hold_time_s)
        what = (f"{n} of the {N} bags still rising, the lowest ({names[low]}) at "
                f"{z[-1, low]:.1f} m, {target - z[-1, low]:.1f} m below the {target:g} m target; "
                f"that distance at the planned speed and the {sc.simulation.hold_time_s:.0f} s hold")
        return _incomplete(run, ds, what, needs)
    return Outcome("not_achieved", (
        f"{n} of the {N} bags stalled short of the {target:g} m target: the lowest, {names[low]}, "
        f"at {z[-1, low]:.1f} m ({target - z[-1, low]:.1f} m below, outside the ±{tol:g} m "
        f"tolerance), moving {speed[low] * 60:+.2f} m/min over the last {span:.0f} s while the "
        f"plan asks {plan:g} m/s: the lift cannot bring it up (more lift at that point, or a "
        "larger volume authority)"))


def _oscillation(t: np.ndarray, e: np.ndarray) -> tuple[float, float | None]:
    """Half the peak-to-peak swing of ``e`` [m] and its period [s] from the crossings of its
    mean (None with fewer than three)."""
    amp = 0.5 * float(np.ptp(e))
    s = np.signbit(e - e.mean())
    k = np.flatnonzero(s[1:] != s[:-1])
    if k.size < 3:
        return amp, None
    return amp, 2.0 * float(t[k[-1]] - t[k[0]]) / (k.size - 1)


def _not_held(run, ds, att: np.ndarray) -> Outcome:
    sc, R = run.scenario, run.state
    t, z = ds.time.values, ds.height.values
    end, target, tol = float(t[-1]), sc.control.target_height_m, sc.limits.arrival_tolerance_m
    hold = sc.simulation.hold_time_s
    last = float(np.nanmax(R.arrival[att]))
    start = float(R.scalars[2])  # within the tolerance since then (nan: not now)
    w = t >= last
    tw, e = t[w], z[w][:, att] - target
    names = np.asarray([str(b) for b in ds.bag.values])[att]
    # judged on the last two thirds of the time since the last arrival (the first holds the
    # overshoot of the arrival itself)
    third = (tw - tw[0]) / max(float(tw[-1] - tw[0]), 1e-9) if tw.size else tw
    half = third >= 2.0 / 3.0
    held_since = f"held within ±{tol:g} m for {end - start:,.0f} s of the {hold:.0f} s"
    if math.isfinite(start) and (tw.size <= 6 or start <= tw[half][0]):
        return _incomplete(run, ds, f"every bag arrived (the last at {last:,.0f} s) and "
                           + held_since, hold - (end - start))
    if tw.size <= 6:
        return _incomplete(run, ds, f"every bag arrived, the last at {last:,.0f} s, just before "
                           f"the end; the {hold:.0f} s hold", hold)
    middle = (third >= 1.0 / 3.0) & ~half
    dev1 = float(np.abs(e[middle]).max()) if middle.any() else math.inf
    dev2 = float(np.abs(e[half]).max())
    if dev2 <= DECAY * dev1:  # settling: extrapolate the decay
        span = float(tw[half][-1] - tw[half][0])
        thirds = math.log(tol / dev2) / math.log(dev2 / dev1) if dev2 > tol else 0.0
        needs = max(thirds, 0.0) * span + hold
        return _incomplete(run, ds, f"every bag arrived (the last at {last:,.0f} s) and is "
                           f"settling (within ±{dev2:.1f} m of the target in the last "
                           f"{span:,.0f} s, from ±{dev1:.1f} m before); its decay to ±{tol:g} m "
                           f"and the {hold:.0f} s hold", needs)
    later = third >= 1.0 / 3.0
    swings = [_oscillation(tw[later], e[later][:, j]) for j in range(e.shape[1])]
    j = int(np.argmax([s[0] for s in swings]))
    amp, period = swings[j]
    centre = float(e[later][:, j].mean())
    about = f" about {target + centre:.1f} m" if abs(centre) > 0.25 * tol else ""
    how = (f"oscillating ±{amp:.2g} m{about}, period {period:.0f} s" if period else
           f"drifting up to {dev2:.2g} m from the target")
    return Outcome("not_achieved", (
        f"every bag arrived (the last at {last:,.0f} s); they did not hold within ±{tol:g} m "
        f"of the {target:g} m target for {hold:.0f} s: {how} ({names[j]} the widest, over the "
        f"last {float(tw[-1] - tw[later][0]):,.0f} s of the run, not settling)"))
