"""``results.nc`` with every control mode of a run: one netCDF 3 file (SPEC §8).

Layout: each mode's dataset along a ``mode`` dimension. Runs of different lengths share one
``row`` dimension (and ``strength_row`` for the strength samples), the shorter padded with
NaN at its end; ``time(mode, row)`` and ``time_strength(mode, strength_row)`` [s] are
variables, and ``rows(mode)`` / ``strength_rows(mode)`` say how many rows each mode has.
(A shared ``time`` axis aligned by value would interleave NaN rows wherever one mode stopped
off the other's grid.) Each mode's attributes (events, criteria, headline, ...) are the JSON
object ``mode_attrs[mode]`` in the file's attributes. Read one mode back, exactly as it was
written, with :func:`unstack` (:func:`flexlift.output.results.load_netcdf` does).

Bags of one lift point (:mod:`flexlift.output.liftpoints`) move together unless a fault or
noise parts them: a bag history whose columns are equal, bit for bit, within every lift point
in every mode is stored once per point, ``(mode, row, point)``, and ``bag_point(bag)`` says
which point's column is each bag's (:func:`unstack` spreads it back; nothing is lost). On the
tanker with 73 bags of 50 t at 10 points that is 7 times smaller.

Sizes: the state variables (heights, gas volumes, lift, the hull's heave, pitch and holding
force) and everything else stay float64; the derived, plot-only bag histories in
:data:`FLOAT32_VARS` are stored as float32 (read back as float64 with float32's 7 digits).
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

#: bag histories derived from the states or kept for the figures: stored as float32
FLOAT32_VARS = frozenset({"ascent_velocity", "pitch_angle", "pitch_rate", "net_flow", "fill_rate",
                          "purge_opening", "supervisor_output", "desired_volume",
                          "reference_height"})
_TIMES = {"time": "row", "time_strength": "strength_row"}


def _padded(a: np.ndarray, n: int) -> np.ndarray:
    """``a`` with NaN rows appended along its first axis up to ``n`` rows."""
    if a.shape[0] == n:
        return a
    pad = np.full((n - a.shape[0],) + a.shape[1:], np.nan, dtype=a.dtype)
    return np.concatenate([a, pad])


def stack(datasets: list[xr.Dataset]) -> xr.Dataset:
    """The datasets of several control modes (``attrs["control"]`` names each) as one."""
    modes = [d.attrs["control"] for d in datasets]
    if len(set(modes)) != len(modes):
        raise ValueError(f"one dataset per control mode, got {modes}")
    sizes = {dim: max((d.sizes.get(dim, 0) for d in datasets), default=0) for dim in _TIMES}
    names: dict[str, None] = {}
    for d in datasets:
        names.update(dict.fromkeys(list(d.data_vars) + [c for c in _TIMES if c in d.coords]))
    template = {}
    for name in names:
        template[name] = next(d[name] for d in datasets if name in d.variables)
    data = {}
    first_of_point, bag_point = _points(datasets[0])
    for name, tv in template.items():
        dims = tuple(_TIMES.get(dim, dim) for dim in tv.dims)
        parts = []
        for d in datasets:
            if name in d.variables:
                a = d[name].values
            else:  # a variable this mode has not (its plant had no strength grid)
                shape = tuple(d.sizes.get(dim, tv.sizes[dim]) for dim in tv.dims)
                a = np.full(shape, np.nan)
            if tv.dims and tv.dims[0] in _TIMES:
                a = _padded(a, sizes[tv.dims[0]])
            parts.append(a)
        arr = np.stack(parts)
        attrs = dict(tv.attrs)
        if dims[-2:] == ("row", "bag") and _by_point(arr, first_of_point, bag_point):
            arr, dims = arr[..., first_of_point], dims[:-1] + ("point",)
            attrs[_STORED] = "one column per lift point: bag_point(bag) says which"
        if name in FLOAT32_VARS:
            arr = arr.astype(np.float32)
        elif arr.dtype.kind == "U":
            arr = arr.astype("S")
        data[name] = (("mode",) + dims, arr, attrs)
    data["bag_point"] = (("bag",), bag_point.astype(np.int32),
                         {"units": "1", "long_name": "the lift point (column along point) of the "
                                                     "bag's histories stored by point"})
    data["rows"] = (("mode",), np.array([d.sizes.get("time", 0) for d in datasets], np.int32),
                    {"units": "1", "long_name": "rows of the mode's time histories"})
    data["strength_rows"] = (("mode",), np.array([d.sizes.get("time_strength", 0)
                                                  for d in datasets], np.int32),
                             {"units": "1", "long_name": "rows of the mode's strength samples"})
    coords = {"mode": ("mode", np.array(modes, dtype="S"))}
    for d in datasets:
        for c in ("bag", "x"):
            if c in d.coords and c not in coords:
                coords[c] = (c, d[c].values, dict(d[c].attrs))
    meta = {d.attrs["control"]: {"attrs": dict(d.attrs),
                                 "variables": list(d.data_vars),
                                 "coords": list(d.coords)} for d in datasets}
    first = datasets[0].attrs
    attrs = {"title": f"flexlift ascent of {first.get('scenario', '')}, control modes: "
                      f"{', '.join(modes)}",
             "scenario": first.get("scenario", ""),
             "scenario_checksum": first.get("scenario_checksum", ""),
             "modes": " ".join(modes),
             "mode_attrs": json.dumps(meta)}
    if "bag" in coords:
        coords["bag"] = ("bag", np.array([str(b) for b in coords["bag"][1]], dtype="S"))
    return xr.Dataset(data, coords=coords, attrs=attrs)


#: the attribute of a bag history stored once per lift point
_STORED = "stored_by_point"


def _points(ds: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """(the first bag of each lift point, each bag's point) along ``bag``."""
    from flexlift.output.liftpoints import lift_points

    points = lift_points(ds) if "bag_x" in ds and "bag_kind" in ds else []
    bag_point = np.zeros(ds.sizes.get("bag", 0), dtype=int)
    for j, p in enumerate(points):
        bag_point[p.index] = j
    return np.array([p.index[0] for p in points], dtype=int), bag_point


def _by_point(arr: np.ndarray, first_of_point: np.ndarray, bag_point: np.ndarray) -> bool:
    """Whether ``arr`` (..., bag) holds, for every bag, its point's first bag's values exactly
    (NaN equal to NaN), so that storing one column per point loses nothing."""
    if not first_of_point.size or first_of_point.size == bag_point.size:
        return False
    return bool(np.array_equal(arr, arr[..., first_of_point[bag_point]], equal_nan=True))


def modes_of(ds: xr.Dataset) -> list[str]:
    """The control modes of a stacked dataset, in their order."""
    return ds.attrs["modes"].split()


def unstack(ds: xr.Dataset, mode: str | None = None) -> xr.Dataset:
    """One mode's dataset (the first when ``mode`` is None) as :func:`stack` received it; the
    float32 variables come back as float64."""
    modes = modes_of(ds)
    mode = modes[0] if mode is None else mode
    if mode not in modes:
        raise KeyError(f"control mode {mode!r} is not in the file; it has {', '.join(modes)}")
    k = modes.index(mode)
    meta = json.loads(ds.attrs["mode_attrs"])[mode]
    cut = {"row": int(ds["rows"].values[k]), "strength_row": int(ds["strength_rows"].values[k])}

    def one(name):
        v = ds[name]
        a = v.values[k]
        dims = v.dims[1:]
        attrs = dict(v.attrs)
        if dims[-1:] == ("point",):  # stored once per lift point: back to every bag
            a, dims = a[..., ds["bag_point"].values], dims[:-1] + ("bag",)
            attrs.pop(_STORED, None)
        if dims and dims[0] in cut:
            a = a[:cut[dims[0]]]
        if a.dtype == np.float32:
            a = a.astype(np.float64)
        elif a.dtype.kind == "S":
            a = a.astype(str)
        back = {row: t for t, row in _TIMES.items()}
        return tuple(back.get(d, d) for d in dims), a, attrs

    coords = {}
    for c in meta["coords"]:
        if c in _TIMES:
            coords[c] = one(c)
        else:
            vals = ds[c].values
            coords[c] = (c, vals.astype(str) if vals.dtype.kind == "S" else vals,
                         dict(ds[c].attrs))
    data = {name: one(name) for name in meta["variables"]}
    return xr.Dataset(data, coords=coords, attrs=meta["attrs"])
