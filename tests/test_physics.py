"""Each physical law on its own, against hand values and textbook results (issue 11).

These are the functions the compiled ascent calls (flexlift.physics): a wrong coefficient here
fails here, and a wrong coefficient anywhere else fails the assembled-plant tests of
tests/test_plant.py.
"""

import math

import numpy as np
import pytest

from flexlift.ascent.records import Seabed
from flexlift.constants import P_ATM, R_GAS, RHO_SEAWATER, T_SEA
from flexlift.physics import gas, hydro, seabed

RG = RHO_SEAWATER * 9.81
RT = R_GAS * T_SEA
DEPTH = 350.0


def test_ambient_pressure_is_the_water_column_and_stops_at_the_surface():
    h = np.array([0.0, 100.0, 350.0, 400.0])
    p = gas.ambient_pressure(h, DEPTH, P_ATM, RG)
    np.testing.assert_allclose(p, [P_ATM + RG * 350, P_ATM + RG * 250, P_ATM, P_ATM])
    assert gas.ambient_pressure(100.0, DEPTH, P_ATM, RG) == pytest.approx(P_ATM + RG * 250)


def test_boyle_bag_raised_in_steps():
    """A fixed amount of gas raised from the seabed: p V constant, six-fold at 50 m (docs/theory/gas.md#boyle)."""
    heights = np.arange(0.0, 301.0, 50.0)
    p = gas.ambient_pressure(heights, DEPTH, P_ATM, RG)
    n = gas.moles_of(50.0, p[0], RT)
    V = gas.gas_volume(n, p, RT, 1e9)
    np.testing.assert_allclose(p * V, p[0] * 50.0, rtol=1e-12)
    assert 5.5 < V[-1] / V[0] < 6.5
    assert V[-1] == pytest.approx(n * R_GAS * 283.15 / (101325.0 + 1025.0 * 9.81 * 50.0), rel=1e-12)
    assert gas.gas_volume(n, p[0], RT, 20.0) == 20.0  # never more than the capacity


def test_spill_at_capacity_and_relief_at_its_setting():
    p = gas.ambient_pressure(300.0, DEPTH, P_ATM, RG)
    n = gas.moles_of(150.0, p, RT)  # 1.5 times a 100 m3 capacity at ambient
    open_out = gas.vented_moles(n, p, 100.0, 0.0, RT)
    assert (n - open_out) * RT / p == pytest.approx(100.0, rel=1e-12)  # keeps its capacity
    relief = 0.1e5
    closed_out = gas.vented_moles(n, p, 100.0, relief, RT)
    assert (n - closed_out) * RT / 100.0 == pytest.approx(p + relief, rel=1e-12)
    assert gas.vented_moles(0.5 * n, p, 100.0, 0.0, RT) == 0.0  # within capacity: nothing
    assert gas.moles_capacity(p, 100.0, relief, RT) == pytest.approx((p + relief) * 100 / RT)


def test_purge_orifice_law():
    """Q = u Q_max sqrt(V / V_max), the valve opening and the fill fraction saturated."""
    assert gas.purge_flow(1.0, 100.0, 100.0, 2.0) == pytest.approx(2.0)
    assert gas.purge_flow(0.5, 25.0, 100.0, 2.0) == pytest.approx(0.5 * 2.0 * 0.5)
    assert gas.purge_flow(0.3, 81.0, 100.0, 2.0) == pytest.approx(0.3 * 2.0 * 0.9)
    assert gas.purge_flow(2.0, 100.0, 100.0, 2.0) == pytest.approx(2.0)
    assert gas.purge_flow(-1.0, 100.0, 100.0, 2.0) == 0.0
    np.testing.assert_allclose(gas.purge_flow(np.array([1.0, 1.0]), np.array([4.0, 9.0]), 16.0, 1.0),
                               [0.5, 0.75])


def test_gas_rates_buoyancy_free_air_and_expansion():
    p = gas.ambient_pressure(0.0, DEPTH, P_ATM, RG)
    assert gas.moles_rate(p, 0.5, 0.2, RT) == pytest.approx(p * 0.3 / RT)
    assert gas.buoyancy(10.0, RG) == pytest.approx(10.0 * 1025 * 9.81)
    assert gas.free_air(1.0, p, P_ATM) == pytest.approx(p / P_ATM)
    # dV/dt = V rho g v / p, equal to the derivative of Boyle's V(h) at constant n
    n = gas.moles_of(100.0, p, RT)
    h, dh = 10.0, 1e-4
    dV = (gas.gas_volume(n, gas.ambient_pressure(h + dh, DEPTH, P_ATM, RG), RT, 1e9)
          - gas.gas_volume(n, gas.ambient_pressure(h - dh, DEPTH, P_ATM, RG), RT, 1e9)) / (2 * dh)
    ph = gas.ambient_pressure(h, DEPTH, P_ATM, RG)
    assert gas.expansion_rate(gas.gas_volume(n, ph, RT, 1e9), ph, RG, 0.2) == pytest.approx(0.2 * dV, rel=1e-6)


H0 = 8.0e6


def timer(breakout_time=400.0):
    """A seabed record of the timer law (the fields ``holding_rate`` reads)."""
    return Seabed(ng=1, hold_force=np.zeros((1, 1)), H0=np.array([H0]),
                  group_weight=np.zeros(1), breakout_time=breakout_time, release_time=30.0,
                  liftoff_clearance=0.1, law=seabed.LAW_TIMER, consolidation_time=1.0)


def rate(U, T_b=400.0):
    """The timer law's dH/dt under U (it does not read the hold left)."""
    return seabed.holding_rate(U, H0, H0, timer(T_b))


@pytest.mark.parametrize("frac", [0.1, 0.25, 0.5, 0.9])
def test_holding_decay_below_H0_gives_the_breakout_time(frac):
    U = frac * H0
    assert rate(U) == pytest.approx(-(H0 / 400.0) * frac)
    expected = 400.0 * (1.0 / frac - 1.0)  # T_b (H0 / U - 1)
    assert seabed.separation_time(U, H0, 400.0) == pytest.approx(expected)
    H, t, dt = H0, 0.0, 0.05
    while U <= H:
        H += dt * rate(U)
        t += dt
    assert t == pytest.approx(expected, abs=0.1)


def test_holding_decay_at_and_above_H0_and_without_pull():
    assert rate(2 * H0) == pytest.approx(-H0 / 400.0)
    assert rate(H0) == pytest.approx(-H0 / 400.0)
    assert rate(-1e6) == 0.0
    assert rate(0.0) == 0.0
    assert seabed.separation_time(1.5 * H0, H0, 400.0) == 0.0
    assert seabed.separation_time(0.0, H0, 400.0) == math.inf
    assert [rate(0.5 * H0), rate(2.0 * H0)] == pytest.approx([-H0 / 800.0, -H0 / 400.0])


def test_release_is_the_exact_exponential():
    assert seabed.released_holding(1000.0, 30.0, 30.0) == pytest.approx(1000.0 / math.e)
    assert seabed.released_holding(1000.0, 0.0, 30.0) == 1000.0


def test_holding_shape_linear_half_to_one_and_a_half():
    L = 78.0
    x = np.linspace(0, L, 100001)
    s = seabed.holding_shape(x, L, 0.5, 1.5)
    assert np.trapezoid(s, x) == pytest.approx(1.0, rel=1e-9)
    assert s[0] * L == pytest.approx(0.5) and s[-1] * L == pytest.approx(1.5)


def test_contact_force_one_sided_and_bilateral():
    w = np.array([-0.01, 0.0, 0.02, -0.001])
    v = np.array([0.0, 0.0, 0.0, 0.1])  # the last is lifting off fast: no pull from the spring
    q = seabed.contact_load(w, v, 5e6, 2e6, False)
    np.testing.assert_allclose(q, [5e4, 0.0, 0.0, 0.0])
    assert seabed.in_contact(w, v, 5e6, 2e6).tolist() == [True, False, False, False]
    np.testing.assert_allclose(seabed.contact_load(w, v, 5e6, 2e6, True), -5e6 * w - 2e6 * v)
    assert seabed.contact_load(-0.02, -0.1, 5e6, 2e6, False) == pytest.approx(5e6 * 0.02 + 2e6 * 0.1)


def test_quadratic_drag_and_its_coefficient():
    coeff = hydro.drag_coefficient(1025.0, 1.2, 12.0)
    assert coeff == pytest.approx(0.5 * 1025 * 1.2 * 12)
    assert hydro.drag(0.3, coeff) == pytest.approx(-0.5 * 1025 * 1.2 * 12 * 0.09)
    assert hydro.drag(-0.3, coeff) == pytest.approx(0.5 * 1025 * 1.2 * 12 * 0.09)
    np.testing.assert_allclose(hydro.drag(np.array([-2.0, 0.0, 2.0]), 1.0), [4.0, 0.0, -4.0])


def test_added_mass_submerged_weight_and_bag_sphere():
    assert hydro.added_mass_per_length(12.0, 1025.0, 1.0) == pytest.approx(1025 * math.pi * 144 / 4)
    assert hydro.added_mass_per_length(12.0, 1025.0, 0.5) == pytest.approx(0.5 * 1025 * math.pi * 36)
    assert hydro.submerged_weight(1000.0, 9.81, 1025.0, 7850.0) == pytest.approx(9810 * (1 - 1025 / 7850))
    V = 4.0 / 3.0 * math.pi * 2.0**3
    assert hydro.sphere_diameter(V) == pytest.approx(4.0)
    assert hydro.sphere_frontal_area(V) == pytest.approx(math.pi * 4.0)
