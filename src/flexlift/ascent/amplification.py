"""Dynamic amplification of the sling forces, read from a run (issue 25).

Per bag and phase, the dynamic amplification factor is the peak sling force in the phase over
the bag's force in the closed static design case of the same phase
(:mod:`flexlift.loads.design`):

- the pull phase (up to and including the separation): the holding share plus its pull, i.e.
  the bag's neutral buoyancy plus its share of the breakout pull as the ascent plans it
  (:func:`flexlift.control.build.bag_pulls`, the ``breakout`` case);
- the ascent (after the separation): the holding share, the neutral buoyancy (the
  ``holding`` case).

The separation time is the bag's own separation event where the plant names one (the
paper's plant), else the run's first separation. Forces in N.
"""

from __future__ import annotations

import numpy as np


def static_forces(scenario, plant, mode: str) -> tuple[np.ndarray, np.ndarray]:
    """(holding, pull-phase) static force of each bag [N]: rho g V_neutral, plus the planned
    breakout pull of each external bag for the pull phase."""
    from flexlift.control.build import bag_pulls

    hold = np.asarray(plant.neutral_volume, dtype=float) * plant.bags.rho_g
    pull = hold.copy()
    ext = np.flatnonzero(plant.external)
    if ext.size:
        pull[ext] += bag_pulls(scenario, plant, mode) * plant.bags.rho_g
    return hold, pull


def separation_times(events: list[dict], names) -> np.ndarray:
    """Each bag's separation time [s] (NaN when it never separated)."""
    seps = [e for e in events if e["kind"] == "separation"]
    first = seps[0]["time_s"] if seps else np.nan
    own = {e["bag"]: e["time_s"] for e in reversed(seps) if e["bag"]}
    return np.array([own.get(str(n), first) for n in names], dtype=float)


def phase_peaks(t: np.ndarray, sling: np.ndarray, t_sep: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """(pull-phase, ascent) peak sling force of each bag [N] from the histories ``sling``
    (time, bag) at ``t``: the pull phase up to and including ``t_sep``, the ascent after
    (NaN where a phase has no sample)."""
    nb = sling.shape[1]
    pull, asc = np.full(nb, np.nan), np.full(nb, np.nan)
    for i in range(nb):
        before = t <= t_sep[i] if np.isfinite(t_sep[i]) else np.ones(t.size, bool)
        if before.any():
            pull[i] = float(sling[before, i].max())
        if (~before).any():
            asc[i] = float(sling[~before, i].max())
    return pull, asc


def amplification(ds, events, scenario, plant, mode: str) -> dict:
    """The per-bag arrays (peaks, static forces, DAFs) of a run's dataset ``ds``."""
    hold, pull_static = static_forces(scenario, plant, mode)
    t_sep = separation_times(events, ds.bag.values)
    peak_pull, peak_asc = phase_peaks(ds.time.values, ds.sling_force.values, t_sep)
    with np.errstate(invalid="ignore", divide="ignore"):
        daf_pull = np.where(pull_static > 0, peak_pull / pull_static, np.nan)
        daf_asc = np.where(hold > 0, peak_asc / hold, np.nan)
    return {"static_force_hold": hold, "static_force_pull": pull_static,
            "peak_sling_force_pull": peak_pull, "peak_sling_force_ascent": peak_asc,
            "daf_pull": daf_pull, "daf_ascent": daf_asc}


def largest(values: np.ndarray, names, among: np.ndarray) -> tuple[float | None, str | None]:
    """The largest finite value of ``values`` among the bags flagged ``among`` and its bag."""
    v = np.where(among & np.isfinite(values), values, -np.inf)
    if not np.isfinite(v).any():
        return None, None
    k = int(np.argmax(v))
    return float(v[k]), str(names[k])
