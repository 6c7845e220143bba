import numpy as np
import pytest

from flexlift.bags import GasModel, spill
from flexlift.constants import R_GAS


@pytest.fixture
def gas():
    return GasModel(water_depth=350.0)


def test_boyle_bag_raised_in_steps(gas):
    """A fixed amount of gas raised from the seabed in steps: p V constant (Boyle)."""
    heights = np.arange(0.0, 301.0, 50.0)
    p = gas.pressure(heights)
    n = gas.moles(50.0, p[0])
    V = gas.volume(n, p, capacity=1e9)
    np.testing.assert_allclose(p * V, p[0] * 50.0, rtol=1e-12)
    # 350 m -> 50 m of water: the gas grows about six-fold (SPEC §5)
    assert 5.5 < V[-1] / V[0] < 6.5
    # hand computation at 50 m depth
    p50 = 101325.0 + 1025.0 * 9.81 * 50.0
    assert V[-1] == pytest.approx(n * R_GAS * 283.15 / p50, rel=1e-12)


def test_parachute_spills_closed_bag_relieves(gas):
    p = gas.pressure(np.array([300.0, 300.0]))
    cap = np.array([100.0, 100.0])
    n_big = gas.moles(150.0, p)  # 1.5 times the capacity at ambient
    kept, vented = spill(gas, n_big, p, cap, closed=np.array([False, True]))
    # open bag keeps exactly its capacity at ambient pressure
    assert gas.volume(kept[0], p[0], 1e9) == pytest.approx(100.0, rel=1e-12)
    # closed bag keeps gas up to ambient + relief at full volume
    assert kept[1] * gas.RT / 100.0 == pytest.approx(p[1] + 0.1e5, rel=1e-12)
    np.testing.assert_allclose(kept + vented, n_big)


def test_purge_orifice_flow_and_free_air(gas):
    assert gas.purge_flow(1.0, 100.0, 100.0) == pytest.approx(2.0)
    assert gas.purge_flow(0.5, 25.0, 100.0) == pytest.approx(0.5 * 2.0 * 0.5)
    assert gas.purge_flow(2.0, 100.0, 100.0) == pytest.approx(2.0)  # saturated valve
    p = gas.pressure(0.0)
    assert gas.free_air(1.0, p) == pytest.approx(p / 101325.0)
    assert gas.dn_dt(p, 0.5, 0.0) == pytest.approx(p * 0.5 / (R_GAS * 283.15))
