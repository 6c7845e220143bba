"""Results of an ascent: an xarray Dataset with units, criteria, netCDF and CSV (SPEC §7-8).

Dimensions: ``time`` (every ``simulation.output_interval_s``), ``bag``, ``x`` (along the hull)
and ``time_strength`` (every ``simulation.strength_interval_s``, for shear and moment).
Every variable carries ``units`` and ``long_name`` attributes. The events, the criteria and the
headline numbers are JSON strings in the dataset's attributes, so a saved file is complete.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import xarray as xr

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
HULL_VARS = {
    "heave": ("m", "rigid heave of the hull's centre of mass above the seabed"),
    "pitch": ("rad", "rigid pitch angle of the hull, bow-up positive"),
    "holding_force": ("N", "suction holding force H"),
    "uplift": ("N", "net uplift U = sum of bag lift - wet weight"),
    "contact_force": ("N", "seabed contact force"),
}
CRITERIA = ("ascent_velocity", "pitch", "reached_target", "no_surface_breach", "no_resettle")


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
        h = self.headline
        ds = self.dataset
        arr = {str(b): (None if np.isnan(v) else round(float(v), 1))
               for b, v in zip(ds.bag.values, ds.arrival_time.values)}
        return {
            "control": self.control,
            "breakout_time_s": h["breakout_time_s"],
            "separation_time_s": h["separation_time_s"],
            "arrival_time_s": arr,
            "arrival_spread_s": h["arrival_spread_s"],
            "max_ascent_velocity_ms": h["max_ascent_velocity_ms"],
            "max_pitch_deg": h["max_pitch_deg"],
            "max_bending_moment_MNm": h["max_bending_moment_MNm"],
            "max_shear_force_MN": h["max_shear_force_MN"],
            "gas_used_local_m3": h["gas_used_local_m3"],
            "gas_used_free_air_m3": h["gas_used_free_air_m3"],
            "final_height_m": {str(b): round(float(v), 2)
                               for b, v in zip(ds.bag.values, ds.height.values[-1])},
            "end_time_s": h["end_time_s"],
            "criteria": self.criteria,
            "events": [{"time_s": e["time_s"], "kind": e["kind"], "bag": e["bag"]}
                       for e in self.events],
            "error": self.error or None,
        }


def _r(v, nd=3):
    return None if v is None or not np.isfinite(v) else round(float(v), nd)


def strength(P, snaps, n_per_element: int = 8):
    """Shear force and bending moment along the hull at the snapshot times.

    Returns (x [m], V [N] (nt, nx), M [N m] (nt, nx)), from the line loads (wet weight,
    inertia of the structural and added mass, drag, seabed contact, suction, force noise,
    internal bags) and point loads (external bags with their drag, point masses)."""
    from flexlift.loads import shear_moment

    hull = P.hull
    L = hull.length
    base = np.linspace(0.0, L, n_per_element * hull.n_elements + 1)
    ends = sorted({e for s in P.spans if s is not None for e in s if 0 < e < L})
    x = np.sort(np.concatenate([base, ends, ends]))
    side = np.zeros_like(x)
    for e in ends:
        k = np.flatnonzero(np.isclose(x, e))
        side[k[0]], side[k[-1]] = -1.0, 1.0
    xe = x + side * 1e-9 * L
    nr = P.nr
    psi = P.modes.shape_at(np.clip(xe, 0, L))[:, :nr]
    l = hull.element_length
    m_s = hull.mass_per_length[np.clip((xe / l).astype(int), 0, hull.n_elements - 1)]
    buoy = P.wet_weight / P.plan.dry_weight
    g = P.gas.g
    sb = P.seabed
    qs, pts = [], []
    for s in snaps:
        w, v, a = psi @ s["q"], psi @ s["v"], psi @ s["a"]
        q = -m_s * g * buoy - (m_s + P.mass_line) * a
        vr = v - s["current"]
        q = q - P.drag_line * np.abs(vr) * vr
        qc = -sb.stiffness * w - sb.damping * v
        if s["separated"]:
            q = q + np.where((w < 0) & (qc > 0), qc, 0.0) - s["H"] * sb.shape(xe, L)
        else:
            q = q + qc
        q = q + np.interp(xe, P.xs, s["noise"])
        for i, span in enumerate(P.spans):
            if span is not None:
                a0, a1 = span
                inside = (xe >= a0) & (xe <= a1)
                q = q + np.where(inside, P.gas.rho * g * s["volume"][i] * s["attached"][i] / (a1 - a0), 0.0)
        qs.append(q)
        pts.append(s["point"] * P.external + 0.0)
    qs = np.array(qs)
    pts = np.array(pts)
    point_loads = [(float(P.x_point[i]), pts[:, i]) for i in np.flatnonzero(P.external)]
    acc_nodes = None
    for j, mp in enumerate(hull.point_masses):
        if mp > 0:
            if acc_nodes is None:
                an = np.array([s["a"] for s in snaps]) @ P.modes.displacement[:, :nr].T
                acc_nodes = an
            point_loads.append((float(hull.x_nodes[j]), -mp * g * buoy - mp * acc_nodes[:, j]))
    V, M = shear_moment(x, qs, point_loads)
    return x, V, M


def build_result(rec, error: str | None) -> Result:
    """Assemble the Dataset of a finished (or failed) run from a Recorder."""
    P, sc = rec.P, rec.scenario
    rows = rec.rows
    t = np.asarray(rows["time"], dtype=float)
    coords = {"time": ("time", t, {"units": "s", "long_name": "time since filling began"}),
              "bag": ("bag", list(P.names))}
    data = {}
    for name, (unit, long) in BAG_VARS.items():
        data[name] = (("time", "bag"), np.array(rows[name], dtype=float), {"units": unit, "long_name": long})
    for name, (unit, long) in HULL_VARS.items():
        data[name] = (("time",), np.array(rows[name], dtype=float), {"units": unit, "long_name": long})
    data["bag_x"] = (("bag",), P.x_point, {"units": "m", "long_name": "bag point from the aft end"})
    data["bag_kind"] = (("bag",), np.array(["external" if e else "internal" for e in P.external]),
                        {"units": "1", "long_name": "external parachute or internal cylindrical"})
    data["arrival_time"] = (("bag",), rec.arrival, {"units": "s", "long_name": "first time within tolerance of the target"})
    data["gas_vented"] = (("bag",), rec.vented, {"units": "m3", "long_name": "gas spilled or vented, at local pressure"})
    data["gas_used_local"] = (("bag",), rec.gas_local, {"units": "m3", "long_name": "gas filled, at local pressure"})
    data["gas_used_free_air"] = (("bag",), rec.gas_free, {"units": "m3", "long_name": "gas filled, as free air at the surface"})
    Mmax = Vmax = 0.0
    if rec.snap:
        xg, Vs, Ms = strength(P, rec.snap)
        ts = np.array([s["t"] for s in rec.snap])
        coords["x"] = ("x", xg, {"units": "m", "long_name": "position from the aft end"})
        coords["time_strength"] = ("time_strength", ts, {"units": "s", "long_name": "time of the strength samples"})
        data["shear_force"] = (("time_strength", "x"), Vs, {"units": "N", "long_name": "shear force, upward forces aft of x"})
        data["bending_moment"] = (("time_strength", "x"), Ms, {"units": "N m", "long_name": "bending moment, sagging positive"})
        data["moment_max"] = (("x",), Ms.max(0), {"units": "N m", "long_name": "envelope: largest bending moment"})
        data["moment_min"] = (("x",), Ms.min(0), {"units": "N m", "long_name": "envelope: smallest bending moment"})
        data["shear_max"] = (("x",), Vs.max(0), {"units": "N", "long_name": "envelope: largest shear force"})
        data["shear_min"] = (("x",), Vs.min(0), {"units": "N", "long_name": "envelope: smallest shear force"})
        Mmax, Vmax = float(np.abs(Ms).max()), float(np.abs(Vs).max())
    ds = xr.Dataset(data, coords=coords)
    ev = rec.events
    kinds = {e["kind"] for e in ev}
    held = "target_held" in kinds
    crit = {
        "ascent_velocity": rec.vmax < sc.limits.ascent_velocity_m_s,
        "pitch": float(np.degrees(rec.pmax)) < sc.limits.pitch_deg,
        "reached_target": held,
        "no_surface_breach": "surface_breach" not in kinds,
        "no_resettle": "resettle" not in kinds,
    }
    def first(kind):
        return next((e["time_s"] for e in ev if e["kind"] == kind), None)

    arr = rec.arrival[P.external] if P.external.any() else rec.arrival
    spread = float(np.nanmax(arr) - np.nanmin(arr)) if np.all(np.isfinite(arr)) else None
    headline = {
        "separation_time_s": _r(first("separation"), 1),
        "breakout_time_s": _r(first("breakout"), 1),
        "arrival_spread_s": _r(spread, 1),
        "max_ascent_velocity_ms": _r(rec.vmax, 4),
        "max_pitch_deg": _r(np.degrees(rec.pmax), 4),
        "max_bending_moment_MNm": _r(Mmax / 1e6, 3) if rec.snap else None,
        "max_shear_force_MN": _r(Vmax / 1e6, 4) if rec.snap else None,
        "gas_used_local_m3": _r(rec.gas_local.sum(), 1),
        "gas_used_free_air_m3": _r(rec.gas_free.sum(), 1),
        "end_time_s": _r(float(t[-1]) if t.size else 0.0, 1),
    }
    ds.attrs.update(
        title=f"flexlift ascent of {sc.name}, {rec.mode} control",
        scenario=sc.name,
        scenario_checksum=sc.checksum(),
        control=rec.mode,
        events=json.dumps(ev),
        criteria=json.dumps(crit),
        headline=json.dumps(headline),
        error=error or "",
        max_ascent_velocity_m_s=rec.vmax,
        max_pitch_rad=rec.pmax,
    )
    return Result(ds)


# ---------------------------------------------------------------------- files
def save_netcdf(result: Result, path) -> Path:
    """Write the dataset as netCDF 3 (scipy engine), atomically; returns the path."""
    from flexlift.output.files import atomic_file

    path = Path(path)
    ds = result.dataset.copy()
    ds["bag_kind"] = ds["bag_kind"].astype("S8")
    with atomic_file(path, suffix=".nc") as tmp:
        ds.to_netcdf(tmp, engine="scipy")
    return path


def load_netcdf(path) -> Result:
    """Read a result written by :func:`save_netcdf`."""
    with xr.open_dataset(path, engine="scipy") as ds:
        ds = ds.load()
    for name in ("bag", "bag_kind"):
        if ds[name].dtype.kind == "S":
            ds[name] = ds[name].astype(str)
    return Result(ds)


def to_csv(result: Result, folder, prefix: str = "simulate") -> list[Path]:
    """Write the time histories (one column per variable and bag, units in the headers) and
    the strength envelopes as CSV under ``folder``; returns the paths."""
    from flexlift.output.files import write_text

    ds = result.dataset
    folder = Path(folder)
    cols = ["time [s]"]
    arrays = [ds.time.values]
    for name in HULL_VARS:
        cols.append(f"{name} [{ds[name].attrs['units']}]")
        arrays.append(ds[name].values)
    for name in BAG_VARS:
        for k, b in enumerate(ds.bag.values):
            cols.append(f"{name}_{b} [{ds[name].attrs['units']}]")
            arrays.append(ds[name].values[:, k])
    paths = [write_text(folder / f"{prefix}_time_histories.csv", _csv(cols, np.column_stack(arrays)))]
    if "x" in ds.coords:
        names = ["moment_max", "moment_min", "shear_max", "shear_min"]
        cols = ["x [m]"] + [f"{n} [{ds[n].attrs['units']}]" for n in names]
        arr = np.column_stack([ds.x.values] + [ds[n].values for n in names])
        paths.append(write_text(folder / f"{prefix}_strength_envelope.csv", _csv(cols, arr)))
    return paths


def _csv(cols, arr) -> str:
    lines = [",".join(cols)]
    for row in arr:
        lines.append(",".join("" if not np.isfinite(v) else f"{v:.6g}" for v in row))
    return "\n".join(lines) + "\n"
