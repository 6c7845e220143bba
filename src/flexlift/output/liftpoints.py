"""Bags grouped by their lift point, for output that reads the same for 7 bags and for 400.

A lift point is where bags act on the hull: the external bags of one cluster share one point
(the same x), an internal bag is a point of its own. Figures draw one line per point (the
mean over its bags, their spread as a band), the CSV time histories one column per point and
statistic, and the tables one row per point; every bag's own values stay in ``results.nc``.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

#: positions closer than this are one lift point [m]
SAME_POINT_M = 1e-6


@dataclass(frozen=True)
class LiftPoint:
    """One lift point of a result.

    label : the bag's name for a lone bag, ``"bag_1..bag_8"`` for a run of names (or
        ``"bag_3+7"``, the first and how many more, otherwise)
    kind : "external" or "internal"
    x : position from the aft end [m] (an internal bag's point: the middle of its span)
    bags : the bags' names; index : their positions along the ``bag`` dimension
    """

    label: str
    kind: str
    x: float
    bags: tuple[str, ...]
    index: np.ndarray

    @property
    def count(self) -> int:
        return len(self.bags)


def _label(names: list[str]) -> str:
    if len(names) == 1:
        return names[0]
    nums = [n.removeprefix("bag_") for n in names]
    if all(s.isdigit() for s in nums) and [int(s) for s in nums] == list(
            range(int(nums[0]), int(nums[0]) + len(nums))):
        return f"{names[0]}..{names[-1]}"  # as the lift plan figure names a cluster
    return f"{names[0]}+{len(names) - 1}"


def lift_points(ds) -> list[LiftPoint]:
    """The lift points of a result's dataset (``bag``, ``bag_x`` [m], ``bag_kind``), in the
    order of their first bag."""
    names = [str(b) for b in ds.bag.values]
    xs = np.asarray(ds.bag_x.values, dtype=float)
    kinds = [str(k) for k in ds.bag_kind.values]
    groups: dict[tuple, list[int]] = {}
    for k, (x, kind) in enumerate(zip(xs, kinds)):
        key = (kind, round(x / SAME_POINT_M) if kind == "external" else names[k])
        groups.setdefault(key, []).append(k)
    return [LiftPoint(_label([names[k] for k in idx]), kinds[idx[0]], float(xs[idx[0]]),
                      tuple(names[k] for k in idx), np.array(idx))
            for idx in groups.values()]


def point_stats(values: np.ndarray, point: LiftPoint) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mean, min, max) over the point's bags of ``values`` (time, bag); NaN where every bag
    of the point is NaN."""
    v = np.asarray(values)[:, point.index]
    if point.count == 1:
        return v[:, 0], v[:, 0], v[:, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN row is NaN, as said
        return np.nanmean(v, axis=1), np.nanmin(v, axis=1), np.nanmax(v, axis=1)


#: the variables whose spread over a lift point's bags (min, max) the CSV also holds
SPREAD_VARS = ("height",)


def point_columns(ds, names: list[str]):
    """(column header, values over time) of the bag variables ``names`` by lift point: a lone
    bag's column is ``"height_bag_5 [m]"`` (as before lift points); a cluster's is the mean over
    its bags, ``"height_bag_1..bag_8_mean [m]"``, and for :data:`SPREAD_VARS` also ``_min`` and
    ``_max``."""
    points = lift_points(ds)
    for name in names:
        unit = ds[name].attrs["units"]
        values = ds[name].values
        for p in points:
            mean, lo, hi = point_stats(values, p)
            if p.count == 1:
                yield f"{name}_{p.label} [{unit}]", mean
                continue
            yield f"{name}_{p.label}_mean [{unit}]", mean
            if name in SPREAD_VARS:
                yield f"{name}_{p.label}_min [{unit}]", lo
                yield f"{name}_{p.label}_max [{unit}]", hi
