"""The soil's breakout law (docs/theory/breakout-soil.md) against hand values, and the compiled
loop under it against the law's own separation time; the timer law stays the default."""

import math

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.ascent.plant import coupled_plant
from flexlift.physics import seabed

T = 1000.0  # [s] a consolidation time for the hand checks


def test_the_bearing_capacity_force_by_hand():
    """A 25 m x 10 m base 2 m deep in s_u = 3 kPa: N_c = 5 (1.04)(1.08) = 5.616, F = 250 m2
    x 3 kPa x 5.616 = 4.212 MN; deep enough, N_c stops at Skempton's 7.5."""
    assert seabed.soil_breakout_force(25.0, 10.0, 2.0, 3e3) == pytest.approx(
        250.0 * 3e3 * 5.0 * 1.04 * 1.08, rel=1e-12)
    assert seabed.soil_breakout_force(10.0, 25.0, 2.0, 3e3) == pytest.approx(
        seabed.soil_breakout_force(25.0, 10.0, 2.0, 3e3), rel=1e-12)  # either way round
    assert seabed.soil_breakout_force(10.0, 10.0, 50.0, 1e3) == pytest.approx(100 * 1e3 * 7.5)


def test_terzaghi_degree_and_its_rate():
    """T_v = pi U^2 / 4 below 60 %, -(4/pi^2) ln(pi^2 (1 - U) / 8) above (T_v(0.9) = 0.848,
    the textbook's 0.848); the rate is the derivative of the inverse on each branch."""
    assert seabed.consolidation_degree_time(0.5) == pytest.approx(math.pi / 16, rel=1e-12)
    assert seabed.consolidation_degree_time(0.9) == pytest.approx(0.848, abs=1e-3)
    assert seabed.consolidation_degree_time(1.0) == math.inf
    for u in (0.2, 0.5, 0.7, 0.95):
        h = 1e-6
        dt = seabed.consolidation_degree_time(u + h) - seabed.consolidation_degree_time(u - h)
        assert seabed.relief_rate(u) == pytest.approx(2 * h / dt, rel=1e-5)
    assert seabed.relief_rate(0.0) == seabed.relief_rate(seabed.MIN_DEGREE)  # regularised


def test_the_soil_separation_time():
    """Under 0 < U < H_0 the hull separates when the relieved hold H_0 (1 - U_c) meets U:
    T_c T_v(1 - U/H_0); at once under a full pull; never without one."""
    assert seabed.soil_separation_time(0.5, 1.0, T) == pytest.approx(T * math.pi / 16)
    assert seabed.soil_separation_time(0.05, 1.0, T) == pytest.approx(
        T * seabed.consolidation_degree_time(0.95))
    assert seabed.soil_separation_time(1.0, 1.0, T) == 0.0
    assert seabed.soil_separation_time(0.0, 1.0, T) == math.inf


@pytest.fixture(scope="module")
def ehime():
    return load_scenario("field-ehime-maru")


def test_the_scenario_chooses_the_law_and_the_timer_stays_the_default(ehime):
    """``seabed.breakout_law: soil`` puts the soil's H0 and T_c = d^2 / c_v in the plant;
    the default (the tanker) is the timer law with H0 = (breakout_factor - 1) W'."""
    p = coupled_plant(ehime)
    sb = ehime.seabed
    assert p.seabed.law == seabed.LAW_SOIL
    assert float(p.seabed.H0.sum()) == pytest.approx(seabed.soil_breakout_force(
        58.0, 9.3, sb.embedment_m, 1e3 * sb.shear_strength_kPa), rel=1e-9)
    assert p.seabed.consolidation_time == pytest.approx(
        sb.drainage_length_m**2 / sb.consolidation_coefficient_m2_s)
    tanker = load_scenario("tanker")
    assert tanker.seabed.breakout_law == "timer"
    tp = coupled_plant(tanker)
    assert tp.seabed.law == seabed.LAW_TIMER
    assert float(tp.seabed.H0.sum()) == pytest.approx(
        (tanker.lift.breakout_factor - 1.0) * tp.wet_weight, rel=1e-9)


@pytest.mark.parametrize("cv_factor", [1.0, 4.0])
def test_the_loop_separates_when_the_law_says(ehime, cv_factor):
    """The compiled loop under the soil law separates at the law's time for the uplift it
    held (the uplift read off the run; the fill is seconds), for two consolidation
    coefficients (four times c_v: a quarter of the time), and names the law it ran."""
    sc = ehime.with_changes(**{"seabed.consolidation_coefficient_m2_s":
                               cv_factor * ehime.seabed.consolidation_coefficient_m2_s,
                               "simulation.duration_s": 9000.0 / cv_factor + 300.0})
    r = simulate(sc, control="open-loop")
    assert r.summary()["breakout_law"] == "soil"
    p = coupled_plant(sc)
    t_sep = r.headline["separation_time_s"]
    t = r.dataset.time.values
    held = float(r.dataset.uplift.values[np.argmin(np.abs(t - 0.5 * t_sep))])
    expect = seabed.soil_separation_time(held, float(p.seabed.H0.sum()),
                                         p.seabed.consolidation_time)
    assert t_sep == pytest.approx(expect, rel=0.01)
