"""A compressor's free-air delivery shared by the bags it feeds, derated by depth (issue 25:
docs/theory/gas.md#supply)."""

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate

FAD_M3_MIN = 10.0  # far below what seven bags at 350 m ask for at 0.5 m3/s each


@pytest.fixture(scope="module")
def filling():
    tanker = load_scenario("tanker").with_changes(**{"gas.supply_free_air_m3_min": FAD_M3_MIN})
    return tanker, simulate(tanker, control="decentralized", duration=120.0)


def test_the_bags_share_the_compressors_free_air_derated_by_depth(filling):
    tanker, r = filling
    ds = r.dataset
    env = tanker.environment
    p_atm, rho_g = env.atmospheric_pressure_Pa, env.seawater_density_kg_m3 * env.gravity_m_s2
    # each bag's pressure at its depth (hand: p = p_atm + rho g (water depth - height))
    p = p_atm + rho_g * (env.water_depth_m - ds["height"].values)
    fill = ds["fill_rate"].values  # [m3/s] at the bag's pressure
    free = (fill * p / p_atm).sum(axis=1)  # [m3/s] of free air drawn from the compressor
    rows = fill.sum(axis=1) > 0
    assert rows.sum() > 50
    np.testing.assert_allclose(free[rows], FAD_M3_MIN / 60.0, rtol=1e-3)
    # at 350 m a bag gets ~ FAD/7 p_atm/p: two orders below the 0.5 m3/s it asks for
    per_bag = fill[rows].max()
    assert per_bag < 0.5 / 50


def test_without_a_compressor_each_bag_fills_at_its_rate_at_depth():
    tanker = load_scenario("tanker")
    r = simulate(tanker, control="decentralized", duration=60.0)
    fill = r.dataset["fill_rate"].values
    assert fill.max() == pytest.approx(tanker.gas.fill_rate_max_m3_s, rel=1e-9)


def test_the_checks_and_the_design_basis_use_the_compressor(filling):
    from flexlift.ascent.checks import fill_rate_on_seabed
    from flexlift.scenario.basis import design_basis

    tanker, _ = filling
    env = tanker.environment
    p = env.atmospheric_pressure_Pa + env.seawater_density_kg_m3 * env.gravity_m_s2 * 350.0
    assert fill_rate_on_seabed(tanker, 7) == pytest.approx(
        FAD_M3_MIN / 60.0 * env.atmospheric_pressure_Pa / p / 7, rel=1e-12)
    assert fill_rate_on_seabed(load_scenario("tanker"), 7) == 0.5  # the paper's assumption
    row = next(r for r in design_basis(tanker) if r["item"].startswith("gas supply"))
    assert "10 m3/min of free air" in row["value"]
