"""Loads, consistent nodal loads and the statics of shear force and bending moment."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from flexlift import constants as C
from flexlift.errors import InputError
from flexlift.loads.strength import (
    LineLoad,
    LoadCase,
    PointLoad,
    bag_load_matrix,
    lift_load_case,
    line_load_on_grid,
    line_load_vector,
    nodal_loads,
    point_load_vector,
    resultant_of,
    sample_grid,
    shear_moment,
    strength,
)
from flexlift.structure.beam import assemble
from flexlift.structure.hull import Hull

L = 78.02
EI = 3.0e12


@pytest.fixture(scope="module")
def hull():
    return Hull.uniform(L, EI, 3.2e6 / L, 11)


def _cantilever_tip(hull, f):
    """Tip deflection and rotation of ``hull`` clamped at node 0 under nodal loads f."""
    K = assemble(hull).K.toarray()
    u = np.linalg.solve(K[2:, 2:], f[2:])
    return u[-2], u[-1]


# ----------------------------------------------------------------------------- nodal loads
@pytest.mark.parametrize("x", [0.0, 3.1, L / 11, 20.0, 40.123, L - 1e-3, L])
def test_point_load_vector_reproduces_resultant_and_moment(hull, x):
    F = -2.5e6
    f = point_load_vector(hull, x, F)
    assert f.shape == (2 * hull.n_nodes,)
    R, Mx = resultant_of(hull, f)
    assert R == pytest.approx(F, rel=1e-12)
    assert Mx == pytest.approx(F * x, rel=1e-12, abs=1e-6)
    # only the DOFs of one element are loaded
    assert np.count_nonzero(np.abs(f) > 1e-9 * abs(F)) <= 4


def test_point_load_vector_broadcasts_force_arrays(hull):
    F = np.array([1.0, -2.0, 3.5])
    f = point_load_vector(hull, 17.3, F)
    assert f.shape == (3, 2 * hull.n_nodes)
    np.testing.assert_allclose(f[1], -2.0 * point_load_vector(hull, 17.3, 1.0))


@pytest.mark.parametrize(
    "x0, x1, q0, q1",
    [
        (0.0, L, -4.5e5, None),  # whole beam
        (14.19, 63.83, 3.06e5, None),  # partial elements at both ends
        (20.0, 21.0, 1.0e5, None),  # inside one element
        (L / 11, 5 * L / 11, 2.0e5, None),  # on nodes
        (3.3, 70.1, 1.0e5, 3.0e5),  # linearly varying
        (0.0, L, 0.5, 1.5),  # the seabed holding shape
    ],
)
def test_line_load_vector_reproduces_resultant_and_moment(hull, x0, x1, q0, q1):
    f = line_load_vector(hull, x0, x1, q0, q1)
    d = LineLoad("q", x0, x1, q0, q1)
    qe = q0 if q1 is None else q1
    h = x1 - x0
    R_exact = 0.5 * (q0 + qe) * h
    # moment about x = 0 of a trapezoidal load, by direct (adaptive) integration
    Mx_exact = quad(lambda s: (q0 + (qe - q0) * (s - x0) / h) * s, x0, x1, epsabs=0)[0]
    R, Mx = resultant_of(hull, f)
    assert R == pytest.approx(R_exact, rel=1e-12)
    assert d.resultant == pytest.approx(R_exact, rel=1e-12)
    assert Mx == pytest.approx(d.moment_about_aft, rel=1e-12)
    assert Mx == pytest.approx(Mx_exact, rel=1e-12)


def test_uniform_load_on_one_element_gives_textbook_fixed_end_vector():
    hull = Hull.uniform(6.0, 1.0, 1.0, 1)
    q, l = 1000.0, 6.0
    f = line_load_vector(hull, 0.0, l, q)
    np.testing.assert_allclose(f, [q * l / 2, q * l**2 / 12, q * l / 2, -q * l**2 / 12])


def test_consistent_point_load_gives_exact_cantilever_deflection(hull):
    # Hermite elements with consistent loads are nodally exact for Euler-Bernoulli beams
    F, a = -1.0e6, 23.4  # inside element 4
    w, th = _cantilever_tip(hull, point_load_vector(hull, a, F))
    assert w == pytest.approx(F * a**2 * (3 * L - a) / (6 * EI), rel=1e-9)
    assert th == pytest.approx(F * a**2 / (2 * EI), rel=1e-9)


def test_consistent_partial_udl_gives_exact_cantilever_deflection(hull):
    q, a, b = 2.0e5, 10.0, 50.5  # both ends inside elements
    w, th = _cantilever_tip(hull, line_load_vector(hull, a, b, q))
    w_exact = q / (6 * EI) * (L * (b**3 - a**3) - (b**4 - a**4) / 4)
    th_exact = q * (b**3 - a**3) / (6 * EI)
    assert w == pytest.approx(w_exact, rel=1e-9)
    assert th == pytest.approx(th_exact, rel=1e-9)


def test_nodal_loads_bad_positions(hull):
    with pytest.raises(InputError, match="point load x"):
        point_load_vector(hull, L + 1.0, 1.0)
    with pytest.raises(InputError, match="line load span"):
        line_load_vector(hull, 10.0, 5.0, 1.0)
    with pytest.raises(InputError, match="must lie on the hull"):
        LoadCase(L, point_loads=(PointLoad("p", -2.0, 1.0),))


# ----------------------------------------------------------------------------- statics
def test_single_point_load():
    a, F = 30.0, 2.0e6
    x = np.linspace(0.0, L, 401)
    V, M = shear_moment(x, np.zeros_like(x), [(a, F)])
    np.testing.assert_allclose(V, np.where(x >= a, F, 0.0))
    np.testing.assert_allclose(M, F * np.clip(x - a, 0, None), atol=1e-6)
    assert V[-1] == F and M[-1] == pytest.approx(F * (L - a))


def test_udl_span():
    x0, x1, q = 14.19, 63.83, 3.0e5
    case = LoadCase(L, (LineLoad("q", x0, x1, q),))
    x = sample_grid(case, 11, 50)
    V, M = shear_moment(x, line_load_on_grid(case, x))
    xc = np.clip(x, x0, x1)
    V_exact = q * (xc - x0)
    M_exact = np.where(
        x <= x1, 0.5 * q * (xc - x0) ** 2, q * (x1 - x0) * (x - 0.5 * (x0 + x1))
    )
    np.testing.assert_allclose(V, V_exact, rtol=1e-12, atol=1e-6)
    np.testing.assert_allclose(M, M_exact, rtol=1e-12, atol=1e-4)


def test_uniform_beam_on_two_symmetric_supports_matches_textbook():
    w, a = 4.5e5, 16.0  # weight [N/m] down, supports at a and L - a
    R = w * L / 2
    case = LoadCase(
        L,
        (LineLoad("weight", 0.0, L, -w),),
        (PointLoad("left", a, R), PointLoad("right", L - a, R)),
    )
    st = strength(case, Hull.uniform(L, EI, 1.0, 11))
    x = st.x
    b = L - a
    V_exact = -w * x + R * (x >= a) + R * (x >= b)
    M_exact = -w * x**2 / 2 + R * np.clip(x - a, 0, None) + R * np.clip(x - b, 0, None)
    # the repeated samples at the supports hold the aft-side values: drop the R there
    first_of_pair = np.zeros(x.size, bool)
    first_of_pair[:-1] = x[:-1] == x[1:]
    V_exact[first_of_pair] -= R
    np.testing.assert_allclose(st.V, V_exact, atol=1e-6 * R)
    np.testing.assert_allclose(st.M, M_exact, atol=1e-9 * R * L)
    # textbook extremes: hogging -w a^2/2 over the supports, midship w L^2/8 - w L a/2
    assert st.max_hogging.value == pytest.approx(-w * a**2 / 2, rel=1e-12)
    mid = np.argmin(np.abs(x - L / 2))
    assert st.M[mid] == pytest.approx(w * L**2 / 8 - w * L * a / 2, rel=1e-12)
    assert abs(st.max_shear.value) == pytest.approx(max(w * a, R - w * a), rel=1e-12)
    assert st.closing_shear == pytest.approx(0.0, abs=1e-6 * R)
    assert st.closing_moment == pytest.approx(0.0, abs=1e-6 * R * L)


def _mixed_case():
    return LoadCase(
        L,
        (
            LineLoad("weight", 0.0, L, -4.0e5),
            LineLoad("tank", 12.3, 40.7, 2.1e5),
            LineLoad("ramp", 45.0, 77.0, 1.0e5, 3.0e5),
        ),
        (PointLoad("a", 5.5, 3.0e6), PointLoad("b", 33.3, 4.0e6), PointLoad("bow", L, 1.0e6)),
    )


def test_equilibrium_closing_values_equal_total_load_and_moment():
    case = _mixed_case()
    hull = Hull.uniform(L, EI, 1.0, 11)
    st = strength(case, hull)
    total = case.total_force
    assert st.closing_shear == pytest.approx(total, rel=1e-12)
    assert st.closing_moment == pytest.approx(total * L - case.moment_about_aft, rel=1e-10)
    # the consistent nodal vector carries the same resultant and moment
    R, Mx = resultant_of(hull, nodal_loads(hull, case))
    assert R == pytest.approx(total, rel=1e-12)
    assert Mx == pytest.approx(case.moment_about_aft, rel=1e-12)


def test_mirror_symmetry():
    case = _mixed_case()
    hull = Hull.uniform(L, EI, 1.0, 11)
    st, sm = strength(case, hull), strength(case.mirrored(), hull)
    # V_m(x) = F_tot - V(L - x);  M_m(x) = M(L - x) - (F_tot (L - x) - sum F s)
    xs = np.linspace(0.3, L - 0.3, 97)
    xs = xs[np.all(np.abs(xs[:, None] - np.array([5.5, 33.3, L - 5.5, L - 33.3])) > 1e-3, 1)]
    F, S = case.total_force, case.moment_about_aft
    Vm = np.interp(xs, sm.x, sm.V)
    Mm = np.interp(xs, sm.x, sm.M)
    np.testing.assert_allclose(Vm, F - np.interp(L - xs, st.x, st.V), atol=1e-6 * abs(F) + 1.0)
    np.testing.assert_allclose(
        Mm, np.interp(L - xs, st.x, st.M) - (F * (L - xs) - S), rtol=1e-5, atol=1e2
    )


def test_leading_dimensions_broadcast():
    x = np.linspace(0.0, L, 201)
    rng = np.random.default_rng(1)
    q = rng.normal(size=(5, x.size)) * 1e4
    F = rng.normal(size=5) * 1e5
    V, M = shear_moment(x, q, [(20.0, F), (50.0, 3.0e5)])
    assert V.shape == M.shape == (5, x.size)
    for k in range(5):
        Vk, Mk = shear_moment(x, q[k], [(20.0, F[k]), (50.0, 3.0e5)])
        np.testing.assert_allclose(V[k], Vk)
        np.testing.assert_allclose(M[k], Mk)
    # 1-D q with array forces broadcasts too
    V2, _ = shear_moment(x, q[0], [(20.0, F)])
    assert V2.shape == (5, x.size)


def test_moment_is_exact_integral_of_shear():
    # piecewise-linear q: M computed exactly, dM/dx = V checked by Simpson on a fine grid
    x = np.linspace(0.0, 10.0, 11)
    q = np.sin(x)
    V, M = shear_moment(x, q)
    xf = np.linspace(0.0, 10.0, 100001)
    qf = np.interp(xf, x, q)
    Vf, Mf = shear_moment(xf, qf)
    np.testing.assert_allclose(V, np.interp(x, xf, Vf), atol=1e-12)
    np.testing.assert_allclose(M, np.interp(x, xf, Mf), atol=1e-8)


def test_shear_moment_bad_input():
    x = np.linspace(0.0, 1.0, 5)
    with pytest.raises(InputError, match="non-decreasing"):
        shear_moment(x[::-1], np.zeros(5))
    with pytest.raises(InputError, match="last dimension"):
        shear_moment(x, np.zeros(4))
    with pytest.raises(InputError, match="point load x"):
        shear_moment(x, np.zeros(5), [(2.0, 1.0)])


def test_sample_grid_repeats_discontinuities():
    case = _mixed_case()
    x = sample_grid(case, 11, 50)
    assert np.all(np.diff(x) >= 0)
    for b in (12.3, 40.7, 45.0, 5.5, 33.3, L):
        assert np.count_nonzero(x == b) == 2
    assert np.count_nonzero(x == 0.0) == 1  # a span starting at the aft end is no jump
    assert x.size >= 11 * 50 + 1
    q = line_load_on_grid(case, x)
    k = np.nonzero(x == 12.3)[0]
    assert q[k[0]] == pytest.approx(-4.0e5) and q[k[1]] == pytest.approx(-1.9e5)


# ----------------------------------------------------------------------------- the tanker
def test_tanker_load_case(tanker_plan, tanker_hull):
    g = tanker_plan.gravity
    case = lift_load_case(tanker_plan, tanker_hull)
    weight = [d for d in case.line_loads if d.name == "weight"]
    assert len(weight) == 1
    assert weight[0].q0 == pytest.approx(-1.3 * tanker_plan.wet_weight / L, rel=1e-12)
    assert case.total_force == pytest.approx((7 * 517 - 1.3 * 2782.1656) * C.TONNE * g, rel=1e-4)
    ext = [p for p in case.point_loads]
    assert [p.name for p in ext] == ["bag_1", "bag_2", "bag_3", "bag_4"]
    # partial lift of one bag
    half = lift_load_case(tanker_plan, tanker_hull, bag_lifts={"bag_5": 0.0})
    assert half.total_force == pytest.approx(case.total_force - 517 * C.TONNE * g, rel=1e-9)
    with pytest.raises(InputError, match="bag_lifts"):
        lift_load_case(tanker_plan, tanker_hull, bag_lifts={"bag_99": 1.0})


def test_tanker_strength_against_hand_statics(tanker_plan, tanker_hull):
    plan, hull = tanker_plan, tanker_hull
    st = strength(lift_load_case(plan, hull), hull)
    xn = hull.x_nodes
    q_w = plan.required_lift / L
    F = plan.bag_lift
    p_int = 3 * F / (xn[9] - xn[2])  # internal bags: one uniform load over nodes 3..10

    def M_hand(x):  # moment of the forces aft of x, sagging positive
        m = -q_w * x**2 / 2
        m += sum(F * (x - xb) for xb in xn[[1, 4, 7, 10]] if xb < x)
        m += p_int * np.clip(x - xn[2], 0, xn[9] - xn[2]) * (
            x - 0.5 * (xn[2] + np.clip(x, xn[2], xn[9]))
        )
        return m

    for j in (1, 4, 6, 7, 11):
        k = np.argmin(np.abs(st.x - xn[j]))
        assert st.M[k] == pytest.approx(M_hand(xn[j]), rel=1e-9, abs=1.0)
    # the hull hogs over bag_2 (node 5) and, by symmetry, bag_3 (node 8)
    assert st.max_moment.node == 5 and st.max_moment.value < 0
    assert st.max_moment.value == pytest.approx(M_hand(xn[4]), rel=1e-9)
    assert abs(st.max_moment.value) / 1e6 == pytest.approx(44.27, abs=0.01)
    assert abs(st.max_shear.value) / 1e6 == pytest.approx(3.505, abs=0.001)
    assert st.max_shear.node == 8
    # closing values: the 2.18 t excess of 7 x 517 t over 1.3 W', acting symmetrically
    excess = (plan.total_lift - plan.required_lift)
    assert excess / (C.TONNE * plan.gravity) == pytest.approx(2.18, abs=0.01)
    assert st.closing_shear == pytest.approx(excess, rel=1e-9)
    assert st.closing_moment == pytest.approx(excess * L / 2, rel=1e-6)
    # mirror symmetry of the symmetric layout: V antisymmetric, M symmetric (up to the excess)
    xs = np.linspace(1.0, L - 1.0, 40)
    np.testing.assert_allclose(
        np.interp(xs, st.x, st.M) - excess * xs / 2,
        np.interp(L - xs, st.x, st.M) - excess * (L - xs) / 2,
        atol=1e-6 * abs(st.max_moment.value),
    )


def test_bag_load_matrix(tanker_plan, tanker_hull):
    B = bag_load_matrix(tanker_plan, tanker_hull)
    assert B.shape == (24, 7)
    for k, b in enumerate(tanker_plan.bags):
        R, Mx = resultant_of(tanker_hull, B[:, k])
        assert R == pytest.approx(1.0, rel=1e-12)
        assert Mx == pytest.approx(b.x, rel=1e-12)  # span centre for an internal bag
    lifts = np.array([b.lift for b in tanker_plan.bags])
    case = lift_load_case(tanker_plan, tanker_hull, weight_factor=0.0)
    np.testing.assert_allclose(B @ lifts, nodal_loads(tanker_hull, case), atol=1e-6)
