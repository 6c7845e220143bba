"""The result of an ascent: an xarray Dataset with units, events, criteria and headline numbers.

Dimensions: ``time`` (every ``simulation.output_interval_s``), ``bag``, ``x`` (along the hull)
and ``time_strength`` (every ``simulation.strength_interval_s``, for shear and moment). Every
variable carries ``units`` and ``long_name``; the events, the criteria and the headline
numbers are JSON strings in the dataset's attributes, so a saved file is complete.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import xarray as xr

from flexlift import constants as C
from flexlift.ascent.state import (
    EV_ARRIVAL,
    EV_BREAKOUT,
    EV_LIFTOFF,
    EV_LIMIT_PITCH,
    EV_LIMIT_VELOCITY,
    EV_NUMERICS,
    EV_RESETTLE,
    EV_SEPARATION,
    EV_SURFACE_BREACH,
    EV_TARGET_HELD,
)

#: the bag variables of a recorded row, in the order the compiled loop writes them
BAG_VARS = {
    "height": ("m", "height of the bag's point above the seabed"),
    "ascent_velocity": ("m/s", "vertical velocity of the bag's point"),
    "pitch_angle": ("rad", "local slope of the hull at the bag's point, bow-up positive"),
    "pitch_rate": ("rad/s", "rate of the local slope at the bag's point"),
    "net_flow": ("m3/s", "fill minus purge flow at local pressure"),
    "gas_volume": ("m3", "gas volume in the bag"),
    "lift": ("N", "buoyancy of the bag acting on the hull"),
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
CRITERIA = ("ascent_velocity", "pitch", "reached_target", "no_surface_breach", "no_resettle")
EVENT_KINDS = {EV_SEPARATION: "separation", EV_BREAKOUT: "breakout", EV_ARRIVAL: "arrival",
               EV_TARGET_HELD: "target_held", EV_SURFACE_BREACH: "surface_breach",
               EV_LIMIT_VELOCITY: "limit_ascent_velocity", EV_LIMIT_PITCH: "limit_pitch",
               EV_LIFTOFF: "liftoff", EV_RESETTLE: "resettle", EV_NUMERICS: "numerics_failed"}


@dataclass(frozen=True)
class Result:
    """One simulated ascent. ``dataset`` holds everything; the properties read its attrs."""

    dataset: xr.Dataset

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
                "max_ascent_velocity_ms", "max_pitch_deg", "max_bending_moment_MNm",
                "max_shear_force_MN", "gas_used_local_m3", "gas_used_free_air_m3", "end_time_s")
        out = {"control": self.control, **{k: h[k] for k in keys}, "arrival_time_s": arr,
               "final_height_m": {str(b): round(float(v), 2)
                                  for b, v in zip(ds.bag.values, ds.height.values[-1])},
               "criteria": self.criteria,
               "events": [{"time_s": e["time_s"], "kind": e["kind"], "bag": e["bag"]}
                          for e in self.events],
               "error": self.error or None}
        return out


def _r(v, nd=3):
    return None if v is None or not np.isfinite(v) else round(float(v), nd)


def event_list(run) -> list[dict]:
    """The run's events (compiled loop and faults) in time order, with names and details."""
    rec, P, X = run.rec, run.plant, run.X
    g_t = P.gravity * C.TONNE
    out = []
    for k in range(int(rec.counts[2])):
        code, i, val = int(rec.ev_code[k]), int(rec.ev_index[k]), float(rec.ev_value[k])
        kind = EVENT_KINDS[code]
        bag = P.names[i] if code in (EV_ARRIVAL, EV_SURFACE_BREACH, EV_LIMIT_VELOCITY) else None
        detail = {EV_SURFACE_BREACH: "the run ends at the surface",
                  EV_LIMIT_VELOCITY: f"{val:.2f} m/s",
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


def snapshots(run) -> dict:
    """The strength snapshots of a run, stacked over time (copies), by name."""
    rec = run.rec
    n = int(rec.counts[1])
    return {"t": rec.snap_t[:n].copy(), "q": rec.snap_q[:n].copy(), "v": rec.snap_v[:n].copy(),
            "a": rec.snap_a[:n].copy(), "H": rec.snap_H[:n].copy(), "sep": rec.snap_sep[:n].copy(),
            "V": rec.snap_V[:n].copy(), "attached": rec.snap_attached[:n].copy(),
            "current": rec.snap_current[:n].copy(), "noise": rec.snap_noise[:n].copy()}


def build_result(run, error: str | None) -> Result:
    """The Dataset of a finished (or failed) run."""
    from flexlift.ascent.strength import strength

    P, rec, R = run.plant, run.rec, run.R
    nrow = int(rec.counts[0])
    t = rec.t[:nrow].copy()
    coords = {"time": ("time", t, {"units": "s", "long_name": "time since filling began"}),
              "bag": ("bag", list(P.names))}
    data = {}
    for j, (name, (unit, long)) in enumerate(BAG_VARS.items()):
        data[name] = (("time", "bag"), rec.bag[:nrow, j, :].copy(), {"units": unit, "long_name": long})
    for j, (name, (unit, long)) in enumerate(HULL_VARS.items()):
        data[name] = (("time",), rec.hull[:nrow, j].copy(), {"units": unit, "long_name": long})
    per_bag = {"bag_x": (P.x_point, "m", "bag point from the aft end"),
               "arrival_time": (R.arrival, "s", "first time within tolerance of the target"),
               "gas_vented": (R.vented, "m3", "gas spilled, vented or leaked, at local pressure"),
               "gas_purged": (R.purged, "m3", "gas purged, at local pressure"),
               "gas_used_local": (R.gas_local, "m3", "gas filled, at local pressure"),
               "gas_used_free_air": (R.gas_free, "m3", "gas filled, as free air at the surface")}
    for name, (vals, unit, long) in per_bag.items():
        data[name] = (("bag",), np.array(vals, dtype=float), {"units": unit, "long_name": long})
    data["bag_kind"] = (("bag",), np.array(["external" if e else "internal" for e in P.external]),
                        {"units": "1", "long_name": "external parachute or internal cylindrical"})
    Mmax = Vmax = None
    snaps = snapshots(run)
    if snaps["t"].size and P.kind == "coupled":
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
        Mmax, Vmax = float(np.abs(Ms).max()), float(np.abs(Vs).max())
    ds = xr.Dataset(data, coords=coords)
    events = event_list(run)
    _attributes(ds, run, events, t, Mmax, Vmax, error)
    return Result(ds)


def _attributes(ds, run, events, t, Mmax, Vmax, error) -> None:
    sc, R, P = run.scenario, run.R, run.plant
    vmax, pmax = float(R.scalars[0]), float(R.scalars[1])
    kinds = {e["kind"] for e in events}
    crit = {"ascent_velocity": vmax < sc.limits.ascent_velocity_m_s,
            "pitch": float(np.degrees(pmax)) < sc.limits.pitch_deg,
            "reached_target": "target_held" in kinds,
            "no_surface_breach": "surface_breach" not in kinds,
            "no_resettle": "resettle" not in kinds}

    def first(kind):
        return next((e["time_s"] for e in events if e["kind"] == kind), None)

    arr = R.arrival[P.external] if P.external.any() else R.arrival
    spread = float(np.nanmax(arr) - np.nanmin(arr)) if np.all(np.isfinite(arr)) else None
    headline = {
        "separation_time_s": _r(first("separation"), 1),
        "breakout_time_s": _r(first("breakout"), 1),
        "arrival_spread_s": _r(spread, 1),
        "max_ascent_velocity_ms": _r(vmax, 4),
        "max_pitch_deg": _r(np.degrees(pmax), 4),
        "max_bending_moment_MNm": _r(Mmax / 1e6, 3) if Mmax is not None else None,
        "max_shear_force_MN": _r(Vmax / 1e6, 4) if Vmax is not None else None,
        "gas_used_local_m3": _r(R.gas_local.sum(), 1),
        "gas_used_free_air_m3": _r(R.gas_free.sum(), 1),
        "end_time_s": _r(float(t[-1]) if t.size else 0.0, 1),
    }
    ds.attrs.update(title=f"flexlift ascent of {sc.name}, {run.mode} control", scenario=sc.name,
                    scenario_checksum=sc.checksum(), control=run.mode, events=json.dumps(events),
                    criteria=json.dumps(crit), headline=json.dumps(headline), error=error or "",
                    max_ascent_velocity_m_s=vmax, max_pitch_rad=pmax)
