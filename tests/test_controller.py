"""The controllers as the compiled loop runs them (flexlift.control), one sample at a time."""

import numpy as np
import pytest

from flexlift.ascent.plant import coupled_plant
from flexlift.control.build import controller_for, fuzzy_maps, shaped_pull
from flexlift.control.controller import sample
from flexlift.control.reference import trapezoid
from flexlift.fuzzy.rulebase import supervisor_fis
from flexlift.fuzzy.tables import Table2D


def test_trapezoid_reaches_target_gently():
    tau = np.linspace(0, 2000, 20001)
    pv = np.array([trapezoid(t, 300.0, 0.2, 0.002) for t in tau])
    pos, vel = pv[:, 0], pv[:, 1]
    assert pos[-1] == pytest.approx(300.0) and pos[0] == 0.0
    assert vel.max() == pytest.approx(0.2)
    assert np.abs(np.diff(vel) / np.diff(tau)).max() <= 0.002 + 1e-9
    np.testing.assert_allclose(np.gradient(pos, tau), vel, atol=2e-3)  # v is dz/dt
    short = np.array([trapezoid(t, 1.0, 0.2, 0.002) for t in (0.0, 50.0, 1000.0)])
    assert short[-1, 0] == pytest.approx(1.0) and short[:, 1].max() < 0.2
    assert trapezoid(100.0, -10.0, 0.2, 0.002)[0] < 0  # downward moves are signed


def test_shaped_pull_puts_the_resultant_on_the_suction_centroid():
    x = np.array([7.09, 28.37, 49.65, 70.93])
    xc = 78.02 * 7 / 12  # centroid of a linear shape 0.5..1.5
    p = shaped_pull(100.0, x, xc)
    assert p.sum() == pytest.approx(100.0)
    assert (p @ x) / p.sum() == pytest.approx(xc)
    assert np.all(np.diff(p) > 0)  # more pull towards the bow, where the suction is


def test_lookup_table_matches_exact_inference():
    fis = supervisor_fis()
    table = Table2D.sample(fis, 201)
    x = np.random.default_rng(1).uniform(-1.2, 1.2, size=(400, 2))
    assert np.abs(table(x) - fis(np.clip(x, -1, 1))).max() < 1e-3
    assert table(np.array([0.3, -0.2])) == pytest.approx(float(fis(np.array([0.3, -0.2]))), abs=1e-3)


@pytest.fixture(scope="module")
def plant(tanker):
    return coupled_plant(tanker)


def _controller(scenario, plant, mode="decentralized"):
    table, _, fill = fuzzy_maps(scenario)
    return controller_for(scenario, plant, mode, table, fill)


def _step(C, S, t, z, zd, V, separated):
    n = C.bags.size
    sample(t, np.broadcast_to(z, n).astype(float).copy(), np.broadcast_to(zd, n).astype(float).copy(),
           np.broadcast_to(V, n).astype(float).copy(), np.full(n, separated), C, S)
    return S


def test_breakout_pull_then_a_neutral_supervisor(tanker, plant):
    """The pull on top of the neutral volumes: shared equally (shape_breakout_pull false), or
    shaped like the suction (the default): the same total, its centroid on the hold's."""
    pull = 150e3 / 1025.0  # m3 in all
    for shaped in (False, True):
        sc = tanker.with_changes(**{"control.shape_breakout_pull": shaped})
        C, S = _controller(sc, plant)
        Vn = C.V_neutral
        _step(C, S, 0.0, 0.0, 0.0, Vn, False)
        extra = S.V_d - Vn
        assert extra.sum() == pytest.approx(pull, rel=1e-9)
        if shaped:
            xs, strips = plant.strip_x, plant.strips
            hold = float(np.sum(strips.weight * strips.hold * xs))
            assert float(extra @ C.x) / pull == pytest.approx(hold, rel=1e-6)
            assert np.ptp(extra) > 1.0  # not equal shares: the tanker's hold is not centred
        else:
            np.testing.assert_allclose(extra, pull / 4)
        assert np.all(S.fill > 0) and np.all(S.opening == 0)
        _step(C, S, 1.0, 0.0, 0.0, Vn, True)  # separated at the reference, no excess
        np.testing.assert_allclose(S.z_ref, 0.0)
        assert np.all(np.abs(S.u) < 1e-6)


def test_purge_on_excess_with_anti_windup(tanker, plant):
    C, S = _controller(tanker, plant)
    V = C.V_neutral
    _step(C, S, 0.0, 0.0, 0.0, V, True)
    integ = []
    for k in range(1, 200):
        _step(C, S, 0.1 * k, 0.0, 0.0, V + 120.0, True)
        integ.append(S.integ.copy())
        assert np.all(S.fill == 0)
    assert np.all(S.opening == 1.0)  # saturated open
    np.testing.assert_array_equal(integ[-1], integ[0])  # no windup while saturated
    _step(C, S, 30.0, 0.0, 0.0, V - 50.0, True)  # too little gas: fill takes over
    assert np.all(S.fill > 0) and np.all(S.opening == 0)


def test_open_loop_never_purges(tanker, plant):
    C, S = _controller(tanker, plant, "open-loop")
    for k in range(50):
        _step(C, S, 0.1 * k, 0.0, 1.0, C.V_neutral + 200.0, True)
        assert np.all(S.opening == 0) and np.all(S.fill == 0)


@pytest.mark.parametrize("what", ["angle", "rate"])
def test_coordination_levels_a_pitching_hull(tanker, plant, what):
    """Bow up (or pitching bow-up): the bow bags are asked for less gas, the stern's for more."""
    C, S = _controller(tanker, plant, "coordinated")
    Cd, Sd = _controller(tanker, plant, "decentralized")
    x = C.x - C.x.mean()
    z, zd = (1e-3 * x, 0.0 * x) if what == "angle" else (0.0 * x, 1e-4 * x)
    for c, s in ((C, S), (Cd, Sd)):
        _step(c, s, 0.0, 0.0, 0.0, c.V_neutral, True)
        _step(c, s, 0.1, z, zd, c.V_neutral, True)
    corr = S.V_d - Sd.V_d
    assert np.all(np.sign(corr) == -np.sign(x))
    k = C.k_pitch * 1e-3 if what == "angle" else C.k_pitch_rate * 1e-4
    np.testing.assert_allclose(corr, -k * C.lever, rtol=0.05)


def test_the_neutral_volume_adapts_to_a_steady_error(tanker, plant):
    sc = tanker.with_changes(**{"control.height_integral_gain_m2_s": 0.05})
    C, S = _controller(sc, plant)
    _step(C, S, 0.0, 0.0, 0.0, C.V_neutral, True)

    def below(k, d):  # d metres below the reference at sample k
        return trapezoid(0.1 * k, 300.0, 0.2, 0.002)[0] - d

    for k in range(1, 101):  # 10 s one metre below the reference: 0.05 m3 per m and s
        _step(C, S, 0.1 * k, below(k, 1.0), 0.0, C.V_neutral, True)
    np.testing.assert_allclose(S.adapt, 0.05 * 1.0 * 10.0, rtol=1e-9)
    for k in range(101, 16101):  # it never exceeds the supervisor's authority
        _step(C, S, 0.1 * k, below(k, 1.0), 0.0, C.V_neutral, True)
    np.testing.assert_allclose(S.adapt, C.dV_max)
    C, S = _controller(sc, plant)  # far from the reference (a transient): no adaptation
    _step(C, S, 0.0, 0.0, 0.0, C.V_neutral, True)
    for k in range(1, 101):
        _step(C, S, 0.1 * k, below(k, 3.0), 0.0, C.V_neutral, True)
    np.testing.assert_array_equal(S.adapt, 0.0)


def test_the_measurement_filter_lags_a_step(tanker, plant):
    sc = tanker.with_changes(**{"control.measurement_filter_s": 2.0})
    C, S = _controller(sc, plant)
    _step(C, S, 0.0, 0.0, 0.0, C.V_neutral, True)
    for k in range(1, 21):  # 2 s after a 1 m step: 1 - 1/e of it
        _step(C, S, 0.1 * k, 1.0, 0.0, C.V_neutral, True)
    np.testing.assert_allclose(S.z_f, 1.0 - np.exp(-1.0), rtol=1e-9)
