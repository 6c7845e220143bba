"""A balanced layout of the external bags (docs/theory/strength.md#balance): the lift centroid on the centre of gravity
of what the bags carry, and a small static bending moment.

The load the external bags must balance is the submerged weight (distributed like the mass,
point masses included) less the internal bags' lift over their spans: the state in which the
bags hold the structure through the ascent, each external bag carrying an equal share. (The
breakout pull on top of it is shaped like the suction by the controllers.) With n equal bags:

1. **Equal shares.** The hull is cut into n segments that each carry 1/n of that load, and a
   bag goes to each segment's load centroid. The bags then close the force and the moment
   (their lift centroid is the load's centroid) and each carries its own stretch, which keeps
   the bending moment small.
2. **Least squares.** The positions are refined to minimise the mean square static bending
   moment along the hull (``scipy.optimize.minimize``, SLSQP) with the lift centroid held on
   the centre of gravity and every bag on the hull.
3. **Clusters.** Bags closer together than a bag's diameter share one lift point, at their
   mean position (the moment is unchanged): a heavy engine room gets a cluster, not bags
   jammed side by side.

Positions are in metres anywhere along the hull; nothing is snapped to the mesh.
"""

from __future__ import annotations

import numpy as np

from flexlift._threads import one_blas_thread
from flexlift.loads.strength import shear_moment

#: grid points along the hull for the load and the bending moment
GRID = 2001


def design_load(hull, weight_per_length, point_weight, internal_spans, internal_lift,
                factor: float) -> tuple[np.ndarray, np.ndarray, list[tuple[float, float]]]:
    """The downward load the external bags balance: (x [m], line load [N/m], point loads
    [(x, N)]), down positive; ``weight_per_length`` (n_el,) [N/m] and ``point_weight``
    (n_nodes,) [N] the submerged weight, times ``factor``; the internal bags' ``internal_lift``
    [N] each over ``internal_spans`` [(x0, x1)] taken off."""
    L = hull.length
    x = np.linspace(0.0, L, GRID)
    q = factor * weight_per_length[hull.element_of(x)]
    for (a, b), F in zip(internal_spans, internal_lift):
        q = q - np.where((x >= a) & (x <= b), F / (b - a), 0.0)
    points = [(float(xn), float(factor * w)) for xn, w in zip(hull.x_nodes, point_weight) if w > 0]
    return x, q, points


def equal_share_positions(x: np.ndarray, q: np.ndarray, points, n: int) -> np.ndarray:
    """Load centroids of ``n`` segments of equal load [m] (step 1 of the module docstring);
    where the net load is negative (internal lift above the weight) it counts as none."""
    qp = np.maximum(q, 0.0)
    dC = 0.5 * (qp[1:] + qp[:-1]) * np.diff(x)
    dM = 0.5 * (qp[1:] * x[1:] + qp[:-1] * x[:-1]) * np.diff(x)
    cells = [(xm, c, m) for xm, c, m in zip(0.5 * (x[1:] + x[:-1]), dC, dM)]
    cells += [(xp, F, F * xp) for xp, F in points if F > 0]
    cells.sort(key=lambda c: c[0])
    C = np.array([c[1] for c in cells])
    Mx = np.array([c[2] for c in cells])
    total = C.sum()
    edges = np.linspace(0.0, total, n + 1)
    if total <= 0:
        return np.sort(x[0] + (np.arange(n) + 0.5) * (x[-1] - x[0]) / n)
    # the first moment of the load up to a level of the cumulative load, each cell's share
    # taken in proportion (piecewise linear between the cells' ends); a segment's centroid is
    # its moment over its load
    keep = C > 0
    cum = np.concatenate(([0.0], np.cumsum(C[keep])))
    moment = np.interp(edges, cum, np.concatenate(([0.0], np.cumsum(Mx[keep]))))
    return np.sort(np.diff(moment) / np.diff(edges))


def static_moment(x, q_down, points_down, bag_x, bag_lift):
    """(shear [N], bending moment [N m]) along ``x`` under the net design load of
    :func:`design_load` (down; the internal bags already in it) and the external bags (up)."""
    pts = [(xp, -F) for xp, F in points_down] + [(float(b), float(bag_lift)) for b in bag_x]
    return shear_moment(x, -q_down, pts)


#: the most bags whose positions :func:`refine` optimises (more: the equal-load centroids)
MAX_REFINED = 60


def moment_cost(x, M0, p, bag_lift: float) -> tuple[float, np.ndarray]:
    """(mean square moment [N^2 m^2], its gradient in the bag positions ``p`` [N^2 m]) with
    bags of ``bag_lift`` [N] at ``p`` added to ``M0``, the moment along ``x`` (ascending)
    without them (the bags' term of :func:`~flexlift.loads.strength.shear_moment`:
    F max(x - p, 0)). By sorted sums, O(len(x) + n log n), not the (len(x), n) arrays: at x
    the k bags below it add F (k x - their positions' sum); bag j's gradient is -2 F / len(x)
    times the sum of M over the points above it."""
    ps = np.sort(p)
    k = np.searchsorted(ps, x, side="left")  # bags strictly below each point
    below_sum = np.concatenate(([0.0], np.cumsum(ps)))
    M = M0 + bag_lift * (k * x - below_sum[k])
    above = np.concatenate((np.cumsum(M[::-1])[::-1], [0.0]))  # sum of M from each point on
    first_above = np.searchsorted(x, p, side="right")
    return float(np.mean(M**2)), -2.0 * bag_lift * above[first_above] / x.size


def refine(x, q, points, start: np.ndarray, bag_lift: float, x_target_moment: float,
           length: float) -> np.ndarray:
    """Positions minimising the mean square static moment (step 2), the bags' first moment
    kept at ``x_target_moment`` [N m] (their lift centroid on the centre of gravity)."""
    if start.size > MAX_REFINED:
        return start  # SLSQP's dense steps grow as n^3: the equal-load centroids stand
    from scipy.optimize import minimize  # here: importing it costs 0.3 s, most runs never do

    x = np.asarray(x, dtype=float)
    _, M0 = static_moment(x, q, points, [], bag_lift)  # the moment without the bags

    def cost(p):
        return moment_cost(x, M0, p, bag_lift)[0]

    scale = cost(start) or 1.0
    with one_blas_thread():  # tens of unknowns: BLAS threads only wait (flexlift._threads)
        res = minimize(lambda p: cost(p) / scale, start,
                       jac=lambda p: moment_cost(x, M0, p, bag_lift)[1] / scale, method="SLSQP",
                       bounds=[(0.0, length)] * start.size,
                       constraints=[{"type": "eq",
                                     "fun": lambda p: (bag_lift * p.sum() - x_target_moment)
                                     / (bag_lift * length),
                                     "jac": lambda p: np.ones_like(p) / length}],
                       options={"maxiter": 200, "ftol": 1e-10})
    p = np.sort(res.x) if res.success and cost(res.x) <= cost(start) else start
    return p


def clusters(positions: np.ndarray, min_spacing: float) -> list[tuple[float, int]]:
    """Lift points (x [m], number of bags) merging bags closer than ``min_spacing`` [m]."""
    groups: list[list[float]] = []  # [sum of positions, count] of each lift point
    for p in np.sort(positions):
        if groups and p - groups[-1][0] / groups[-1][1] < min_spacing:
            groups[-1][0] += float(p)
            groups[-1][1] += 1
        else:
            groups.append([float(p), 1])
    return [(total / count, int(count)) for total, count in groups]
