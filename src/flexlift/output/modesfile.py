"""``results.nc`` with every control mode of a run: one netCDF 3 file (docs/theory/loop.md#state).

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


def _fill(dtype) -> object:
    """The padding of an array of ``dtype``: NaN, an empty string, or 0."""
    return np.nan if dtype.kind == "f" else "" if dtype.kind in "US" else 0


def _spread(a: np.ndarray, dims: tuple, pos: np.ndarray, n_bags: int) -> np.ndarray:
    """``a`` with its ``bag`` axis (if any) placed at ``pos`` of ``n_bags``, padded."""
    if "bag" not in dims:
        return a
    ax = dims.index("bag")
    shape = a.shape[:ax] + (n_bags,) + a.shape[ax + 1:]
    full = np.full(shape, _fill(a.dtype), dtype=a.dtype)
    full[(slice(None),) * ax + (pos,)] = a
    return full


def stack(datasets: list[xr.Dataset], by_point: dict | None = None) -> xr.Dataset:
    """The datasets of several control modes (``attrs["control"]`` names each) as one. The
    ``bag`` dimension is the union of the modes' bags (the paper's plant has the external bags
    only): a bag a mode has not is padded like a missing row. ``by_point``: for a mode read
    back with :func:`unstack` (``by_point=True``), its bags' points (``{mode: bag_point}``):
    its histories stored by point are spread to its bags one variable at a time."""
    by_point = by_point or {}
    modes = [d.attrs["control"] for d in datasets]
    if len(set(modes)) != len(modes):
        raise ValueError(f"one dataset per control mode, got {modes}")
    sizes = {dim: max((d.sizes.get(dim, 0) for d in datasets), default=0) for dim in _TIMES}
    bags = list(dict.fromkeys(str(b) for d in datasets if "bag" in d.coords
                              for b in d.bag.values))
    pos = {d.attrs["control"]: np.array([bags.index(str(b)) for b in d.bag.values], dtype=int)
           if "bag" in d.coords else np.zeros(0, dtype=int) for d in datasets}
    template = _template(datasets)
    data = {}
    first_of_point, bag_point = _points(datasets, bags)
    for name, tv in template.items():
        dims = tuple(_TIMES.get(dim, dim) for dim in tv.dims)
        parts = []
        for d in datasets:
            if name not in d.variables:  # a variable this mode has not (no strength grid)
                shape = tuple(sizes[dim] if dim in _TIMES else len(bags) if dim == "bag"
                              else d0 for dim, d0 in zip(tv.dims, tv.shape))
                parts.append(np.full(shape, _fill(tv.dtype), dtype=tv.dtype))
                continue
            a = d[name].values
            if d[name].dims[-1:] == ("point",):
                a = a[..., by_point[d.attrs["control"]]]
            a = _spread(a, tv.dims, pos[d.attrs["control"]], len(bags))
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
    if bags:
        coords["bag"] = ("bag", np.array(bags, dtype="S"))
    for d in datasets:
        if "x" in d.coords and "x" not in coords:
            coords["x"] = ("x", d["x"].values, dict(d["x"].attrs))
    return xr.Dataset(data, coords=coords, attrs=_file_attrs(datasets, modes))


def _template(datasets: list[xr.Dataset]) -> dict:
    """Each variable (and time coordinate) of any mode, from the first mode that has it; one
    stored by lift point as the bags' histories it stands for (an empty ``bag`` column)."""
    names: dict[str, None] = {}
    for d in datasets:
        names.update(dict.fromkeys(list(d.data_vars) + [c for c in _TIMES if c in d.coords]))
    template = {}
    for name in names:
        template[name] = next(d[name] for d in datasets if name in d.variables)
        if template[name].dims[-1:] == ("point",):  # as the bags' histories it stands for
            tv = template[name]
            template[name] = xr.Variable(tv.dims[:-1] + ("bag",), np.zeros(
                tv.shape[:-1] + (0,), tv.dtype), {k: v for k, v in tv.attrs.items()
                                                   if k != _STORED})
    return template


def _file_attrs(datasets: list[xr.Dataset], modes: list[str]) -> dict:
    """The stacked file's attributes: its title, scenario and checksum, and each mode's own
    attributes, variables, coordinates and bags (``mode_attrs``, JSON) for :func:`unstack`."""
    meta = {d.attrs["control"]: {"attrs": dict(d.attrs),
                                 "variables": list(d.data_vars),
                                 "coords": list(d.coords),
                                 "bags": [str(b) for b in d.bag.values] if "bag" in d.coords
                                 else []} for d in datasets}
    first = datasets[0].attrs
    return {"title": f"flexlift ascent of {first.get('scenario', '')}, control modes: "
                     f"{', '.join(modes)}",
            "scenario": first.get("scenario", ""),
            "scenario_checksum": first.get("scenario_checksum", ""),
            "modes": " ".join(modes),
            "mode_attrs": json.dumps(meta)}


#: the attribute of a bag history stored once per lift point
_STORED = "stored_by_point"


def _points(datasets: list[xr.Dataset], bags: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(the first bag of each lift point, each bag's point) along the union ``bags``."""
    from flexlift.output.liftpoints import lift_points

    x, kind = {}, {}
    for d in datasets:
        if "bag_x" in d and "bag_kind" in d:
            for b, xb, k in zip(d.bag.values, d.bag_x.values, d.bag_kind.values):
                x.setdefault(str(b), float(xb))
                kind.setdefault(str(b), str(k))
    bag_point = np.zeros(len(bags), dtype=int)
    if len(x) != len(bags):
        return np.zeros(0, dtype=int), bag_point
    union = xr.Dataset({"bag_x": ("bag", [x[b] for b in bags]),
                        "bag_kind": ("bag", [kind[b] for b in bags])}, coords={"bag": bags})
    points = lift_points(union)
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


def unstack(ds: xr.Dataset, mode: str | None = None, variables=None,
            by_point: bool = False) -> xr.Dataset:
    """One mode's dataset (the first when ``mode`` is None) as :func:`stack` received it; the
    float32 variables come back as float64. ``variables``: only these (default all; the
    coordinates always). ``by_point``: the histories stored once per lift point stay so
    (``(time, point)``; :func:`bag_points` says which point is each bag's), for
    :func:`stack` to take back without holding every bag's copy at once."""
    modes = modes_of(ds)
    mode = modes[0] if mode is None else mode
    if mode not in modes:
        raise KeyError(f"control mode {mode!r} is not in the file; it has {', '.join(modes)}")
    k = modes.index(mode)
    meta = json.loads(ds.attrs["mode_attrs"])[mode]
    cut = {"row": int(ds["rows"].values[k]), "strength_row": int(ds["strength_rows"].values[k])}
    union = [b.decode() if isinstance(b, bytes) else str(b) for b in ds["bag"].values] \
        if "bag" in ds.coords else []
    mine = np.array([union.index(b) for b in meta["bags"]], dtype=int)

    def one(name):
        v = ds[name]
        a = v.values[k]
        dims = v.dims[1:]
        attrs = dict(v.attrs)
        if dims[-1:] == ("point",) and not by_point:  # stored per lift point: to every bag
            a, dims = a[..., ds["bag_point"].values], dims[:-1] + ("bag",)
            attrs.pop(_STORED, None)
        if dims and dims[0] in cut:
            a = a[:cut[dims[0]]]
        if "bag" in dims:  # the mode's own bags of the union
            a = np.take(a, mine, axis=dims.index("bag"))
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
        elif c == "bag":
            coords[c] = (c, np.array(meta["bags"]), dict(ds[c].attrs))
        else:
            vals = ds[c].values
            coords[c] = (c, vals.astype(str) if vals.dtype.kind == "S" else vals,
                         dict(ds[c].attrs))
    data = {name: one(name) for name in meta["variables"]
            if variables is None or name in variables}
    return xr.Dataset(data, coords=coords, attrs=meta["attrs"])


def bag_points(ds: xr.Dataset, mode: str) -> np.ndarray:
    """The lift point (column along ``point``) of each of ``mode``'s own bags in a stacked
    dataset (what :func:`stack` takes for a mode read with ``unstack(by_point=True)``)."""
    meta = json.loads(ds.attrs["mode_attrs"])[mode]
    union = [b.decode() if isinstance(b, bytes) else str(b) for b in ds["bag"].values]
    return ds["bag_point"].values[[union.index(b) for b in meta["bags"]]].astype(int)
