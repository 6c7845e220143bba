"""Faults of the scenario, applied to the running ascent at their times.

Each fault changes the :class:`~flexlift.ascent.state.Switches` (and, for a lost bag, its
controller), for any plant:

- ``bag_rupture``: the bag's gas escapes with time constant ``leak_time_s``;
- ``sling_break``: the bag no longer acts on the structure; its controller stops;
- ``supply_failure``: the bag can no longer be filled;
- ``sensor_drift``: its height reading drifts at ``rate_m_s``;
- ``sensor_stuck``: its readings hold their last values from then on;
- ``sensor_dropout``: they hold them for ``duration_s``;
- ``dump_valve_stuck_closed``: the bag's purge opening is held at 0 from then on;
- ``fill_valve_stuck_open``: the bag fills at the full rate (``gas.fill_rate_max_m3_s``)
  whatever its command, until its true capacity; the excess then spills or is relieved;
- ``fill_valve_stuck_closed``: the bag is filled no more whatever its command (its purge
  still works). Within the model a shut fill valve and a lost supply line cut the same
  flow, so both clear the one switch ``supply`` (at their step, not the next sample).

The stuck-open fill and stuck-closed dump valves act at the next control sample (:func:`flexlift.ascent.kernel.stuck_valves`).
"""

from __future__ import annotations

import math

import numpy as np

from flexlift.errors import InputError


def check_faults(scenario, names) -> None:
    """InputError for a fault that names an unknown bag."""
    for k, f in enumerate(scenario.faults):
        if f.bag not in names:
            shown = (", ".join(names) if len(names) <= 10 else
                     f"{', '.join(names[:4])}, ..., {', '.join(names[-2:])} ({len(names)} bags)")
            raise InputError(f"faults[{k}].bag", f.bag, f"known bags are {shown}")


def fault_step(fault, dt: float) -> int:
    """The step at whose start ``fault`` takes effect (the first at or after its time)."""
    return int(math.ceil(fault.time_s / dt - 1e-9))


def apply_fault(fault, t: float, names, switches, control_bags, control_state) -> str:
    """Apply ``fault`` at time ``t`` [s]; returns a detail for its event ("" if none)."""
    i = names.index(fault.bag)
    sw = switches
    controlled = np.flatnonzero(control_bags == i)
    if fault.kind == "bag_rupture":
        sw.leak[i] = 1.0 / fault.leak_time_s
    elif fault.kind == "sling_break":
        sw.attached[i] = 0.0
        if controlled.size:
            control_state.active[controlled[0]] = False
    elif fault.kind in ("supply_failure", "fill_valve_stuck_closed"):
        sw.supply[i] = 0.0
    elif fault.kind == "sensor_drift":
        sw.drift[i], sw.drift_t0[i] = fault.rate_m_s, t
    elif fault.kind == "dump_valve_stuck_closed":
        sw.dump_stuck[i] = True
    elif fault.kind == "fill_valve_stuck_open":
        sw.fill_stuck[i] = True
    elif fault.kind == "sensor_stuck":
        sw.frozen[i], sw.frozen_until[i] = True, math.inf
    elif fault.kind == "sensor_dropout":
        sw.frozen[i], sw.frozen_until[i] = True, t + fault.duration_s
    if fault.kind.startswith("sensor") and not controlled.size:
        return "no controller on this bag: no effect"
    return ""
