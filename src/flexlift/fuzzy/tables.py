"""Lookup tables of sampled fuzzy maps: the one table class the compiled loop reads.

Exact Mamdani inference costs tens of microseconds per point; the ascent samples its fuzzy
systems once into these tables and interpolates (bilinear in 2-D, linear in 1-D), within
1e-3 of exact inference on the built-in supervisor (tested). A table is immutable data; its
lookup is a compiled function that Python callers and the compiled loop share.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexlift._jit import inline_jit, jit


@inline_jit
def bilinear(values, lo0, hi0, lo1, hi1, x0, x1):
    """Bilinear interpolation in ``values`` (n0, n1), sampled evenly over [lo0, hi0] x
    [lo1, hi1], at (x0, x1) (floats; saturated to the box; NaN in, NaN out)."""
    if x0 != x0 or x1 != x1:
        return np.nan
    n0, n1 = values.shape
    s0 = (x0 - lo0) / (hi0 - lo0) * (n0 - 1)
    s1 = (x1 - lo1) / (hi1 - lo1) * (n1 - 1)
    s0 = min(max(s0, 0.0), n0 - 1 - 1e-9)
    s1 = min(max(s1, 0.0), n1 - 1 - 1e-9)
    i, j = int(s0), int(s1)
    f0, f1 = s0 - i, s1 - j
    c00, c10 = values[i, j], values[i + 1, j]
    c01, c11 = values[i, j + 1], values[i + 1, j + 1]
    lo = c00 + f0 * (c10 - c00)
    return lo + f1 * (c01 + f0 * (c11 - c01) - lo)


@inline_jit
def linear(values, lo, hi, x):
    """Linear interpolation in ``values`` (n,), sampled evenly over [lo, hi], at ``x`` (a
    float; saturated; NaN in, NaN out). O(1): numba's ``np.interp`` validates the whole table
    on every scalar call, which made it the most expensive line of a control sample."""
    if x != x:
        return np.nan
    n = values.size
    s = max((x - lo) / (hi - lo) * (n - 1), 0.0)
    if s >= n - 1:
        return values[n - 1]
    i = int(s)
    return values[i] + (s - i) * (values[i + 1] - values[i])


@jit
def _linear_many(values, lo, hi, x, out):
    for k in range(x.size):
        out[k] = linear(values, lo, hi, x[k])
    return out


@jit
def _bilinear_many(values, lo0, hi0, lo1, hi1, x0, x1, out):
    for k in range(x0.size):
        out[k] = bilinear(values, lo0, hi0, lo1, hi1, x0[k], x1[k])
    return out


@dataclass(frozen=True)
class Table2D:
    """A two-input map sampled on an even ``grid`` x ``grid`` lattice over ``box``
    ((lo0, hi0), (lo1, hi1)); ``table(x)`` with x (n, 2) or (2,) interpolates bilinearly."""

    values: np.ndarray
    box: tuple[tuple[float, float], tuple[float, float]] = ((-1.0, 1.0), (-1.0, 1.0))

    @classmethod
    def sample(cls, fn, grid: int = 201, box=((-1.0, 1.0), (-1.0, 1.0))) -> Table2D:
        """Sample ``fn`` (points (n, 2) -> values (n,)) on a ``grid`` x ``grid`` lattice."""
        a = np.linspace(*box[0], grid)
        b = np.linspace(*box[1], grid)
        A, B = np.meshgrid(a, b, indexing="ij")
        vals = np.asarray(fn(np.column_stack([A.ravel(), B.ravel()])), dtype=float)
        return cls(vals.reshape(grid, grid).copy(), (tuple(box[0]), tuple(box[1])))

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        pts = np.atleast_2d(x)
        (a0, b0), (a1, b1) = self.box
        out = _bilinear_many(self.values, a0, b0, a1, b1, np.ascontiguousarray(pts[:, 0]),
                             np.ascontiguousarray(pts[:, 1]), np.empty(pts.shape[0]))
        return float(out[0]) if x.ndim == 1 else out


@dataclass(frozen=True)
class Table1D:
    """A one-input map sampled evenly over ``box`` (lo, hi); ``table(x)`` interpolates linearly
    (x a float or an array; saturated to the box)."""

    values: np.ndarray
    box: tuple[float, float] = (0.0, 1.0)

    def __call__(self, x):
        x = np.asarray(x, dtype=float)
        flat = np.ascontiguousarray(x.ravel())
        out = _linear_many(self.values, self.box[0], self.box[1], flat, np.empty(flat.size))
        return float(out[0]) if x.ndim == 0 else out.reshape(x.shape)
