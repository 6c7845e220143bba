"""The result of an ascent: an xarray Dataset with units, events, criteria and headline numbers.

Dimensions: ``time`` (every ``simulation.output_interval_s``), ``bag``, ``x`` (along the hull)
and ``time_strength`` (every ``simulation.strength_interval_s``, for shear and moment). Every
variable carries ``units`` and ``long_name``; the events, the criteria and the headline
numbers are JSON strings in the dataset's attributes, so a saved file is complete.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from flexlift import constants as C
from flexlift.ascent.amplification import amplification, largest
from flexlift.ascent.outcome import judge
from flexlift.ascent.records import BAG_OPEN_PARACHUTE, BAG_PAPER
from flexlift.ascent.state import (
    EV_ARRIVAL,
    EV_BREAKOUT,
    EV_LIFTOFF,
    EV_LIMIT_DESCENT,
    EV_LIMIT_PITCH,
    EV_LIMIT_VELOCITY,
    EV_NUMERICS,
    EV_RESETTLE,
    EV_SEPARATION,
    EV_SURFACE_BREACH,
    EV_TARGET_HELD,
)

if TYPE_CHECKING:  # xarray is imported where a Dataset is built: a sweep's worker that
    import xarray as xr  # records summaries never loads it (nor pandas)

#: the bag variables of a recorded row, in the order the compiled loop writes them
BAG_VARS = {
    "height": ("m", "height of the bag's point above the seabed"),
    "ascent_velocity": ("m/s", "vertical velocity of the bag's point"),
    "pitch_angle": ("rad", "local slope of the hull at the bag's point, bow-up positive"),
    "pitch_rate": ("rad/s", "rate of the local slope at the bag's point"),
    "net_flow": ("m3/s", "fill minus purge flow at local pressure"),
    "gas_volume": ("m3", "gas volume in the bag"),
    "sling_force": ("N", "force of the bag's sling on the hull: its buoyancy plus its drag, "
                    "0 once detached"),
    "fill_rate": ("m3/s", "fill flow at local pressure"),
    "purge_opening": ("1", "purge valve opening"),
    "supervisor_output": ("1", "supervisory fuzzy controller output u"),
    "desired_volume": ("m3", "desired gas volume V_d"),
    "reference_height": ("m", "reference trajectory z_ref of the bag's point"),
}
#: the hull variables of a recorded row, in order
HULL_VARS = {
    "heave": ("m", "rigid heave of the hull's centre of mass above the seabed"),
    "pitch": ("rad", "rigid pitch angle of the hull, bow-up positive"),
    "holding_force": ("N", "suction holding force H"),
    "uplift": ("N", "net uplift U = sum of bag lift - wet weight"),
    "contact_force": ("N", "seabed contact force"),
}
#: the per-bag dynamic amplification variables (:mod:`flexlift.ascent.amplification`)
DAF_VARS = {
    "static_force_hold": "static force in the holding case: neutral buoyancy",
    "static_force_pull": "static force in the pull phase: neutral buoyancy plus planned pull",
    "peak_sling_force_pull": "peak sling force up to the separation",
    "peak_sling_force_ascent": "peak sling force after the separation",
    "daf_pull": "dynamic amplification before the separation: peak over static pull-phase force",
    "daf_ascent": "dynamic amplification after the separation: peak over neutral buoyancy",
}
CRITERIA = ("ascent_velocity", "descent_velocity", "pitch", "reached_target", "no_surface_breach",
            "no_resettle", "bending_utilisation")
EVENT_KINDS = {EV_LIMIT_DESCENT: "limit_descent_velocity", EV_SEPARATION: "separation", EV_BREAKOUT: "breakout", EV_ARRIVAL: "arrival",
               EV_TARGET_HELD: "target_held", EV_SURFACE_BREACH: "surface_breach",
               EV_LIMIT_VELOCITY: "limit_ascent_velocity", EV_LIMIT_PITCH: "limit_pitch",
               EV_LIFTOFF: "liftoff", EV_RESETTLE: "resettle", EV_NUMERICS: "numerics_failed"}


@dataclass(frozen=True)
class Result:
    """One simulated ascent. ``dataset`` holds everything (a :class:`Frame` of the same
    arrays when the run recorded a summary only); the properties read its attrs."""

    dataset: xr.Dataset | Frame

    @property
    def events(self) -> list[dict]:
        return json.loads(self.dataset.attrs["events"])

    @property
    def criteria(self) -> dict[str, bool]:
        return {k: bool(v) for k, v in json.loads(self.dataset.attrs["criteria"]).items()}

    @property
    def headline(self) -> dict:
        return json.loads(self.dataset.attrs["headline"])

    @property
    def control(self) -> str:
        return self.dataset.attrs["control"]

    @property
    def reasons(self) -> dict[str, str]:
        """Each failed criterion's cause, with times and numbers (:func:`explain`)."""
        return json.loads(self.dataset.attrs.get("reasons", "{}"))

    @property
    def warnings(self) -> list[str]:
        """What the run's engineer should know though no criterion failed (e.g. slopes beyond
        the small-deflection beam's validity), one sentence each, with where and when."""
        return json.loads(self.dataset.attrs.get("warnings", "[]"))

    @property
    def outcome(self) -> dict:
        """What happened (:mod:`flexlift.ascent.outcome`): ``kind`` (safe, unsafe,
        not_achieved or incomplete), ``cause`` (one sentence) and ``needs_s`` (incomplete:
        about how much longer the run must go on [s])."""
        return json.loads(self.dataset.attrs.get("outcome", "{}"))

    @property
    def error(self) -> str:
        return self.dataset.attrs.get("error", "")

    def event_time(self, kind: str, bag: str | None = None) -> float | None:
        for e in self.events:
            if e["kind"] == kind and (bag is None or e["bag"] == bag):
                return e["time_s"]
        return None

    def summary(self) -> dict:
        """The JSON summary of ``flexlift simulate --json``."""
        h, ds = self.headline, self.dataset
        arr = {str(b): (None if np.isnan(v) else round(float(v), 1))
               for b, v in zip(ds.bag.values, ds.arrival_time.values)}
        keys = ("breakout_time_s", "separation_time_s", "arrival_spread_s",
                "max_ascent_velocity_ms", "max_descent_velocity_ms", "max_pitch_deg",
                "max_bending_moment_MNm", "max_shear_force_MN", "max_stress_MPa",
                "max_utilisation", "max_slope_deg", "max_slope_x_m", "max_slope_time_s",
                "gas_used_local_m3", "gas_used_free_air_m3",
                "gas_initial_free_air_m3", "gas_total_free_air_m3", "gas_vented_free_air_m3",
                "gas_purged_free_air_m3", "supply_bag_hours", "daf_pull", "daf_pull_bag",
                "daf_ascent", "daf_ascent_bag", "end_time_s")
        out = {"control": self.control, "breakout_law": ds.attrs.get("breakout_law", "timer"),
               "outcome": self.outcome.get("kind"),
               "outcome_cause": self.outcome.get("cause"),
               "needs_more_s": self.outcome.get("needs_s"),
               **{k: h[k] for k in keys}, "arrival_time_s": arr,
               "final_height_m": {str(b): round(float(v), 2)
                                  for b, v in zip(ds.bag.values, ds.height.values[-1])},
               "criteria": self.criteria, "reasons": self.reasons, "warnings": self.warnings,
               "events": [{"time_s": e["time_s"], "kind": e["kind"], "bag": e["bag"]}
                          for e in self.events],
               "error": self.error or None}
        return out


def _r(v, nd=3):
    return None if v is None or not np.isfinite(v) else round(float(v), nd)


def _breach_detail(kind: int) -> str:
    """What a bag of ``kind`` (:data:`flexlift.ascent.records.BAG_KINDS`) does at the surface."""
    return {BAG_PAPER: "the run ends at the surface",
            BAG_OPEN_PARACHUTE: "it broaches: only its gas below the waterline lifts; past its "
                                "tip freeboard it tips and spills; the run goes on",
            }.get(kind, "it floats on its gas below the waterline; the run goes on")


def ended_at_surface(run, events: list[dict]) -> bool:
    """Whether the run ended at a surface breach (one of the paper's bags: no surface law)."""
    kind = dict(zip(run.plant.names, run.plant.bags.kind))
    return any(e["kind"] == "surface_breach" and kind.get(e["bag"]) == BAG_PAPER
               for e in events)


def event_list(run) -> list[dict]:
    """The run's events (compiled loop and faults) in time order, with names and details."""
    rec, P, X = run.recorder, run.plant, run.settings
    g_t = P.gravity * C.TONNE
    out = []
    for k in range(int(rec.counts[2])):
        code, i, val = int(rec.ev_code[k]), int(rec.ev_index[k]), float(rec.ev_value[k])
        kind = EVENT_KINDS[code]
        bag = (P.names[i] if code in (EV_ARRIVAL, EV_SURFACE_BREACH, EV_LIMIT_VELOCITY,
                                      EV_LIMIT_DESCENT) else None)
        detail = {EV_SURFACE_BREACH: _breach_detail(int(P.bags.kind[i])) if i >= 0 else "",
                  EV_LIMIT_VELOCITY: f"{val:.2f} m/s upward",
                  EV_LIMIT_DESCENT: f"{val:.2f} m/s downward",
                  EV_LIMIT_PITCH: f"{np.degrees(val):.1f} deg",
                  EV_LIFTOFF: "the whole hull is clear of the seabed",
                  EV_RESETTLE: "the hull touched the seabed again",
                  EV_BREAKOUT: "holding force below 0.1 % of H0",
                  EV_TARGET_HELD: f"held {X.hold_time:.0f} s"}.get(code, "")
        if code == EV_SEPARATION:
            if P.kind == "paper":
                bag, detail = P.names[i], "this bag's share of the hull lifts off"
            else:
                detail = f"uplift {val / g_t:.0f} t"
        out.append({"time_s": round(float(rec.ev_t[k]), 3), "kind": kind, "bag": bag,
                    "detail": detail})
    out += [{"time_s": round(t, 3), "kind": kind, "bag": bag, "detail": detail}
            for t, kind, bag, detail in run.fault_events]
    return sorted(out, key=lambda e: e["time_s"])


def snapshots(run, own=np.copy) -> dict:
    """The strength snapshots of a run, stacked over time, by name (``own`` of each: copies,
    or ``np.asarray`` for views of the run's record)."""
    rec = run.recorder
    n = int(rec.counts[1])
    return {name: own(getattr(rec, f"snap_{name}")[:n])
            for name in ("t", "q", "v", "a", "H", "sep", "V", "attached", "current", "noise")}


def build_result(run, error: str | None, summary_only: bool = False) -> Result:
    """The Dataset of a finished (or failed) run (``summary_only``: the same arrays and
    attributes in a :class:`Frame`, no Dataset; its time series are views of the run's record,
    not copies: a summary reads a few of them once, and the record is the run's own)."""
    from flexlift.physics.gas import buoyancy

    P, rec, R = run.plant, run.recorder, run.state
    own = np.asarray if summary_only else np.copy
    nrow = int(rec.counts[0])
    t = own(rec.t[:nrow])
    coords = {"time": ("time", t, {"units": "s", "long_name": "time since filling began"}),
              "bag": ("bag", list(P.names))}
    data = {}
    for j, (name, (unit, long)) in enumerate(BAG_VARS.items()):
        data[name] = (("time", "bag"), own(rec.bag[:nrow, j, :]), {"units": unit, "long_name": long})
    data["buoyancy"] = (("time", "bag"), buoyancy(rec.bag[:nrow, 5, :], P.bags.rho_g),
                        {"units": "N", "long_name": "buoyancy of the bag's gas, rho g V"})
    for j, (name, (unit, long)) in enumerate(HULL_VARS.items()):
        data[name] = (("time",), own(rec.hull[:nrow, j]), {"units": unit, "long_name": long})
    per_bag = {"bag_x": (P.x_point, "m", "bag point from the aft end"),
               "arrival_time": (R.arrival, "s", "first time within tolerance of the target"),
               "gas_vented": (R.vented, "m3", "gas spilled, vented or leaked, at local pressure"),
               "gas_purged": (R.purged, "m3", "gas purged, at local pressure"),
               "gas_used_local": (R.gas_local, "m3", "gas filled, at local pressure"),
               "gas_used_free_air": (R.gas_free, "m3", "gas filled, as free air at the surface"),
               "gas_vented_free_air": (R.vented_free, "m3", "gas vented, as free air"),
               "gas_purged_free_air": (R.purged_free, "m3", "gas purged, as free air"),
               "gas_initial_local": (P.neutral_volume, "m3", "gas at the start, at local pressure"),
               "gas_initial_free_air": (_initial_free_air(P), "m3", "gas at the start, as free air")}
    for name, (vals, unit, long) in per_bag.items():
        data[name] = (("bag",), np.array(vals, dtype=float), {"units": unit, "long_name": long})
    data["bag_kind"] = (("bag",), np.array(["external" if e else "internal" for e in P.external]),
                        {"units": "1", "long_name": "external parachute or internal cylindrical"})
    Mmax = Vmax = None
    snaps = snapshots(run, own)
    if snaps["t"].size and P.kind == "coupled":
        Mmax, Vmax = _strength_vars(run, snaps, coords, data)
    events = event_list(run)
    # what the amplification reads (the sling forces over time, the bags' names) as plain
    # arrays: the values a Dataset of them would hold, without building one
    daf = amplification(_Arrays(bag=np.array(coords["bag"][1]), time=t,
                                sling_force=data["sling_force"][1]),
                        events, run.scenario, P, run.mode)
    for name, long in DAF_VARS.items():
        data[name] = (("bag",), daf[name], {"units": "1" if name.startswith("daf") else "N",
                                             "long_name": long})
    if summary_only:
        ds = Frame(data, coords)
    else:
        import xarray as xr

        ds = xr.Dataset(data, coords=coords)
    _attributes(ds, run, events, t, Mmax, Vmax, error)
    return Result(ds)


def _strength_vars(run, snaps, coords, data) -> tuple[float, float]:
    """The strength samples ``snaps`` of a coupled run into ``coords`` and ``data``: the shear
    and moment distributions and their envelopes, the stress and utilisation envelopes, the
    grounded part and the slopes. Returns the largest |M| [N m] and |V| [N]."""
    from flexlift.ascent.strength import seabed_profile, strength

    P = run.plant
    xg, Vs, Ms = strength(P, snaps)
    coords["x"] = ("x", xg, {"units": "m", "long_name": "position from the aft end"})
    coords["time_strength"] = ("time_strength", snaps["t"],
                               {"units": "s", "long_name": "time of the strength samples"})
    data["shear_force"] = (("time_strength", "x"), Vs, {"units": "N", "long_name": "shear force, upward forces aft of x"})
    data["bending_moment"] = (("time_strength", "x"), Ms, {"units": "N m", "long_name": "bending moment, sagging positive"})
    for name, arr, how in (("moment_max", Ms.max(0), "largest bending moment"),
                           ("moment_min", Ms.min(0), "smallest bending moment"),
                           ("shear_max", Vs.max(0), "largest shear force"),
                           ("shear_min", Vs.min(0), "smallest shear force")):
        data[name] = (("x",), arr, {"units": "N m" if "moment" in name else "N",
                                    "long_name": f"envelope: {how}"})
    Z = section_modulus(run.scenario, xg)
    allow = run.scenario.hull.allowable_stress_MPa * 1e6
    stress = np.abs(Ms).max(0) / Z
    data["stress_max"] = (("x",), stress, {"units": "Pa", "long_name": "envelope: largest hull girder bending stress |M| / Z"})
    data["utilisation_max"] = (("x",), stress / allow, {"units": "1", "long_name": "envelope: stress over the allowable stress"})
    bed = seabed_profile(P, snaps)
    for name, long in (("grounded_from", "aft-most point on the seabed (a touchdown point)"),
                       ("grounded_to", "forward-most point on the seabed (a touchdown point)"),
                       ("grounded_length", "length of the structure on the seabed")):
        data[name] = (("time_strength",), bed[name], {"units": "m", "long_name": long})
    data["slope_max"] = (("x",), np.abs(bed["slope"]).max(0), {
        "units": "rad", "long_name": "envelope: largest slope of the structure (retained modes)"})
    data["slope_largest"] = (("time_strength",), np.abs(bed["slope"]).max(1), {
        "units": "rad", "long_name": "largest slope along the structure"})
    return float(np.abs(Ms).max()), float(np.abs(Vs).max())


class _Arrays:
    """Named arrays read as a Dataset's variables are (``obj.name.values``)."""

    def __init__(self, **arrays):
        for name, values in arrays.items():
            setattr(self, name, _Values(values))


class _Values:
    __slots__ = ("values",)

    def __init__(self, values):
        self.values = values

    def max(self):
        """The largest value, NaN skipped as xarray's ``max`` does (NaN when all are)."""
        v = np.asarray(self.values)
        v = v[~np.isnan(v)] if v.dtype.kind == "f" else v
        return v.max() if v.size else np.nan


class Frame:
    """A result's arrays without an xarray Dataset (``simulate(..., summary_only=True)``, a
    sweep's ``keep: summary``): the same variables, coordinates and attributes, read as a
    Dataset's are (``frame.height.values``, ``frame["x"].values``, ``"x" in frame``,
    ``frame.attrs``), each variable's (dimensions, values, attributes) in ``variables``.
    What a summary reads is the same numbers either way; a Dataset costs a few
    milliseconds to build, a sizeable part of a sweep's short case."""

    def __init__(self, data: dict, coords: dict):
        self.variables = {**coords, **data}
        self.attrs: dict = {}

    def __contains__(self, name) -> bool:
        return name in self.variables

    def __getitem__(self, name):
        item = self.variables[name]
        return _Values(np.asarray(item[1]))

    def __getattr__(self, name):
        if name.startswith("_") or name not in self.__dict__.get("variables", {}):
            raise AttributeError(name)
        return self[name]


def section_modulus(scenario, x) -> np.ndarray:
    """The hull girder section modulus Z [m^3] at ``x`` [m] (one value or one per element of
    the scenario's hull)."""
    Z = np.broadcast_to(np.asarray(scenario.hull.section_modulus_m3, dtype=float),
                        (scenario.hull.elements,))
    e = np.clip((np.asarray(x) / scenario.hull.length_m * Z.size).astype(int), 0, Z.size - 1)
    return Z[e]


def _initial_free_air(P) -> np.ndarray:
    """Each bag's gas at the start as free air at the surface [m^3] (n R T / p_atm)."""
    return P.initial_moles() * P.bags.RT / P.bags.p_atm


def gas_budget(run) -> dict:
    """The whole gas budget [m^3] and the supply time (headline keys): the initial fill, the
    top-up during the run, the vented and purged gas, as free air and at local pressure."""
    R, P, sc = run.state, run.plant, run.scenario
    init_free, init_local = _initial_free_air(P), P.neutral_volume
    q_in = sc.gas.fill_rate_max_m3_s
    local = init_local + R.gas_local  # filled at local pressure, per bag
    return {
        "gas_initial_free_air_m3": _r(init_free.sum(), 1),
        "gas_initial_local_m3": _r(init_local.sum(), 1),
        "gas_topup_free_air_m3": _r(R.gas_free.sum(), 1),
        "gas_topup_local_m3": _r(R.gas_local.sum(), 1),
        "gas_total_free_air_m3": _r(init_free.sum() + R.gas_free.sum(), 1),
        "gas_vented_free_air_m3": _r(R.vented_free.sum(), 1),
        "gas_purged_free_air_m3": _r(R.purged_free.sum(), 1),
        "supply_bag_hours": _r(local.sum() / q_in / 3600.0, 2),
        "supply_hours_parallel": _r(local.max() / q_in / 3600.0, 2),
    }


def _attributes(ds, run, events, t, Mmax, Vmax, error) -> None:
    sc, R, P = run.scenario, run.state, run.plant
    vmax, pmax, vdown = float(R.scalars[0]), float(R.scalars[1]), float(R.scalars[4])
    kinds = {e["kind"] for e in events}
    crit = {"ascent_velocity": vmax < sc.limits.ascent_velocity_m_s,
            "descent_velocity": vdown < sc.limits.descent_velocity_m_s,
            "pitch": sc.limits.pitch_deg is None or float(np.degrees(pmax)) < sc.limits.pitch_deg,
            "reached_target": "target_held" in kinds,
            "no_surface_breach": "surface_breach" not in kinds,
            "no_resettle": "resettle" not in kinds,
            # the dynamic hull girder stress over the ascent within the allowable (docs/theory/strength.md#dynamic-strength)
            "bending_utilisation": not ("utilisation_max" in ds
                                        and float(ds["utilisation_max"].max()) > 1.0)}

    def first(kind):
        return next((e["time_s"] for e in events if e["kind"] == kind), None)

    arr = R.arrival[P.external] if P.external.any() else R.arrival
    spread = float(np.nanmax(arr) - np.nanmin(arr)) if np.all(np.isfinite(arr)) else None
    headline = {
        "separation_time_s": _r(first("separation"), 1),
        "breakout_time_s": _r(first("breakout"), 1),
        "arrival_spread_s": _r(spread, 1),
        "max_ascent_velocity_ms": _r(vmax, 4),
        "max_descent_velocity_ms": _r(vdown, 4),
        "max_pitch_deg": _r(np.degrees(pmax), 4),
        "max_bending_moment_MNm": _r(Mmax / 1e6, 3) if Mmax is not None else None,
        "max_shear_force_MN": _r(Vmax / 1e6, 4) if Vmax is not None else None,
        "gas_used_local_m3": _r(R.gas_local.sum(), 1),
        "gas_used_free_air_m3": _r(R.gas_free.sum(), 1),
        **gas_budget(run),
        "max_stress_MPa": _r(float(ds["stress_max"].max()) / 1e6, 2) if "stress_max" in ds else None,
        "max_utilisation": _r(float(ds["utilisation_max"].max()), 3) if "utilisation_max" in ds else None,
        **steepest(ds),
        **daf_headline(ds),
        "end_time_s": _r(float(t[-1]) if t.size else 0.0, 1),
    }
    reasons = explain(run, events, crit, vmax, vdown, pmax, error)
    if not crit["bending_utilisation"]:
        reasons["bending_utilisation"] = utilisation_reason(ds, sc)
    outcome = judge(run, ds, events, crit, reasons, error)
    if outcome.kind in ("incomplete", "not_achieved"):
        reasons["reached_target"] = outcome.cause
    warnings = slope_warnings(ds, sc.limits.slope_validity_deg)
    if sc.limits.pitch_deg is None:  # the tilt criterion does not apply: the design basis
        del crit["pitch"]             # and the particulars say so (not a warning of every run)
    ds.attrs.update(warnings=json.dumps(warnings),title=f"flexlift ascent of {sc.name}, {run.mode} control", scenario=sc.name,
                    scenario_checksum=sc.checksum(), control=run.mode, events=json.dumps(events),
                    criteria=json.dumps(crit), reasons=json.dumps(reasons),
                    outcome=json.dumps(outcome.as_dict()), headline=json.dumps(headline), error=error or "",
                    max_ascent_velocity_m_s=vmax, max_pitch_rad=pmax,
                    breakout_law=sc.seabed.breakout_law)


def utilisation_reason(ds, sc) -> str:
    """Why the bending utilisation failed: the largest stress, where and when, against the
    allowable stress and the section modulus there."""
    x = ds["x"].values
    Z = section_modulus(sc, x)
    u = np.abs(ds["bending_moment"].values) / Z[None, :] / (sc.hull.allowable_stress_MPa * 1e6)
    k, j = np.unravel_index(int(np.argmax(u)), u.shape)
    M = float(ds["bending_moment"].values[k, j])
    return (f"the hull girder bending stress reached {abs(M) / Z[j] / 1e6:.0f} MPa at "
            f"x = {x[j]:.1f} m at {float(ds['time_strength'].values[k]):.0f} s (M = "
            f"{M / 1e6:.1f} MN m, Z = {Z[j]:.3g} m3): utilisation {float(u[k, j]):.2f} against "
            f"the allowable {sc.hull.allowable_stress_MPa:g} MPa (hull.allowable_stress_MPa); "
            "a stronger section, or lift points closer to where the weight is")


def daf_headline(ds) -> dict:
    """Headline keys of the sling forces' dynamic amplification: the largest of each phase
    among the external bags (all bags when none is) and which bag."""
    names = ds.bag.values
    ext = ds["bag_kind"].values == "external"
    among = ext if ext.any() else np.ones(names.size, bool)
    out = {}
    for phase in ("pull", "ascent"):
        v, b = largest(ds[f"daf_{phase}"].values, names, among)
        out[f"daf_{phase}"], out[f"daf_{phase}_bag"] = _r(v, 3), b
    return out


def steepest(ds) -> dict:
    """Headline keys of the largest slope along the structure: degrees, where [m], when [s]
    (None without the strength samples)."""
    if "slope_largest" not in ds:
        return {"max_slope_deg": None, "max_slope_x_m": None, "max_slope_time_s": None}
    k = int(np.argmax(ds["slope_largest"].values))
    j = int(np.argmax(ds["slope_max"].values))
    return {"max_slope_deg": _r(np.degrees(float(ds["slope_largest"].values[k])), 3),
            "max_slope_x_m": _r(float(ds["x"].values[j]), 1),
            "max_slope_time_s": _r(float(ds["time_strength"].values[k]), 1)}


def slope_warnings(ds, validity_deg: float) -> list[str]:
    """A warning when the structure gets steeper than ``validity_deg`` (the small-deflection
    beam's validity, ``limits.slope_validity_deg``): where, from when to when, and how steep."""
    if "slope_largest" not in ds:
        return []
    deg = np.degrees(ds["slope_largest"].values)
    over = deg > validity_deg
    if not over.any():
        return []
    t = ds["time_strength"].values
    h = steepest(ds)
    return [f"the structure's slope passed {validity_deg:g} deg from {t[over][0]:.0f} s to "
            f"{t[over][-1]:.0f} s (largest {h['max_slope_deg']:.1f} deg at x = "
            f"{h['max_slope_x_m']:.0f} m, {h['max_slope_time_s']:.0f} s): beyond the "
            "small-deflection beam's validity; heights, moments and stresses there are "
            "approximate (a gentler plan: a slower ascent, a shorter stage delay, more lift "
            "points)"]


def _fault_before(events, time: float | None) -> str:
    """The last fault event at or before ``time``, as "a sling_break of bag_2 at 1980 s; "."""
    faults = [e for e in events if e["kind"] not in EVENT_KINDS.values()
              and (time is None or e["time_s"] <= time + 1e-9)]
    if not faults:
        return ""
    f = faults[-1]
    what = f["kind"].replace("_", " ")
    return f"{what} of {f['bag']} at {f['time_s']:.0f} s; " if f["bag"] else f"{what} at {f['time_s']:.0f} s; "


def explain(run, events, crit, vmax: float, vdown: float, pmax: float, error) -> dict[str, str]:
    """Each failed criterion's cause in one sentence: what happened, to which bag, when, the
    value against its limit, and the fault that set it off (if any)."""
    from flexlift.ascent.checks import breakout_check

    sc, lim = run.scenario, run.scenario.limits

    def first(kind):
        return next((e for e in events if e["kind"] == kind), None)

    out = {}
    if not crit["ascent_velocity"]:
        e = first("limit_ascent_velocity")
        out["ascent_velocity"] = (
            f"{_fault_before(events, e and e['time_s'])}{e['bag'] if e else 'a bag'} rose faster "
            f"than {lim.ascent_velocity_m_s:g} m/s from {e['time_s']:.0f} s" if e else
            f"the ascent reached {vmax:.2f} m/s") + f" (largest upward speed {vmax:.2f} m/s)"
    if not crit["descent_velocity"]:
        e = first("limit_descent_velocity")
        settle = first("resettle")
        text = (f"{_fault_before(events, e and e['time_s'])}the hull sank at up to {vdown:.2f} m/s "
                f"(limit {lim.descent_velocity_m_s:g} m/s)")
        if e:
            text += f", {e['bag']} first over the limit at {e['time_s']:.0f} s"
        if settle:
            text += f", and resettled on the seabed at {settle['time_s']:.0f} s"
        out["descent_velocity"] = text
    if not crit["pitch"]:  # explained before the inapplicable criterion is dropped
        e = first("limit_pitch")
        out["pitch"] = (f"{_fault_before(events, e and e['time_s'])}the pitch passed "
                        f"{lim.pitch_deg:g} deg" + (f" at {e['time_s']:.0f} s" if e else "")
                        + f" (largest {np.degrees(pmax):.1f} deg)")
    if not crit["no_surface_breach"]:
        e = first("surface_breach")
        out["no_surface_breach"] = (f"{_fault_before(events, e['time_s'])}{e['bag']} reached the "
                                    f"surface at {e['time_s']:.0f} s; " + (
                                        "the run ends there" if ended_at_surface(run, events) else
                                        "the run went on (its surface law)"))
    if not crit["no_resettle"]:
        e = first("resettle")
        out["no_resettle"] = (f"{_fault_before(events, e['time_s'])}the hull touched the seabed "
                              f"again at {e['time_s']:.0f} s")
    if not crit["reached_target"]:
        end = float(run.recorder.t[max(int(run.recorder.counts[0]) - 1, 0)])
        if error:
            out["reached_target"] = f"the run stopped at {end:.0f} s: {error}"
        elif ended_at_surface(run, events):
            out["reached_target"] = "the run ended at the surface breach"
        elif first("surface_breach") and first("resettle"):
            out["reached_target"] = (f"a bag broke the surface at {first('surface_breach')['time_s']:.0f}"
                                     f" s and the hull fell back: the run ended when it resettled"
                                     f" at {first('resettle')['time_s']:.0f} s")
        elif first("separation") is None:
            out["reached_target"] = ("never separated in the "
                                     f"{end:,.0f} s run: {breakout_check(sc, run.plant).message}")
        else:  # (a run that kept every limit has its outcome's cause here instead)
            att = np.asarray(run.switches.attached) > 0
            n, N = int(np.count_nonzero(np.isfinite(run.state.arrival) & att)), int(att.sum())
            tol = f"±{lim.arrival_tolerance_m:g} m of the target"
            out["reached_target"] = (
                f"separated at {first('separation')['time_s']:.0f} s; "
                + (f"every bag arrived within {tol}, but they did not hold there for "
                   f"{run.settings.hold_time:.0f} s" if n == N and N else
                   f"{n} of the {N} bags arrived within {tol}, the others did not" if n else
                   f"no bag arrived within {tol}")
                + f" by the end of the {end:,.0f} s run")
    return out
