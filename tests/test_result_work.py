"""The per-case work of a run's result: the strength grid found by bisection (the same points
as the np.isclose scan it replaces), kept per plant, and the same result either way."""

import math
from pathlib import Path

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import strength as S
from flexlift.ascent.plant import coupled_plant

TRAWLER = Path(__file__).parent / "data" / "trawler.yaml"


def _scan_grid(plant):
    """The strength grid as it was built before (every end point found by np.isclose)."""
    hull = plant.hull
    L = hull.length
    n_out = min(8 * hull.n_elements, S.MAX_POINTS - 1)
    refine = int(np.clip(math.ceil(S.POINTS_PER_HALF_WAVE * (plant.modal.nr - 1) / n_out), 1,
                         S.MAX_REFINE))
    base = np.linspace(0.0, L, n_out * refine + 1)
    spans = {float(e) for s in plant.spans if s is not None for e in s if 0 < e < L}
    cells = {float(e) for e in S.strip_cells(plant)[1:-1] if 0 < e < L}
    ends = sorted(spans | cells)
    x = np.sort(np.concatenate([base, ends, ends]))
    side, stored = np.zeros_like(x), np.zeros(x.size, dtype=bool)
    for e in ends:
        k = np.flatnonzero(np.isclose(x, e))
        side[k[0]], side[k[-1]] = -1.0, 1.0
        stored[k] = e in spans
    stored[np.searchsorted(x, base[::refine])] = True
    return x, np.clip(x + side * 1e-9 * L, 0.0, L), np.flatnonzero(stored)


@pytest.mark.parametrize("name", ["tanker", "pipeline", str(TRAWLER)])
def test_the_strength_grid_is_the_scanned_one(name):
    plant = coupled_plant(load_scenario(name))
    for got, want in zip(S.plant_grid(plant), _scan_grid(plant)):
        np.testing.assert_array_equal(got, want)


def test_the_grid_is_kept_for_its_plant_only():
    tanker, pipeline = (coupled_plant(load_scenario(n)) for n in ("tanker", "pipeline"))
    first = S.strength_grid(tanker)
    assert S.strength_grid(tanker) is first  # asked again: kept
    other = S.strength_grid(pipeline)
    assert other[0].size != first[0].size or not np.array_equal(other[0], first[0])
    np.testing.assert_array_equal(S.strength_grid(tanker)[0], first[0])  # rebuilt, the same
    assert not first[0].flags.writeable
