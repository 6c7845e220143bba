"""Results on disk: an ascent's dataset as netCDF and its time histories as CSV (docs/theory/loop.md#outputs).

The dataset itself (variables, units, criteria, headline numbers) is built by
:mod:`flexlift.ascent.result`; this module only writes and reads it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from flexlift.ascent.result import BAG_VARS, CRITERIA, HULL_VARS, Result

__all__ = ["BAG_VARS", "CRITERIA", "HULL_VARS", "Result", "add_to_netcdf", "load_netcdf",
           "netcdf_modes", "save_netcdf", "to_csv"]


def save_netcdf(result: Result | list[Result], path) -> Path:
    """Write a result as netCDF 3 (scipy engine), atomically; returns the path. A list of
    results (one per control mode, as ``results.nc`` holds them) is written in the layout of
    :mod:`flexlift.output.modesfile` (a ``mode`` dimension); a single result as its dataset
    (a sweep's case histories)."""
    from flexlift.plumbing.atomic import atomic_file

    path = Path(path)
    if isinstance(result, list):
        from flexlift.output.modesfile import stack

        ds = stack([r.dataset for r in result])
    else:
        ds = result.dataset.copy()
        ds["bag_kind"] = ds["bag_kind"].astype("S8")
    with atomic_file(path, suffix=".nc") as tmp:
        ds.to_netcdf(tmp, engine="scipy")
    return path


def add_to_netcdf(result: Result, path) -> Path:
    """Add ``result``'s control mode to the file at ``path`` (written by :func:`save_netcdf`;
    a mode already there is replaced, a missing file is created); returns the path."""
    from flexlift.output.modesfile import bag_points, stack, unstack
    from flexlift.plumbing.atomic import atomic_file

    path = Path(path)
    if not path.is_file():
        return save_netcdf([result], path)
    with xr.open_dataset(path, engine="scipy") as ds:
        by_mode = "mode" in ds.dims
        if by_mode:
            ds = ds.load()
    if not by_mode:  # a single result, as flexlift wrote it before the mode dimension
        old = load_netcdf(path)
        return save_netcdf(([old] if old.control != result.control else []) + [result], path)
    # the other modes as stored: their histories by lift point are spread to the bags one
    # variable at a time (not every mode's copy of every bag's history at once)
    modes = [m for m in ds.attrs["modes"].split() if m != result.control]
    others = [unstack(ds, m, by_point=True) for m in modes]
    stacked = stack(others + [result.dataset], by_point={m: bag_points(ds, m) for m in modes})
    del ds, others
    with atomic_file(path, suffix=".nc") as tmp:
        stacked.to_netcdf(tmp, engine="scipy")
    return path


def netcdf_modes(path) -> list[str]:
    """The control modes in a file written by :func:`save_netcdf`, in order."""
    from flexlift.output.modesfile import modes_of

    with xr.open_dataset(path, engine="scipy") as ds:
        return modes_of(ds) if "mode" in ds.dims else [ds.attrs["control"]]


def load_netcdf(path, mode: str | None = None, variables=None) -> Result:
    """Read one control mode (the file's first when None) of a file written by
    :func:`save_netcdf` (or a single result as flexlift wrote it before the ``mode``
    dimension; a file of an earlier version, whose ``lift`` held the sling force, is read
    with it named ``sling_force``). ``variables``: only these of a file with the ``mode``
    dimension (default all; the coordinates and attributes always)."""
    from flexlift.output.modesfile import unstack

    with xr.open_dataset(path, engine="scipy") as ds:
        if "mode" in ds.dims:  # only what is asked for read into memory
            drop = [v for v in ds.data_vars if variables is not None and v not in variables
                    and v not in ("time", "time_strength", "bag_point", "rows", "strength_rows")]
            return Result(unstack(ds.drop_vars(drop).load(), mode, variables))
        ds = ds.load()
    for name in ("bag", "bag_kind"):
        if ds[name].dtype.kind == "S":
            ds[name] = ds[name].astype(str)
    if "lift" in ds and "sling_force" not in ds:
        # written before the two were told apart: "lift" held the sling force
        ds = ds.rename({"lift": "sling_force"})
        ds["sling_force"].attrs.update(units="N", long_name=BAG_VARS["sling_force"][1])
    return Result(ds)


def to_csv(result: Result, folder, prefix: str = "simulate") -> list[Path]:
    """Write the time histories (one column per variable and lift point, units in the
    headers: :func:`flexlift.output.liftpoints.point_columns`) and the strength envelopes as
    CSV under ``folder``; returns the paths. Every bag's own histories are in the netCDF."""
    from flexlift.output.liftpoints import point_columns
    from flexlift.plumbing.atomic import write_text

    ds = result.dataset
    folder = Path(folder)
    cols = ["time [s]"]
    arrays = [ds.time.values]
    for name in HULL_VARS:
        cols.append(f"{name} [{ds[name].attrs['units']}]")
        arrays.append(ds[name].values)
    names = [*BAG_VARS, *(["buoyancy"] if "buoyancy" in ds else [])]
    for col, arr in point_columns(ds, names):  # by lift point: see its docstring
        cols.append(col)
        arrays.append(arr)
    paths = [write_text(folder / f"{prefix}_time_histories.csv", _csv(cols, np.column_stack(arrays)))]
    if "x" in ds.coords:
        names = ["moment_max", "moment_min", "shear_max", "shear_min"]
        cols = ["x [m]"] + [f"{n} [{ds[n].attrs['units']}]" for n in names]
        arr = np.column_stack([ds.x.values] + [ds[n].values for n in names])
        paths.append(write_text(folder / f"{prefix}_strength_envelope.csv", _csv(cols, arr)))
    return paths


def _csv(cols, arr) -> str:
    """CSV text: a header line, then each row's values as ``%.6g``, with an empty field for
    NaN or infinity. The whole table is formatted by one ``%`` on a template of every row
    (and the non-finite fields blanked by a replacement), not value by value."""
    arr = np.asarray(arr, dtype=float)
    head = ",".join(cols) + "\n"
    if not arr.size:
        return head
    n_rows, n_cols = arr.shape
    body = ((",".join(["%.6g"] * n_cols) + "\n") * n_rows) % tuple(arr.ravel().tolist())
    if not np.isfinite(arr).all():
        # %.6g writes only digits, "-", "." and "e" for a finite value: "nan", "inf" and
        # "-inf" can only be whole fields
        body = body.replace("-inf", "").replace("inf", "").replace("nan", "")
    return head + body
