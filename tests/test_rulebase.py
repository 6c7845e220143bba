"""The supervisory FIS of docs/theory/control.md#rule-table and the SIFSMC fill map: oracle scikit-fuzzy, symmetry, bounds."""

import math

import numpy as np
import pytest
import skfuzzy

from flexlift.errors import InputError
from flexlift.fuzzy.fis import to_skfuzzy
from flexlift.fuzzy.rulebase import LABELS, SUPERVISOR_TABLE, fill_fis, supervisor_fis


@pytest.fixture(scope="module")
def fis():
    return supervisor_fis()


def test_rule_table_is_the_spec_table(fis):
    # docs/theory/control.md#rule-table's table is u = clip(i_e + i_edot - 3) in label indices (NB = 0 ... PB = 6)
    for row, outs in SUPERVISOR_TABLE.items():
        i = LABELS.index(row)
        assert [LABELS.index(o) for o in outs] == [min(max(i + j - 3, 0), 6) for j in range(7)]
    assert len(fis.rules) == 49
    assert {(r.antecedent, r.consequent) for r in fis.rules} == {
        ((i, j), min(max(i + j - 3, 0), 6)) for i in range(7) for j in range(7)}


def test_sets_cross_at_one_half(fis):
    for var in (*fis.inputs, fis.output):
        assert var.range == (-1.0, 1.0)
        centres = [m.params[1] for m in var.mfs]
        np.testing.assert_allclose(centres, np.linspace(-1, 1, 7), atol=1e-15)
        for a, b in zip(var.mfs, var.mfs[1:]):
            mid = 0.5 * (a.params[1] + b.params[1])
            assert a(mid) == pytest.approx(0.5, rel=1e-12)
            assert b(mid) == pytest.approx(0.5, rel=1e-12)
        assert var.mfs[0].params[0] == pytest.approx((1 / 3) / (2 * math.sqrt(2 * math.log(2))))


def test_defaults_and_firing_strengths(fis):
    assert (fis.and_method, fis.or_method, fis.implication, fis.aggregation,
            fis.defuzzification, fis.resolution) == ("min", "max", "min", "max", "centroid", 101)
    k = [r.antecedent for r in fis.rules]
    w = fis.firing_strengths([0.0, 0.0])
    assert w[k.index((3, 3))] == 1.0  # ZE, ZE
    assert w[k.index((4, 3))] == pytest.approx(0.5 ** 4)  # PS one spacing away: exp(-4 ln 2)
    w = fis.firing_strengths([1 / 6, 0.0])  # half-way between ZE and PS: the 0.5 crossing
    assert w[k.index((3, 3))] == pytest.approx(0.5) and w[k.index((4, 3))] == pytest.approx(0.5)
    assert fis.firing_strengths(np.zeros((5, 2))).shape == (5, 49)
    assert fis([0.0, 0.0]) == pytest.approx(0.0, abs=1e-15)


@pytest.mark.parametrize(
    "options",
    [{}, {"and_method": "prod", "or_method": "probor", "implication": "prod",
          "aggregation": "probor"}, {"aggregation": "sum"}, {"defuzzification": "centroid_trapz"},
     {"defuzzification": "mom"}],
)
def test_symmetry_u_of_minus_is_minus_u(options):
    f = supervisor_fis(**options)
    p = np.random.default_rng(11).uniform(-1.2, 1.2, (500, 2))
    np.testing.assert_allclose(f(-p), -f(p), atol=1e-12)


def test_monotone_along_the_diagonal(fis):
    # at the set centres the table's diagonal NB NB NM ZE PM PB PB is monotone, and so is u
    c = np.linspace(-1, 1, 7)
    at_centres = fis(np.column_stack([c, c]))
    assert np.all(np.diff(at_centres) >= -1e-12) and at_centres[3] == pytest.approx(0, abs=1e-12)
    # between them u rises strictly over |t| <= 0.75; near the saturated corners the centroid of
    # the clipped PB (NB) set overshoots by about 1 % of full scale (a documented property)
    t = np.linspace(-1, 1, 801)
    diag = fis(np.column_stack([t, t]))
    inner = np.abs(t) <= 0.75
    assert np.all(np.diff(diag[inner]) > 0)
    assert np.max(np.maximum.accumulate(diag) - diag) < 0.015
    assert diag[0] < -0.85 and diag[-1] > 0.85


def test_agrees_with_scikit_fuzzy_control_system(fis):
    from skfuzzy.control.controlsystem import CrispValueCalculator

    pts = np.random.default_rng(5).uniform(-1, 1, (40, 2))
    # the antecedent universe holds the test points: scikit-fuzzy's memberships exact there
    sim, out = to_skfuzzy(fis, np.union1d(np.linspace(-1, 1, 201), pts.ravel()))
    ours = fis.aggregate(pts)
    trapz = fis.with_options(defuzzification="centroid_trapz")(pts)
    y = fis.output_grid
    gaps = []
    for k, (e, edot) in enumerate(pts):
        sim.input["e"], sim.input["edot"] = e, edot
        sim.compute()
        universe, curve, _ = CrispValueCalculator(out, sim).find_memberships()
        on_grid = curve[np.isin(universe, y)]  # skfuzzy inserts the cut crossings; keep the grid
        np.testing.assert_allclose(ours[k], on_grid, rtol=1e-9, atol=1e-15)
        assert trapz[k] == pytest.approx(skfuzzy.defuzz(y, on_grid, "centroid"), rel=1e-9,
                                         abs=1e-12)
        gaps.append(abs(sim.output["u"] - trapz[k]))
    # skfuzzy's own answer adds the cut crossings to the grid before its trapezoid centroid
    assert max(gaps) < 2e-3


def test_agrees_with_scikit_fuzzy_functions_many_points():
    pts = np.random.default_rng(6).uniform(-1, 1, (300, 2))
    for options in ({}, {"and_method": "prod", "implication": "prod"}):
        fis = supervisor_fis(defuzzification="centroid_trapz", **options)
        y = fis.output_grid
        outs = [skfuzzy.gaussmf(y, m.params[1], m.params[0]) for m in fis.output.mfs]
        u = fis(pts)
        for k, (e, edot) in enumerate(pts):
            agg = np.zeros_like(y)
            for r in fis.rules:
                me = skfuzzy.gaussmf(np.array([e]), fis.inputs[0].mfs[r.antecedent[0]].params[1],
                                     fis.inputs[0].mfs[r.antecedent[0]].params[0])[0]
                md = skfuzzy.gaussmf(np.array([edot]),
                                     fis.inputs[1].mfs[r.antecedent[1]].params[1],
                                     fis.inputs[1].mfs[r.antecedent[1]].params[0])[0]
                if options:
                    agg = np.fmax(agg, me * md * outs[r.consequent])
                else:
                    agg = np.fmax(agg, np.fmin(min(me, md), outs[r.consequent]))
            assert u[k] == pytest.approx(skfuzzy.defuzz(y, agg, "centroid"), rel=1e-9, abs=1e-12)


def test_interpolated_surface_within_its_bound(fis):
    surf = fis.surface(grid=41)
    assert surf.u.shape == (41, 41) and surf.n_checked > 25_000
    assert 0 < surf.max_error < 0.05
    q = np.random.default_rng(99).uniform(-1, 1, (20_000, 2))
    assert np.max(np.abs(surf(q) - fis(q))) <= surf.error_bound
    # on the grid nodes the table is exact
    assert surf([surf.x0[7], surf.x1[30]]) == pytest.approx(fis([surf.x0[7], surf.x1[30]]),
                                                            abs=1e-14)
    assert surf([3.0, -3.0]) == surf([1.0, -1.0])
    with pytest.raises(InputError):
        surf([np.nan, 0.0])


def test_fill_map_monotone_zero_below_and_full_at_one():
    fill = fill_fis()
    d = np.linspace(-1.5, 1.5, 3001)
    v = fill(d)
    assert v.shape == d.shape
    assert np.all(np.diff(v) >= 0)
    assert np.all(v[d <= 0] == 0.0)
    assert fill(1.0) == 1.0 and fill(2.0) == 1.0
    assert 0.0 < fill(0.05) < fill(0.5) < 1.0
    assert np.all((v >= 0) & (v <= 1))
    np.testing.assert_array_equal(fill(d[:, None]), v)
    with pytest.raises(InputError):
        fill(np.array([0.1, np.nan]))


def test_fill_map_monotone_by_construction_whatever_the_rounding():
    # a centroid computed on another CPU may wiggle by 1e-16 (issue 10: -1.1e-16 steps on a
    # fresh install); the map must stay monotone whatever the rounding of the exact system
    exact = fill_fis().fis
    rng = np.random.default_rng(3)

    def wiggly(x):
        v = np.asarray(exact(x), dtype=float)
        return v + 1e-15 * rng.standard_normal(v.shape)

    from flexlift.fuzzy.rulebase import FillMap

    fill = FillMap(wiggly)
    d = np.linspace(-1.5, 1.5, 30001)
    assert np.all(np.diff(fill(d)) >= 0.0)
    assert fill(0.0) == 0.0 and fill(1.0) == 1.0


def test_fill_map_table_is_the_exact_centroid_to_1e4():
    fill = fill_fis()
    d = np.random.default_rng(4).uniform(0.0, 1.0, 500)
    exact = np.maximum(fill.fis(d), 0.0) / fill.fis(1.0)
    assert np.max(np.abs(fill(d) - exact)) < 1e-4
