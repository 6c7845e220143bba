"""The answer of one single-failure case, from its run: the outcome, the peaks against their
limits, the breach and the resettling, and the reason in one line.

While the run stays within the model's validity the peaks are the run's own headline numbers
(``flexlift simulate`` gives the same); the sling force is the recorded rows' largest over the
bag's design load (its full true lift). Once the hull's pitch or the structure's slope passes
``limits.slope_validity_deg`` (at ``validity_end_s``) the small-deflection model is outside
its validity: the case is unsafe, and the answer reads nothing of the run after that moment.
Each peak is its largest value up to then, with ``*_beyond`` true (what follows is beyond the
model's validity, not a number); the breach and the resettling are kept if they came before
(else ``None`` with ``*_beyond`` true); the reason names the fault and the limits broken before
it; ``end_s`` is that moment. So the run may stop there (``simulate(stop_beyond=True)``, as
:func:`run_fault_case` runs every case) and the answer is the same.

:func:`run_fault_case` is what a sweep engine runs for a case (any executor: a picklable
function of one :class:`~flexlift.sweep.worker.Task`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from flexlift import constants as C
from flexlift.errors import clean
from flexlift.sweep.worker import Task, run_case

#: the answer's numbers that can be beyond the model's validity
PEAKS = ("up_ms", "down_ms", "pitch_deg", "sling_ratio", "utilisation")
#: the answer's peaks that are the run's headline numbers when the whole run is valid
HEADLINE = {"up_ms": "max_ascent_velocity_ms", "down_ms": "max_descent_velocity_ms",
            "pitch_deg": "max_pitch_deg", "utilisation": "max_utilisation"}
#: the events a reason beyond the model's validity names (besides the fault's own)
LIMIT_EVENTS = {"limit_ascent_velocity": "upward speed over its limit",
                "limit_descent_velocity": "downward speed over its limit",
                "limit_pitch": "pitch over its limit", "surface_breach": "surface breach"}
#: the longest reason kept [characters]
REASON_CHARS = 200


#: the record's key of the case's time traces (:func:`trace`); taken out of the record by the
#: coordinator before the record is written (:func:`take_traces`)
TRACES = "_traces"


def run_fault_case(task: Task) -> tuple[dict, dict]:
    """Run one case (:func:`~flexlift.sweep.worker.run_case`) and add to its control mode's
    result its ``answer`` (:func:`case_answer`); no histories are returned, only the few
    traces the report draws of the worst cases (``record[TRACES]``, {mode: :func:`trace`}),
    which the coordinator takes out of the record (:func:`take_traces`) before writing it."""
    record, datasets = run_case(dataclasses.replace(task, histories=True, stop_beyond=True))
    for mode, res in record["results"].items():
        ds = datasets.get(mode)
        if ds is None:
            res["answer"] = {"outcome": "unsafe", "reason": one_line(res.get("error") or
                                                                      "the case did not run")}
            continue
        scenario = task.base.with_changes(**task.changes)
        res["answer"] = case_answer(res, ds, scenario, mode)
        record.setdefault(TRACES, {})[mode] = trace(ds)
        # the case's scenario file, written as the worker's (parallel) work: the coordinator
        # only saves it as the rerun file
        record["scenario_yaml"] = scenario.to_yaml()
    return record, {}


def warm_plant(scenario, mode: str) -> bool:
    """Build, in the worker that runs this, the plant of ``scenario`` (each case's scenario
    but for its fault) for ``mode`` (:func:`~flexlift.sweep.plants.plant_for` keeps it for the
    worker's cases): sent to every worker as the study starts, while the coordinator runs the
    fault-free run. True when built; a failure only means the first case builds it."""
    from flexlift.sweep.plants import plant_for

    try:
        plant_for(scenario, mode)
    except Exception:  # the case reports whatever is wrong with its scenario
        return False
    return True


def trace(ds) -> dict:
    """What the report draws of a case's run (``ds`` its dataset): ``time`` [s], the bags'
    mean ``height`` [m], the largest bag ``speed`` (absolute) [m/s] and the hull's ``pitch``
    [deg], one value per recorded row."""
    return {"time": np.asarray(ds.time.values, dtype=float),
            "height": ds.height.values.mean(axis=1),
            "speed": np.abs(ds.ascent_velocity.values).max(axis=1),
            "pitch": np.degrees(ds.pitch.values)}


def take_traces(record: dict) -> dict:
    """The traces of a worker's ``record`` ({mode: :func:`trace`}), removed from it (they
    are the report's, never written with the case)."""
    return record.pop(TRACES, None) or {}


def one_line(text: str, limit: int = REASON_CHARS) -> str:
    """``text`` cut to ``limit`` characters at a clause boundary where it can, else at a
    word's."""
    text = clean(str(text), 1000)
    if len(text) <= limit:
        return text
    cut = text[:limit].rfind("; ")
    if cut <= 60:
        cut = text[:limit - 2].rfind(" ")
    return text[:cut if cut > 0 else limit - 2] + " …"


def validity_time(ds, validity_deg: float) -> float | None:
    """The first time [s] the hull's pitch or the structure's slope passes ``validity_deg``."""
    lim = math.radians(validity_deg)
    times = []
    over = np.flatnonzero(np.abs(ds["pitch"].values) > lim)
    if over.size:
        times.append(float(ds.time.values[over[0]]))
    if "slope_largest" in ds:
        over = np.flatnonzero(ds["slope_largest"].values > lim)
        if over.size:
            times.append(float(ds.time_strength.values[over[0]]))
    return min(times) if times else None


def _peaks(ds, scenario, capacity, faults, t_end: float, sep: float | None) -> dict:
    """The peaks up to ``t_end`` [s]: upward speed of an attached bag point, downward speed
    once separated [m/s], pitch [deg], sling force over its design load (the bag's full true
    lift), bending utilisation."""
    t = ds.time.values
    keep = t <= t_end
    v = ds.ascent_velocity.values.copy()
    for f in faults:
        if f["kind"] == "sling_break":  # a detached bag's point no longer counts
            j = list(ds.bag.values).index(f["bag"])
            v[t >= f["time_s"], j] = 0.0
    up = float(max(v[keep].max(initial=0.0), 0.0))
    after = keep & (t >= sep) if sep is not None else np.zeros_like(keep)
    down = float(max((-v[after]).max(initial=0.0), 0.0))
    pitch = float(np.degrees(np.abs(ds["pitch"].values[keep]).max(initial=0.0)))
    rho_g = scenario.environment.seawater_density_kg_m3 * scenario.environment.gravity_m_s2
    sling = ds.sling_force.values[keep].max(axis=0, initial=0.0) / (capacity * rho_g)
    j = int(np.argmax(sling))
    g = scenario.environment.gravity_m_s2
    util = None
    if "bending_moment" in ds:
        from flexlift.ascent.result import section_modulus

        ks = ds.time_strength.values <= t_end
        Z = section_modulus(scenario, ds.x.values)
        M = np.abs(ds.bending_moment.values[ks])
        allow = scenario.hull.allowable_stress_MPa * 1e6
        util = float((M / Z).max(initial=0.0) / allow)
    return {"up_ms": round(up, 4), "down_ms": round(down, 4), "pitch_deg": round(pitch, 4),
            "sling_ratio": round(float(sling[j]), 4), "sling_bag": str(ds.bag.values[j]),
            "sling_peak_t": round(float(sling[j] * capacity[j] * rho_g / (C.TONNE * g)), 1),
            "utilisation": None if util is None else round(util, 4)}


def case_answer(result: dict, ds, scenario, mode: str) -> dict:
    """The answer of a case's run (``result`` the worker's digest, ``ds`` its dataset)."""
    from flexlift.sweep.plants import plant_for

    capacity = np.asarray(plant_for(scenario, mode).bags.capacity, dtype=float)
    events = result.get("events", [])
    faults = [f.model_dump() for f in scenario.faults]

    def first(kind):
        return next((e["time_s"] for e in events if e["kind"] == kind), None)

    sep = first("separation")
    end = float(ds.time.values[-1])
    t_v = validity_time(ds, scenario.limits.slope_validity_deg)
    if t_v is not None:  # nothing of the run after t_v is read (the run may stop there)
        return _beyond_answer(events, ds, scenario, capacity, faults, t_v, sep)
    out = _peaks(ds, scenario, capacity, faults, end, sep)
    h = result.get("headline", {})  # the whole run is valid: its own maxima, at every step
    for k, name in HEADLINE.items():
        if h.get(name) is not None:
            out[k] = h[name]
    outcome = result.get("outcome") or "failed"
    reason = one_line(result.get("cause") or result.get("error") or "")
    if outcome == "failed":
        outcome = "unsafe"
    breach = first("surface_breach")
    out.update(outcome=outcome, reason=reason, validity_end_s=None, breach_s=breach,
               breach_beyond=False, resettle_s=first("resettle"), resettle_beyond=False,
               sling_design_t=_design_t(ds, scenario, capacity, out), end_s=end)
    return out


def _design_t(ds, scenario, capacity, peaks) -> float:
    """The design load [t] of the bag whose sling came nearest its own."""
    i = list(ds.bag.values).index(peaks["sling_bag"])
    return round(float(capacity[i] * scenario.environment.seawater_density_kg_m3 / C.TONNE), 1)


def _beyond_answer(events, ds, scenario, capacity, faults, t_v: float, sep) -> dict:
    """The answer of a run whose pitch or slope passed its validity at ``t_v`` [s], from the
    run up to ``t_v`` only."""
    out = _peaks(ds, scenario, capacity, faults, t_v, sep)
    for k in PEAKS:
        out[f"{k}_beyond"] = True

    def before(kind):
        return next((e["time_s"] for e in events if e["kind"] == kind and e["time_s"] <= t_v),
                    None)

    kinds = {f["kind"] for f in faults}
    said = [f"{LIMIT_EVENTS.get(e['kind'], e['kind'].replace('_', ' '))}"
            + (f" of {e['bag']}" if e.get("bag") else "")
            + (f" ({e['detail']})" if e.get("detail") and e["kind"] in LIMIT_EVENTS else "")
            + f" at {e['time_s']:.0f} s"
            for e in events if e["time_s"] <= t_v and (e["kind"] in LIMIT_EVENTS
                                                      or e["kind"] in kinds)]
    lead = one_line("; ".join(said), REASON_CHARS - 70) if said else "unsafe"
    breach, resettle = before("surface_breach"), before("resettle")
    out.update(outcome="unsafe",
               reason=(f"{lead}; the slope passed {scenario.limits.slope_validity_deg:g} deg at "
                       f"{t_v:.0f} s: beyond the model's validity from then on"),
               validity_end_s=t_v, breach_s=breach, breach_beyond=breach is None,
               resettle_s=resettle, resettle_beyond=resettle is None,
               sling_design_t=_design_t(ds, scenario, capacity, out), end_s=t_v)
    return out
