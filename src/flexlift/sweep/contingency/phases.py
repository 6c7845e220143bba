"""The phases of a lift at which a single failure is applied, from the fault-free run's own
events (docs/guide/contingency.md; SPEC §10.4):

- ``pull``: halfway between the start of filling (the first fill of any bag) and the
  separation;
- ``breakout``: the separation plus the suction's release time ``seabed.release_time_s``;
- ``mid``: when the mean height of the bag points first reaches half the target height;
- ``near_target``: when the bags' total gas volume peaks in the upper half of the ascent
  (from ``mid`` on; the end of its plateau when the controller holds it level), or when the
  mean height first reaches 90 % of the target, if that comes earlier;
- the times a user names (``t1800`` for 1800 s), each inside the fault-free run.

A phase the fault-free run never reached (it never separated, never rose half way) is
``None`` with the reason; the rest are still found.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from flexlift.errors import InputError

PHASES = ("pull", "breakout", "mid", "near_target")
#: the fraction of the target height that marks ``near_target`` at the latest
NEAR = 0.9
#: a total gas volume within this fraction of its peak is at the peak (a plateau's end)
PLATEAU = 1e-3


@dataclass(frozen=True)
class Phase:
    """A phase: its ``name``, its ``time_s`` [s] (None: not reached) and how it was found."""

    name: str
    time_s: float | None
    how: str

    def as_dict(self) -> dict:
        return {"name": self.name, "time_s": self.time_s, "how": self.how}


def user_phase_name(t: float) -> str:
    """The name of a user's time ``t`` [s]: ``t1800`` (``t1800.5`` when not whole)."""
    return f"t{t:g}"


def find_phases(ds, events: list[dict], scenario, names=PHASES, times=()) -> list[Phase]:
    """The phases ``names`` (of :data:`PHASES`) and the user's ``times`` [s] of a fault-free
    run (``ds`` its dataset, ``events`` its event list), in time order of the named ones first.

    Raises
    ------
    InputError
        A time outside the fault-free run (before 0 or after its end).
    """
    t = ds.time.values
    end = float(t[-1])
    fill = ds.fill_rate.values
    filling = np.flatnonzero((fill > 0).any(axis=1))
    t_fill = float(t[filling[0]]) if filling.size else 0.0
    sep = next((e["time_s"] for e in events if e["kind"] == "separation"), None)
    target = scenario.control.target_height_m
    mean_z = ds.height.values.mean(axis=1)
    found = {}
    if sep is None:
        why = "not reached: the fault-free run never separated"
        found["pull"] = Phase("pull", None, why)
        found["breakout"] = Phase("breakout", None, why)
    else:
        found["pull"] = Phase("pull", round(0.5 * (t_fill + sep), 1),
                              f"halfway between the start of filling ({t_fill:.0f} s) and the "
                              f"separation ({sep:.0f} s)")
        tb = sep + scenario.seabed.release_time_s
        found["breakout"] = (Phase("breakout", round(tb, 1), f"the separation ({sep:.0f} s) "
                                   f"plus the suction's release time "
                                   f"({scenario.seabed.release_time_s:g} s)")
                             if tb <= end else Phase("breakout", None, "not reached: the "
                                                     "fault-free run ended first"))
    half = _first(t, mean_z >= 0.5 * target)
    found["mid"] = (Phase("mid", round(half, 1), f"the mean bag height first at half the "
                          f"target ({0.5 * target:g} m)") if half is not None else
                    Phase("mid", None, "not reached: the mean bag height never came to half "
                          "the target"))
    total = ds.gas_volume.values.sum(axis=1)
    t_peak = _volume_peak(t, total, half)
    t90 = _first(t, mean_z >= NEAR * target)
    if t90 is not None and (t_peak is None or t90 < t_peak):
        found["near_target"] = Phase("near_target", round(t90, 1), f"the mean bag height first "
                                     f"at 90 % of the target ({NEAR * target:g} m), before the "
                                     f"total gas volume peaks ({t_peak:.0f} s)")
    elif t_peak is not None:
        found["near_target"] = Phase("near_target", round(t_peak, 1), "the bags' total gas "
                                     "volume at its peak in the upper half of the ascent")
    else:
        found["near_target"] = Phase("near_target", None, "not reached: the fault-free run "
                                     "never rose half way")
    out = [found[n] for n in names]
    for x in times:
        if not (isinstance(x, int | float) and math.isfinite(x) and 0.0 <= x <= end):
            raise InputError("--phases", f"t{x}", f"a time inside the fault-free run, 0 to "
                             f"{end:.0f} s")
        out.append(Phase(user_phase_name(float(x)), float(x), "named by the user"))
    return out


def _volume_peak(t: np.ndarray, total: np.ndarray, t_mid: float | None) -> float | None:
    """When the total gas volume ``total`` [m3] peaks in the upper half of the ascent (from
    ``t_mid`` on): the last time within :data:`PLATEAU` of its largest value there (a
    controlled ascent holds the volume nearly constant: the peak is where it ends); None when
    the run never rose half way."""
    if t_mid is None:
        return None
    upper = t >= t_mid
    top = total[upper].max()
    return float(t[upper][np.flatnonzero(total[upper] >= top * (1.0 - PLATEAU))[-1]])


def _first(t: np.ndarray, mask: np.ndarray) -> float | None:
    k = np.flatnonzero(mask)
    return float(t[k[0]]) if k.size else None


def parse_phases(words, end_s: float | None = None
                 ) -> tuple[tuple[str, ...], tuple[float, ...]]:
    """Phase names and user times from ``--phases`` words: a name of :data:`PHASES`, or a
    time ``1800`` / ``t1800`` / ``1800s`` [s], at most ``end_s`` (the scenario's run length
    [s], when given). InputError (with the list) for anything else, and for no word."""
    if not words:
        raise InputError("--phases", ",".join(map(str, words)), "name at least one phase: "
                         f"{', '.join(PHASES)} or a time in seconds (e.g. 1800)")
    named, times = [], []
    for w in words:
        w = str(w).strip()
        if w in PHASES:
            if w not in named:
                named.append(w)
            continue
        text = w[1:] if w.startswith("t") else w
        text = text[:-1] if text.endswith("s") else text
        try:
            x = float(text)
        except ValueError:
            raise InputError("--phases", w, f"use {', '.join(PHASES)} or a time in seconds "
                             "(e.g. 1800)") from None
        if not math.isfinite(x) or x < 0 or (end_s is not None and x > end_s):
            upto = f"{end_s:g} s" if end_s is not None else "the end of the run"
            raise InputError("--phases", w, f"a time in seconds from 0 to {upto} (the run's "
                             "length, simulation.duration_s)")
        times.append(x)
    return tuple(named), tuple(dict.fromkeys(times))
