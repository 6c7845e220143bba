"""Issue 23's consistency fixes: the statics' contact length is a length, and the balance
check weighs what the layout balances (the wet weight, a pipe's contents per element)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent.checks import balance_check, weight_centre
from flexlift.ascent.plant import coupled_plant
from flexlift.cli import main
from flexlift.loads.statics import scenario_statics, summary


def test_resting_tanker_contact_length_is_its_length(tanker, capsys):
    """Every lift at 0: the whole hull rests on the seabed, 78.02 m of it (not 12 nodes
    times an element's 7.09 m = 85.11 m)."""
    lifts = {f"bag_{k}": 0.0 for k in range(1, 8)}
    st = scenario_statics(tanker, lifts)
    assert st.contact.all()
    assert summary(st, 9.81)["contact_length_m"] == pytest.approx(78.02, rel=1e-12)
    args = ["statics", "--json"] + [a for k in range(1, 8) for a in ("--lift", f"bag_{k}=0")]
    assert main(args) == 0
    assert json.loads(capsys.readouterr().out)["contact_length_m"] == pytest.approx(78.02)


def test_partial_contact_counts_tributary_lengths(tanker):
    """Short of the weight with one bag only, part of the hull rests: the length counted is
    the nodes' tributary lengths, never more than the hull."""
    st = scenario_statics(tanker, {"bag_1": 0.0, "bag_2": 0.0})  # the stern rests
    n = int(st.contact.sum())
    assert 0 < n < st.x.size
    l = st.x[1] - st.x[0]
    ends = int(st.contact[0]) + int(st.contact[-1])
    assert summary(st, 9.81)["contact_length_m"] == pytest.approx((n - 0.5 * ends) * l)


def _flooded_pipe():
    return load_scenario("pipeline").with_changes(**{
        "pipe.length_m": 400.0, "pipe.elements": 200, "pipe.lift_points": None,
        "pipe.segments": [{"from_m": 0.0, "to_m": 150.0, "contents": "flooded"}],
        "control.sequence": None, "lift.internal_bags": 0, "lift.catalogue_bag.lift_t": 10.0})


def test_balance_check_and_layout_use_the_same_centre():
    """A pipe flooded over its first 150 m: its wet weight (steel + coat + water inside, less
    the displaced water) is centred elsewhere than its dry mass. The balanced layout puts the
    holding lifts on the wet-weight centre; the check compares against that same centre."""
    sc = _flooded_pipe()
    plant = coupled_plant(sc)
    hull, plan = plant.hull, plant.plan
    env = sc.environment
    # the wet weight's centre, integrated here element by element
    m = hull.mass_per_length
    rho = hull.density
    q = m * env.gravity_m_s2 * (1.0 - env.seawater_density_kg_m3 / rho)
    xc = 0.5 * (hull.x_nodes[1:] + hull.x_nodes[:-1])
    centre = float(q @ xc / q.sum())
    dry = float(m @ xc / m.sum())
    assert abs(centre - dry) > 5.0  # the contents move the centre: a case that tells them apart
    assert weight_centre(hull, env.gravity_m_s2, env.seawater_density_kg_m3,
                         env.steel_density_kg_m3) == pytest.approx(centre, rel=1e-12)
    assert plan.lift_centroid == pytest.approx(centre, abs=1e-3 * hull.length)
    c = balance_check(plant)
    assert c.ok, c.message
    assert f"centre of the wet weight {centre:.2f} m" in c.message
    assert np.isfinite(plan.lift_centroid)


def test_floating_statics_relieve_with_the_water_moving_along():
    """Lifts above the wet weight: the trawler (engine aft) hangs in its bags and the excess
    accelerates the structure and the water moving with it (added mass), as in the ascent.
    The moment closes at both ends, and differs from the structure-only relief."""
    from pathlib import Path

    from flexlift.physics.hydro import moving_water_per_length

    sc = load_scenario(Path(__file__).parent / "data" / "trawler.yaml")
    lifts = {"bag_1": 60.0, "bag_21": 60.0}
    st = scenario_statics(sc, lifts)
    assert st.floating and st.net_force > 0
    peak = np.abs(st.moment).max()
    assert abs(st.moment[0]) <= 1e-6 * peak and abs(st.moment[-1]) <= 1e-6 * peak
    dry = scenario_statics(sc.with_changes(**{"hydro.added_mass_coefficient": 0.0}), lifts)
    assert np.abs(dry.moment - st.moment).max() > 1e-3 * peak
    water = moving_water_per_length(11.0, 1025.0, 1.0, 0.0, 60.0)
    assert water == pytest.approx(1025.0 * np.pi * 11.0**2 / 4)
