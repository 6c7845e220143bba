"""The balanced layout's sums (issue 24, the plan build under load): the equal-load
centroids from the cumulative load's first moment and the lift points from running sums
agree with the cell-by-cell and list-by-list forms they replace."""

from __future__ import annotations

import numpy as np
import pytest

from flexlift.loads import balance


def _centroids_cell_by_cell(x, q, points, n):
    """Each segment's centroid from each cell's share of it (the form replaced)."""
    qp = np.maximum(q, 0.0)
    dC = 0.5 * (qp[1:] + qp[:-1]) * np.diff(x)
    dM = 0.5 * (qp[1:] * x[1:] + qp[:-1] * x[:-1]) * np.diff(x)
    cells = sorted([(xm, c, m) for xm, c, m in zip(0.5 * (x[1:] + x[:-1]), dC, dM)]
                   + [(xp, F, F * xp) for xp, F in points if F > 0])
    C, Mx = np.array([c[1] for c in cells]), np.array([c[2] for c in cells])
    cum = np.cumsum(C)
    edges = np.linspace(0.0, C.sum(), n + 1)
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        frac = np.clip((np.minimum(cum, hi) - np.maximum(cum - C, lo))
                       / np.where(C > 0, C, 1.0), 0, 1)
        out.append((frac * Mx).sum() / (frac * C).sum())
    return np.sort(out)


@pytest.mark.parametrize("n", [1, 7, 25, 181, 362])
def test_equal_load_centroids_as_cell_by_cell(n):
    x = np.linspace(0.0, 78.0, 2001)
    q = 4e5 * (1.0 + 0.6 * np.sin(x / 9.0))
    q[(x > 30.0) & (x < 38.0)] = -2e5  # internal lift above the weight there: counts as none
    points = [(12.0, 3e6), (55.5, 8e6), (70.0, 0.0)]
    got = balance.equal_share_positions(x, q, points, n)
    want = _centroids_cell_by_cell(x, q, points, n)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    assert not ((got > 30.0) & (got < 38.0)).any() or n > 100


def test_lift_points_by_running_sums():
    rng = np.random.default_rng(3)
    p = np.sort(np.concatenate([rng.normal(c, 0.2, 15) for c in (5.0, 20.0, 24.0, 60.0)]))

    def by_lists(pos, spacing):
        groups = []
        for v in np.sort(pos):
            if groups and v - np.mean(groups[-1]) < spacing:
                groups[-1].append(float(v))
            else:
                groups.append([float(v)])
        return [(float(np.mean(g)), len(g)) for g in groups]

    got, want = balance.clusters(p, 1.5), by_lists(p, 1.5)
    assert [c for _, c in got] == [c for _, c in want] and len(got) == 4
    np.testing.assert_allclose([x for x, _ in got], [x for x, _ in want], rtol=1e-13)
