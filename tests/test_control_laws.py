"""Each control law of docs/theory/control.md as the compiled controller computes it, one sample at a time.

tests/test_controller.py covers the breakout pull, the purge's anti-windup, open-loop,
coordination, the adaptation and the height filter; these tests pin the remaining terms with
numbers worked out here: the fill's deadband and SIFSMC distance, the purge's deadband and
proportional opening, the supervisor's inputs, the adapted neutral volume in V_d, and the
speed filter.
"""

import math

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent.plant import coupled_plant
from flexlift.control.build import controller_for, fuzzy_maps
from flexlift.control.controller import sample
from flexlift.control.reference import trapezoid

SC = load_scenario("tanker")
CTL = SC.control
T = 1.0 / CTL.sample_rate_Hz


@pytest.fixture(scope="module")
def plant():
    return coupled_plant(SC)


def controller(plant, scenario=SC, mode="decentralized"):
    table, _, fill = fuzzy_maps(scenario)
    return controller_for(scenario, plant, mode, table, fill)


def step(C, S, t, z, zd, V, separated):
    """One control sample with every controlled bag at height ``z``, speed ``zd`` and gas
    volume ``V`` (scalars or (nc,) arrays)."""
    n = C.bags.size
    arr = lambda x: np.broadcast_to(np.asarray(x, dtype=float), n).copy()  # noqa: E731
    sample(t, arr(z), arr(zd), arr(V), np.full(n, separated), C, S)


@pytest.mark.parametrize("deficit", [0.1, 0.19, 0.3, 1.0, 2.0, 5.0])
def test_fill_beyond_the_deadband_at_the_sifsmc_distance(plant, deficit):
    """A steady deficit eps = V_d - V (so eps' = 0): d = lambda eps / sqrt(1 + lambda^2) /
    d_scale through the monotone fill map times Q_in,max, nothing within the deadband."""
    C, S = controller(plant)
    V_d = C.V_neutral + C.V_pull  # held: the breakout pull
    for k in range(3):
        step(C, S, T * k, 0.0, 0.0, V_d - deficit, False)
    lam = CTL.fill.slope_1_s
    d = lam * deficit / math.sqrt(1.0 + lam**2) / CTL.fill.distance_scale_m3_s
    grid = np.linspace(0.0, 1.0, C.fill_v.size)
    expected = np.interp(d, grid, C.fill_v) * SC.gas.fill_rate_max_m3_s
    if deficit <= CTL.volume_deadband_m3:
        expected = 0.0
    np.testing.assert_allclose(S.fill, expected, rtol=1e-9, atol=0.0)
    assert np.all(S.opening == 0.0)
    if deficit > 1.0:
        assert np.all(S.fill > 0.0)


def test_fill_follows_the_rate_of_the_deficit(plant):
    """A deficit growing at r: the filtered rate (time constant 1 s) enters s = eps' + lambda eps."""
    C, S = controller(plant)
    V_d = C.V_neutral + C.V_pull
    r, eps0 = 0.02, 0.5
    for k in range(30):
        step(C, S, T * k, 0.0, 0.0, V_d - (eps0 + r * T * k), False)
    a = T / (1.0 + T)
    rate = r * (1.0 - (1.0 - a) ** 29)
    np.testing.assert_allclose(S.eps_rate, rate, rtol=1e-9)
    lam = CTL.fill.slope_1_s
    eps = eps0 + r * T * 29
    d = (rate + lam * eps) / math.sqrt(1.0 + lam**2) / CTL.fill.distance_scale_m3_s
    expected = np.interp(d, np.linspace(0, 1, C.fill_v.size), C.fill_v) * SC.gas.fill_rate_max_m3_s
    np.testing.assert_allclose(S.fill, expected, rtol=1e-9)


@pytest.mark.parametrize("excess", [0.1, 0.5, 1.5])
def test_purge_opens_proportionally_beyond_the_deadband(plant, excess):
    """The first sample with an excess V - V_d: opening k_p excess (no integral yet), none within
    the deadband; fill is blocked while the valve is open."""
    C, S = controller(plant)
    step(C, S, 0.0, 0.0, 0.0, C.V_neutral, True)  # separated, on the reference, no excess
    pos, vel = trapezoid(T, CTL.target_height_m, CTL.ascent_speed_m_s, CTL.ascent_acceleration_m_s2)
    step(C, S, T, pos, vel, C.V_neutral + excess, True)  # still on it: u = 0, V_d = V_neutral
    np.testing.assert_allclose(S.V_d, C.V_neutral, atol=1e-9)
    expected = 0.0 if excess <= CTL.volume_deadband_m3 else CTL.purge.kp_1_m3 * excess
    np.testing.assert_allclose(S.opening, expected, rtol=1e-9)
    assert np.all(S.fill == 0.0)


def test_supervisor_inputs_are_the_errors_to_the_reference(plant):
    """e = (z_ref - z) / e_scale and r = (z_ref' - z') / r_scale, saturated to [-1, 1]; a bag
    below its reference asks for more gas, one rising faster than it for less."""
    C, S = controller(plant)
    step(C, S, 0.0, 0.0, 0.0, C.V_neutral, True)  # the reference starts here
    t = 50.0
    pos, vel = trapezoid(t, CTL.target_height_m, CTL.ascent_speed_m_s, CTL.ascent_acceleration_m_s2)
    z = np.array([pos - 2.0, pos, pos + 1.0, pos])
    zd = np.array([vel, vel + 0.05, vel, vel - 0.3])
    step(C, S, t, z, zd, C.V_neutral, True)
    e_scale, r_scale = CTL.supervisor.error_scale_m, CTL.supervisor.rate_scale_m_s
    np.testing.assert_allclose(S.z_ref, pos, rtol=1e-12)
    np.testing.assert_allclose(S.e_in, np.clip((pos - z) / e_scale, -1, 1), rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(S.r_in, np.clip((vel - zd) / r_scale, -1, 1), rtol=1e-9, atol=1e-12)
    assert S.u[0] > 0.1 and S.u[1] < -0.1 and S.u[2] < -0.1 and S.u[3] > 0.5


def test_the_adapted_neutral_volume_enters_the_desired_volume(plant):
    """V_d = V_neutral + I + u dV_max: with the bag held on its reference (u = 0) after a steady
    error has built I up, V_d sits I above the neutral volume."""
    sc = SC.with_changes(**{"control.height_integral_gain_m2_s": 0.05})
    C, S = controller(plant, sc)
    step(C, S, 0.0, 0.0, 0.0, C.V_neutral, True)
    for k in range(1, 51):  # 5 s a metre below the reference
        pos = trapezoid(T * k, CTL.target_height_m, CTL.ascent_speed_m_s,
                        CTL.ascent_acceleration_m_s2)[0]
        step(C, S, T * k, pos - 1.0, 0.0, C.V_neutral, True)
    t = T * 51
    pos, vel = trapezoid(t, CTL.target_height_m, CTL.ascent_speed_m_s, CTL.ascent_acceleration_m_s2)
    step(C, S, t, pos, vel, C.V_neutral, True)  # back on the reference: I stays
    assert np.all(S.adapt > 0.2)
    assert np.abs(S.u).max() < 1e-3
    np.testing.assert_allclose(S.V_d, C.V_neutral + S.adapt + S.u * C.dV_max, rtol=1e-12)
    np.testing.assert_allclose(S.V_d - C.V_neutral, S.adapt, atol=1e-3 * C.dV_max.max())


def test_the_measurement_filter_lags_speed_as_height(plant):
    """A first-order low pass, time constant filter_time, on the speed too."""
    sc = SC.with_changes(**{"control.measurement_filter_s": 2.0})
    C, S = controller(plant, sc)
    step(C, S, 0.0, 0.0, 0.0, C.V_neutral, True)
    for k in range(1, 21):  # 2 s after a step of 0.1 m/s: 1 - 1/e of it
        step(C, S, T * k, 0.0, 0.1, C.V_neutral, True)
    np.testing.assert_allclose(S.zd_f, 0.1 * (1.0 - math.exp(-1.0)), rtol=1e-9)
    np.testing.assert_allclose(S.z_f, 0.0, atol=1e-15)
