"""Each bag type's physics in the one compiled loop, and broaching at the surface
(docs/theory/gas.md#bag-types, docs/theory/gas.md#surface).

The plant and loop tests use the published incident's flange (the shipped field case
``field-imca-flange``, docs/validation/imca-flange.md:
a 0.6 t flange in 19 m of water under one 0.5 t parachute bag 25 % over its rating), changing
only the bag's type where a test needs another.
"""

import math

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import kernel, simulate
from flexlift.ascent.loop import Ascent
from flexlift.ascent.plant import coupled_plant
from flexlift.ascent.records import (
    BAG_CLOSED_PARACHUTE,
    BAG_ENCLOSED,
    BAG_OPEN_PARACHUTE,
    BAG_PAPER,
)
from flexlift.ascent.state import RET_DONE
from flexlift.constants import R_GAS
from flexlift.physics.surface import volume_from_top, waterline_volume

SC = load_scenario("field-imca-flange")
ENV = SC.environment
RHO_G = ENV.seawater_density_kg_m3 * ENV.gravity_m_s2
RT = R_GAS * ENV.sea_temperature_K
BAR = 1e5  # [Pa]


def pressure(height):
    """Ambient pressure at ``height`` above the seabed [Pa], by hand."""
    return ENV.atmospheric_pressure_Pa + RHO_G * (ENV.water_depth_m - height)


def of_type(kind: str, **fields):
    bag = {"type": kind, "lift_t": 0.5, "diameter_m": 0.75, "length_m": 1.13,
           "capacity_factor": 1.25, **fields}
    return SC.with_changes(**{"lift.catalogue_bag": bag})


# ------------------------------------------------------------------------------ the law
def test_the_waterline_volume_of_the_cylinder_against_hand_values():
    """Upright D = 0.75 m: 0.5 m3 of gas with its top 0.2 m out lifts 0.5 - pi 0.375^2 0.2;
    a 0.5 m cone top (D = 1 m) holds A y^3 / (3 c^2) within y of its tip; a lying cylinder
    D = 2 m, L = 3 m holds half its volume in its top half; below the surface all of it lifts."""
    assert waterline_volume(0.5, 0.2, 0.75, 1.13, 0.0, True) == pytest.approx(
        0.5 - math.pi * 0.375**2 * 0.2, rel=1e-12)
    assert waterline_volume(0.5, -1.0, 0.75, 1.13, 0.0, True) == 0.5
    assert waterline_volume(0.05, 0.2, 0.75, 1.13, 0.0, True) == 0.0  # all of it out
    a = math.pi / 4.0
    assert volume_from_top(0.25, 1.0, 2.0, 0.5, True) == pytest.approx(a * 0.25**3 / 0.75,
                                                                        rel=1e-12)
    assert volume_from_top(0.75, 1.0, 2.0, 0.5, True) == pytest.approx(a * 0.5 / 3 + a * 0.25,
                                                                        rel=1e-12)
    assert volume_from_top(1.0, 2.0, 3.0, 0.0, False) == pytest.approx(1.5 * math.pi, rel=1e-12)
    assert volume_from_top(2.5, 2.0, 3.0, 0.0, False) == pytest.approx(3.0 * math.pi, rel=1e-12)
    assert volume_from_top(0.3, 2.0, 3.0, 0.0, False) == pytest.approx(  # the segment formula
        3.0 * (math.acos(0.7) - 0.7 * math.sqrt(2 * 0.3 - 0.09)), rel=1e-12)


# ---------------------------------------------------------------------------- the plant
def test_each_type_gets_its_relief_and_body():
    """Open bags spill (no relief), closed parachute and enclosed bags relieve at their
    catalogue setting (else gas.relief_pressure_bar); the paper's bags as before. The body
    holds the true capacity; an open bag tips at a quarter of its height."""
    cap = 0.5e3 * 1.25 / ENV.seawater_density_kg_m3
    area = math.pi * 0.75**2 / 4
    b = coupled_plant(SC).bags
    assert b.kind[0] == BAG_OPEN_PARACHUTE and b.relief[0] == 0.0
    assert b.capacity[0] == pytest.approx(cap, rel=1e-12)
    assert b.body_length[0] == pytest.approx(cap / area, rel=1e-12)  # 1.38 m > 1.13 m
    assert b.tip_freeboard[0] == pytest.approx(0.25 * cap / area, rel=1e-12)
    assert b.top_offset[0] == pytest.approx(SC.hull.depth_m + cap / area, rel=1e-12)
    b = coupled_plant(of_type("closed_parachute", relief_bar=0.1)).bags
    assert b.kind[0] == BAG_CLOSED_PARACHUTE and b.relief[0] == pytest.approx(0.1 * BAR)
    assert np.isinf(b.tip_freeboard[0])
    b = coupled_plant(of_type("enclosed", length_m=2.0, diameter_m=0.6, relief_bar=0.2)).bags
    assert b.kind[0] == BAG_ENCLOSED and b.relief[0] == pytest.approx(0.2 * BAR)
    assert b.top_offset[0] == pytest.approx(SC.hull.depth_m + 0.6, rel=1e-12)  # lying
    b = coupled_plant(of_type("closed_parachute")).bags  # no setting: gas.relief_pressure_bar
    assert b.relief[0] == pytest.approx(SC.gas.relief_pressure_bar * BAR)
    t = coupled_plant(load_scenario("tanker")).bags  # the paper's, unchanged
    assert (t.kind == BAG_PAPER).all()
    np.testing.assert_array_equal(t.relief, [0.0] * 4 + [0.1 * BAR] * 3)


# ----------------------------------------------------------------------------- the loop
def _raised(scenario, height, n_of):
    """A run with the controllers off, the flange clear of the seabed at ``height`` [m] and
    at rest, the bag's gas ``n_of(capacity)`` [mol]; one step of the compiled loop."""
    run = Ascent(scenario, coupled_plant(scenario), "open-loop", 60.0, "table")
    run.settings = run.settings._replace(k_ctrl=10**9)
    R, a = run.state, run.plant
    R.counters[0] = 1
    R.sep[:], R.broken[:], R.H[:] = True, True, 0.0
    R.q[:], R.v[:] = 0.0, 0.0
    R.q[0] = height / a.modal.heave_row[0]
    R.n[:] = n_of(a.bags.capacity[0])
    R.counters[1] = 0
    n0 = R.n.copy()
    assert kernel.advance(run.inputs(), 2) == RET_DONE
    return run, n0


def test_a_closed_bag_holds_its_relief_setting():
    """Over-filled, a closed bag vents down to its capacity at ambient plus its setting: its
    gas is then at p + 10 kPa (and at p + 5 kPa with a 0.05 bar setting)."""
    for relief_bar in (0.1, 0.05):
        run, n0 = _raised(of_type("closed_parachute", relief_bar=relief_bar), 8.0,
                          lambda cap: 3.0 * pressure(8.0) * cap / RT)
        R, cap = run.state, run.plant.bags.capacity[0]
        gas_pressure = R.n[0] * RT / cap
        assert R.p[0] == pytest.approx(pressure(R.z[0]), rel=1e-12)
        assert gas_pressure - R.p[0] == pytest.approx(relief_bar * BAR, rel=1e-9)
        assert R.V[0] == pytest.approx(cap, rel=1e-12)


def test_an_open_bag_spills_its_boyle_excess():
    """A bag full at the seabed (19 m), raised to 10 m above it, spills what Boyle's law gives
    beyond its capacity: cap (p_0 / p_1 - 1) at p_1, and keeps cap at ambient."""
    run, n0 = _raised(SC, 10.0, lambda cap: pressure(0.0) * cap / RT)
    R, cap = run.state, run.plant.bags.capacity[0]
    p1 = pressure(R.z[0])
    assert R.z[0] == pytest.approx(10.0, abs=0.01)
    assert R.vented[0] == pytest.approx(cap * (pressure(0.0) / p1 - 1.0), rel=1e-9)
    assert R.n[0] * RT / p1 == pytest.approx(cap, rel=1e-12)


def test_a_broached_bag_lifts_its_gas_below_the_waterline():
    """Its top 0.2 m out of the water (within the tip freeboard), a full open bag lifts
    cap - pi D^2 / 4 x 0.2 and spills nothing more; a closed bag floats the same way."""
    for scenario in (SC, of_type("closed_parachute", relief_bar=0.1)):
        b = coupled_plant(scenario).bags
        h = ENV.water_depth_m - b.top_offset[0] + 0.2
        run, n0 = _raised(scenario, h, lambda cap, h=h: pressure(h) * cap / RT)
        R, cap = run.state, b.capacity[0]
        out = R.z[0] + b.top_offset[0] - ENV.water_depth_m
        assert out == pytest.approx(0.2, abs=1e-3)
        assert R.V[0] == pytest.approx(cap - math.pi * 0.75**2 / 4 * out, rel=1e-9)
        assert R.point[0] < RHO_G * cap  # the loads of the step took the waterline volume


def test_a_tipped_open_bag_spills_to_its_waterline_volume():
    """Past its tip freeboard (a quarter of its height) an open bag keeps only its gas below
    the waterline; a closed bag there does not tip."""
    b = coupled_plant(SC).bags
    f = b.tip_freeboard[0] + 0.05
    h = ENV.water_depth_m - b.top_offset[0] + f
    run, n0 = _raised(SC, h, lambda cap: pressure(h) * cap / RT)
    R, cap = run.state, b.capacity[0]
    out = R.z[0] + b.top_offset[0] - ENV.water_depth_m
    # sinking over the step, the gas is within its capacity (Boyle) and keeps what is below
    # the waterline at the step's end
    kept = min(n0[0] * RT / pressure(R.z[0]), cap) - math.pi * 0.75**2 / 4 * out
    assert R.n[0] * RT / R.p[0] == pytest.approx(kept, rel=1e-9)
    closed = of_type("closed_parachute", relief_bar=0.1)
    run, n0 = _raised(closed, h, lambda cap: pressure(h) * cap / RT)
    assert run.state.n[0] == pytest.approx(n0[0], rel=1e-12)


# -------------------------------------------------------------------------- the incident
@pytest.fixture(scope="module")
def incident():
    return simulate(SC)


def test_the_incident_rises_broaches_spills_and_falls_back(incident):
    """The published incident: the over-capacity bag lifts the flange, rises, breaks the
    surface, tips and spills, and the flange falls back; the run goes on past the breach and
    ends when it resettles."""
    ev = incident.events
    kinds = [e["kind"] for e in ev if e["kind"] in ("separation", "surface_breach", "resettle")]
    assert kinds == ["separation", "surface_breach", "resettle"]
    breach = next(e for e in ev if e["kind"] == "surface_breach")
    settle = next(e for e in ev if e["kind"] == "resettle")
    assert "broaches" in breach["detail"]
    ds = incident.dataset
    t, V, z = ds.time.values, ds.gas_volume.values[:, 0], ds.height.values[:, 0]
    cap = coupled_plant(SC).bags.capacity[0]
    before = t < breach["time_s"]
    assert V[before].max() == pytest.approx(cap, rel=1e-9)  # filled to its true capacity
    assert V[(t > breach["time_s"] + 1.0) & (t < settle["time_s"])].max() < 0.25 * cap
    assert z.max() > ENV.water_depth_m - coupled_plant(SC).bags.top_offset[0]  # top out
    assert z[-1] < 0.05 and t[-1] - settle["time_s"] < 1.0  # back down; the run ended there
    assert float(ds.gas_vented_free_air.values.sum()) > 0.5 * cap
    crit = incident.criteria
    assert not crit["no_surface_breach"] and not crit["no_resettle"]
    assert incident.outcome["kind"] == "unsafe"
    assert "the run went on" in incident.reasons["no_surface_breach"]


def test_a_paper_bag_breach_still_ends_the_run():
    """The paper's bags have no surface law: the run ends at the breach, as before."""
    r = simulate(of_type("pressurised_cylinder"))
    last = r.events[-1]
    assert last["kind"] == "surface_breach" and "run ends" in last["detail"]
    assert r.dataset.time.values[-1] - last["time_s"] < 1.0
    assert r.reasons["reached_target"] == "the run ended at the surface breach"
