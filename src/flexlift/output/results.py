"""Results on disk: an ascent's dataset as netCDF and its time histories as CSV (SPEC §8).

The dataset itself (variables, units, criteria, headline numbers) is built by
:mod:`flexlift.ascent.result`; this module only writes and reads it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import xarray as xr

from flexlift.ascent.result import BAG_VARS, CRITERIA, HULL_VARS, Result

__all__ = ["BAG_VARS", "CRITERIA", "HULL_VARS", "Result", "load_netcdf", "save_netcdf", "to_csv"]


def save_netcdf(result: Result, path) -> Path:
    """Write the dataset as netCDF 3 (scipy engine), atomically; returns the path."""
    from flexlift.plumbing.atomic import atomic_file

    path = Path(path)
    ds = result.dataset.copy()
    ds["bag_kind"] = ds["bag_kind"].astype("S8")
    with atomic_file(path, suffix=".nc") as tmp:
        ds.to_netcdf(tmp, engine="scipy")
    return path


def load_netcdf(path) -> Result:
    """Read a result written by :func:`save_netcdf` (a file of an earlier version, whose
    ``lift`` held the sling force, is read with it named ``sling_force``)."""
    with xr.open_dataset(path, engine="scipy") as ds:
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
    """Write the time histories (one column per variable and bag, units in the headers) and
    the strength envelopes as CSV under ``folder``; returns the paths."""
    from flexlift.plumbing.atomic import write_text

    ds = result.dataset
    folder = Path(folder)
    cols = ["time [s]"]
    arrays = [ds.time.values]
    for name in HULL_VARS:
        cols.append(f"{name} [{ds[name].attrs['units']}]")
        arrays.append(ds[name].values)
    for name in [*BAG_VARS, *(["buoyancy"] if "buoyancy" in ds else [])]:
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
