"""What is still to come, from the members as they stand (docs/theory/estimation.md#forecast).

:func:`forecast` forks every member (:meth:`flexlift.ascent.loop.Ascent.fork`: the members
stay where they are), runs the forks to their ends together
(:func:`flexlift.ascent.batch.advance_batch`: one compiled call per chunk for all) under the
members' own control (``under``: the scenario's controller; for commanded members, the
commands as they stand, held), and reads each fork's result as a simulation's: its separation and
breakout time, each bag's arrival, the largest ascent speed and pitch from now on and its
outcome. P(unsafe) is for the rest of the lift: a member counts when its lift ends unsafe
and its first breach (a speed or pitch limit, a surface breach, a resettle) comes at or after
the forecast's time; a breach already past is counted apart (``unsafe_already``). A breach of
the bending allowable has no time in the results (its envelope is over the hull): it counts
as still to come, the cautious reading. Each quantity is given as its 5, 50 and 95 % over the members that have it, and how
many do (a member that never separates has no breakout time: the band is of those that do).
"""

from __future__ import annotations

import math

import numpy as np

from flexlift.ascent.batch import advance_batch
from flexlift.ascent.loop import COMMANDED
from flexlift.errors import SimulationError

#: the events that break a limit at their time (:func:`flexlift.ascent.result.explain`)
BREACHES = ("limit_ascent_velocity", "limit_descent_velocity", "limit_pitch",
            "surface_breach", "resettle")
#: the quantiles of a forecast [%]
QUANTILES = (5, 50, 95)


def band(values) -> dict | None:
    """``{p5, p50, p95, n}`` of the finite ``values``; None when none is."""
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if v.size == 0:
        return None
    q = np.percentile(v, QUANTILES)
    return {"p5": round(float(q[0]), 3), "p50": round(float(q[1]), 3),
            "p95": round(float(q[2]), 3), "n": int(v.size)}


def forecast(estimator, mode: str | None = None) -> dict:
    """The forecast at the estimator's time: ``time_s``; ``separation_time_s``,
    ``breakout_time_s``, ``arrival_time_s`` (the last bag's) and ``arrival_by_bag``, each a
    :func:`band` [s]; ``max_ascent_velocity_ms`` [m/s] and ``max_pitch_deg`` [deg] still to
    come, bands; ``p_unsafe`` (the share of the members whose lift ends unsafe from a breach
    still to come: the module docstring), ``unsafe_already`` (the share whose breach is past)
    and ``members``; ``under``: what runs the valves from now. ``mode``: the forks' valves
    run from now by that mode's controller (:meth:`flexlift.ascent.loop.Ascent.fork`), the
    forecast under the controller's advice; default the members' own control."""
    ens, now = estimator.ensemble, estimator.t
    forks = [run.fork(mode) for run in ens.runs]
    advance_batch(forks, ended=list(ens.ended))
    results = []
    for run in forks:
        try:
            results.append(run.finish(summary_only=True))
        except SimulationError as error:  # the numbers up to where they failed
            results.append(error.partial)
    names = list(ens.plant.names)
    arrival = {name: [] for name in names}
    own = ens.runs[0].mode
    out = {"time_s": round(now, 3), "members": len(results),
           "under": (f"the {mode} controller, taking over now" if mode not in (None, own)
                     else "the commands as they stand, held" if own == COMMANDED
                     else f"the {own} controller")}
    sep, brk, last, vmax, pmax, unsafe, already = [], [], [], [], [], 0, 0
    for res in results:
        h = res.headline
        sep.append(h.get("separation_time_s"))
        brk.append(h.get("breakout_time_s"))
        ds = res.dataset
        times = ds.arrival_time.values
        for name, t in zip(names, times):
            arrival[name].append(float(t))
        last.append(float(np.max(times)) if np.all(np.isfinite(times)) else None)
        later = ds.time.values >= now
        vmax.append(float(np.max(ds.ascent_velocity.values[later], initial=0.0)))
        pmax.append(math.degrees(float(np.max(np.abs(ds.pitch.values[later]), initial=0.0))))
        if res.outcome.get("kind") == "unsafe":
            first = first_breach(res.events)
            past = first is not None and first < now
            unsafe, already = unsafe + (not past), already + past
    out.update(separation_time_s=band(sep), breakout_time_s=band(brk),
               arrival_time_s=band(last),
               arrival_by_bag={name: band(v) for name, v in arrival.items()},
               max_ascent_velocity_ms=band(vmax), max_pitch_deg=band(pmax),
               p_unsafe=round(unsafe / max(len(results), 1), 4),
               unsafe_already=round(already / max(len(results), 1), 4))
    return out


def first_breach(events: list[dict]) -> float | None:
    """The time [s] of the first event among :data:`BREACHES`, None when none."""
    times = [float(e["time_s"]) for e in events if e["kind"] in BREACHES]
    return min(times) if times else None
