"""The stuck-valve faults of the one loop (flexlift.ascent.kernel.stuck_valves, issue 26):
a dump valve stuck closed against Boyle's unvented expansion, a fill valve stuck open against
the fill rate x time up to the bag's true capacity."""

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.ascent.plant import coupled_plant

SC = load_scenario("tanker")
ENV = SC.environment
RHO_G = ENV.seawater_density_kg_m3 * ENV.gravity_m_s2


def pressure(height):
    """Ambient pressure at ``height`` above the seabed [Pa]."""
    return ENV.atmospheric_pressure_Pa + RHO_G * (ENV.water_depth_m - height)


@pytest.fixture(scope="module")
def plant():
    return coupled_plant(SC)


def _bag(result, var, bag="bag_1"):
    ds = result.dataset
    return ds.time.values, ds[var].sel(bag=bag).values


def test_a_dump_valve_stuck_closed_near_the_surface_expands_as_boyle_says(plant):
    """From 3000 s (bag_1 at ~215 m of 350 m water, rising to the 300 m target) its dump valve
    is stuck closed and its supply lost: no gas leaves or enters, so the gas volume follows
    V = V_f p_f / p(z) (Boyle, the gas at the sea's temperature) up to the bag's capacity.
    Without the stuck valve the controller purges and the volume stays below that."""
    t_f = 3000.0
    lost = {"kind": "supply_failure", "bag": "bag_1", "time_s": t_f}
    stuck = {"kind": "dump_valve_stuck_closed", "bag": "bag_1", "time_s": t_f}
    r = simulate(SC.with_changes(faults=[lost, stuck]), duration=3300.0, plant=plant)
    t, V = _bag(r, "gas_volume")
    _, z = _bag(r, "height")
    k0 = int(np.searchsorted(t, t_f))
    assert t[k0] == t_f
    hand = V[k0] * pressure(z[k0]) / pressure(z)  # Boyle from the fault on
    cap = plant.bags.capacity[0]
    after = (t >= t_f) & (hand < cap)
    assert after.sum() > 60  # at least a minute of expansion below the capacity
    np.testing.assert_allclose(V[after], hand[after], rtol=2e-3)
    assert hand[after].max() > 1.3 * V[k0]  # a real expansion, not a standing bag
    full = (t >= t_f) & (hand >= 1.01 * cap)
    np.testing.assert_allclose(V[full], cap, rtol=1e-9)  # then it spills at its capacity
    # the same supply failure with a working dump valve: the controller vents the expansion
    free = simulate(SC.with_changes(faults=[lost]), duration=3300.0, plant=plant)
    t2, V2 = _bag(free, "gas_volume")
    later = (t2 > t_f + 30.0) & (t2 <= t[after][-1])
    assert np.all(V2[later] < V[np.isin(t, t2[later])] - 1.0)


def test_a_fill_valve_stuck_open_fills_at_the_full_rate_up_to_the_true_capacity(plant):
    """From 100 s, on the seabed, bag_1's fill valve is stuck open (and its dump valve closed,
    so that nothing leaves): it fills at gas.fill_rate_max_m3_s whatever the controller asks
    (which asks for its pull volume only), V = V_f + q (t - t_f), until its true capacity;
    then it spills and stays full."""
    t_f = 100.0
    faults = [{"kind": "fill_valve_stuck_open", "bag": "bag_1", "time_s": t_f},
              {"kind": "dump_valve_stuck_closed", "bag": "bag_1", "time_s": t_f}]
    r = simulate(SC.with_changes(faults=faults), duration=700.0, plant=plant)
    t, V = _bag(r, "gas_volume")
    _, q = _bag(r, "fill_rate")
    q_max = SC.gas.fill_rate_max_m3_s
    cap = plant.bags.capacity[0]
    k0 = int(np.searchsorted(t, t_f))
    hand = np.minimum(V[k0] + q_max * (t - t_f), cap)
    on = t >= t_f
    # the hull is held on the seabed (heights within 2 cm): the depth, so the volume, is fixed
    _, z = _bag(r, "height")
    assert np.abs(z[on]).max() < 0.02
    np.testing.assert_allclose(V[on], hand[on], rtol=1e-4, atol=1e-3)
    assert np.any(hand[on] == cap) and np.any(hand[on] < cap - 100.0)
    assert np.all(q[on] == q_max)
    # the same run without the fault: the controller stops filling at its pull volume
    free = simulate(SC.with_changes(faults=faults[1:]), duration=700.0, plant=plant)
    assert free.dataset.gas_volume.sel(bag="bag_1").values.max() < cap - 100.0
