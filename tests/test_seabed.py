import numpy as np
import pytest

from flexlift.seabed import SeabedModel, contact_load

H0 = 8.0e6


def _integrate_held(sb, U, dt=0.05):
    """Time until U > H under a constant uplift, by explicit integration of SPEC §6."""
    H, t = sb.H0, 0.0
    while U <= H:
        H += dt * float(sb.held_rate(U))
        t += dt
    return t


@pytest.mark.parametrize("frac", [0.1, 0.25, 0.5, 0.9])
def test_breakout_time_scales_with_pull(frac):
    sb = SeabedModel(H0=H0, breakout_time=400.0)
    U = frac * H0
    expected = 400.0 * (1.0 / frac - 1.0)  # T_b (H0 / U - 1)
    assert sb.separation_time(U) == pytest.approx(expected)
    assert _integrate_held(sb, U) == pytest.approx(expected, abs=0.1)


def test_full_pull_and_no_pull():
    sb = SeabedModel(H0=H0, breakout_time=400.0)
    assert sb.separation_time(H0 * 1.5) == 0.0
    assert sb.separation_time(0.0) == float("inf")
    assert float(sb.held_rate(-1e6)) == 0.0
    # a full pull decays H at H0 / T_b
    assert float(sb.held_rate(2 * H0)) == pytest.approx(-H0 / 400.0)


def test_release_and_complete():
    sb = SeabedModel(H0=H0, release_time=30.0)
    assert float(sb.released_rate(1000.0)) == pytest.approx(-1000.0 / 30.0)
    assert sb.complete(0.9e-3 * H0) and not sb.complete(1.1e-3 * H0)


def test_holding_shape_linear_half_to_one_and_a_half():
    sb = SeabedModel(H0=H0)
    L = 78.0
    x = np.linspace(0, L, 100001)
    s = sb.shape(x, L)
    assert np.trapezoid(s, x) == pytest.approx(1.0, rel=1e-9)
    assert s[0] * L == pytest.approx(0.5) and s[-1] * L == pytest.approx(1.5)


def test_contact_one_sided_and_bilateral():
    w = np.array([-0.01, 0.0, 0.02, -0.001])
    v = np.array([0.0, 0.0, 0.0, 0.1])  # the last point is lifting off fast: no suction pull
    q, active = contact_load(w, v, 5e6, 2e6, bilateral=False)
    np.testing.assert_allclose(q, [5e4, 0.0, 0.0, 0.0])
    assert active.tolist() == [True, False, False, False]
    qb, _ = contact_load(w, v, 5e6, 2e6, bilateral=True)
    np.testing.assert_allclose(qb, -5e6 * w - 2e6 * v)
