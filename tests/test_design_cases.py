"""The static design cases closed physically (docs/theory/strength.md#design-cases, issue 23), checked against an
integration of the loads written here from the hull, the plan and the ascent's suction and
pull, not from :mod:`flexlift.loads`' load cases.

The trawler and the bulk carrier are the two hulls of issue 23 (tests/data); before the
closure their lift-plan moment peaked at the free bow (the trawler's 3.95 MN m at x = 60 m,
the bulk carrier's closing moment 92 MN m of its 109 MN m), an artefact of the open load case.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent.plant import coupled_plant, wet_beam
from flexlift.control.build import bag_pulls
from flexlift.loads.design import paper_case
from flexlift.loads.liftplan import plan_lift
from flexlift.physics.seabed import holding_shape
from flexlift.stages.loads import design
from flexlift.structure.hull import hull_from_scenario

DATA = Path(__file__).parent / "data"


def _pipe():
    """A 400 m coated line, flooded over its first 150 m (per-element contents), with a 3 t
    valve at 300 m, bags balanced on it."""
    return load_scenario("pipeline").with_changes(**{
        "pipe.length_m": 400.0, "pipe.elements": 200, "pipe.lift_points": None,
        "pipe.segments": [{"from_m": 0.0, "to_m": 150.0, "contents": "flooded"}],
        "pipe.point_masses": [{"x_m": 300.0, "mass_t": 3.0}], "control.sequence": None,
        "lift.catalogue_bag.lift_t": 10.0, "lift.internal_bags": 0})


SCENARIOS = {
    "trawler": lambda: load_scenario(DATA / "trawler.yaml"),
    "bulk_carrier": lambda: load_scenario(DATA / "bulk_carrier.yaml"),
    "pipe": _pipe,
}


@pytest.fixture(scope="module", params=list(SCENARIOS))
def setup(request):
    sc = SCENARIOS[request.param]()
    hull = hull_from_scenario(sc)
    plan = plan_lift(sc, hull)
    plant = coupled_plant(sc, hull, plan)
    return request.param, sc, hull, plan, plant, design(sc, hull, plan, plant, per_element=20)


def _own_loads(sc, hull, plan, plant, name):
    """The case's loads built here: (line pieces [(x0, x1, q0, q1)], points [(x, F)], the
    names of the scalable lifts' point/line entries) before scaling and inertia; up positive."""
    env = sc.environment
    g, rho, rho_s = env.gravity_m_s2, env.seawater_density_kg_m3, env.steel_density_kg_m3
    xn = hull.x_nodes
    q_w = hull.wet_weight_per_length(g, rho, rho_s)
    lines = [(xn[e], xn[e + 1], -q, -q, None) for e, q in enumerate(q_w)]
    points = [(x, -w, None) for x, w in zip(xn, hull.point_wet_weights(g, rho, rho_s)) if w > 0]
    H0 = (sc.lift.breakout_factor - 1.0) * plan.wet_weight
    if name != "holding" and H0 > 0:
        stern, bow = ((sc.seabed.stern_ratio, sc.seabed.bow_ratio)
                      if sc.seabed.holding_shape == "linear" else (1.0, 1.0))
        L = hull.length
        lines.append((0.0, L, -H0 * holding_shape(0.0, L, stern, bow),
                      -H0 * holding_shape(L, L, stern, bow), None))
    lifts = np.array([b.lift for b in plan.bags])
    ext = np.array([b.kind == "external" for b in plan.bags])
    if name != "full_lift":  # holding: internal bags full, externals share the rest of W'
        lifts = np.where(ext, (plan.wet_weight - lifts[~ext].sum()) / ext.sum(), lifts)
    if name == "breakout":
        pull = bag_pulls(sc, plant) * rho * g
        lifts[ext] += pull
    for b, F, is_ext in zip(plan.bags, lifts, ext):
        tag = "scaled" if is_ext else "fixed"
        if b.kind == "external":
            points.append((b.x, F, tag))
        else:
            x0, x1 = b.span
            lines.append((x0, x1, F / (x1 - x0), F / (x1 - x0), tag))
    return lines, points


def _simpson(x0, x1, f):
    return (x1 - x0) / 6.0 * (f(x0) + 4 * f(0.5 * (x0 + x1)) + f(x1))


def _sums(lines, points, L):
    """Resultant [N] and moment about the bow, sum F (L - x) [N m], exactly (Simpson on
    linear loads times a linear lever)."""
    F = sum(0.5 * (q0 + q1) * (x1 - x0) for x0, x1, q0, q1, _ in lines) + sum(f for _, f, _ in points)
    M = sum(_simpson(x0, x1, lambda x, x0=x0, x1=x1, q0=q0, q1=q1:
                     (q0 + (q1 - q0) * (x - x0) / (x1 - x0)) * (L - x))
            for x0, x1, q0, q1, _ in lines) + sum(f * (L - x) for x, f, _ in points)
    return F, M


def _closed_own(sc, hull, plan, plant, name):
    """The case closed here: the external bags scaled to the load, then the rigid-body
    inertia of the mass moving in water. Returns (lines, points, scale, a0, alpha)."""
    lines, points = _own_loads(sc, hull, plan, plant, name)
    up_s = sum(f for _, f, t in points if t == "scaled") + sum(
        0.5 * (q0 + q1) * (x1 - x0) for x0, x1, q0, q1, t in lines if t == "scaled")
    rest = _sums(lines, points, hull.length)[0] - up_s
    s = -rest / up_s
    lines = [(x0, x1, q0 * s, q1 * s, t) if t == "scaled" else (x0, x1, q0, q1, t)
             for x0, x1, q0, q1, t in lines]
    points = [(x, f * s, t) if t == "scaled" else (x, f, t) for x, f, t in points]
    m_line = hull.mass_per_length + wet_beam(sc, hull)[1]
    xn, l = hull.x_nodes, hull.element_length
    xc = 0.5 * (xn[1:] + xn[:-1])
    pm = hull.point_masses
    mass = m_line.sum() * l + pm.sum()
    xg = ((m_line * l) @ xc + pm @ xn) / mass
    F, M_bow = _sums(lines, points, hull.length)
    M_g = F * (hull.length - xg) - M_bow  # sum F (x - xg)
    a0 = F / mass
    alpha = M_g / ((m_line * l) @ ((xc - xg) ** 2 + l * l / 12) + pm @ (xn - xg) ** 2)

    def acc(x):
        return a0 + alpha * (x - xg)

    lines += [(xn[e], xn[e + 1], -m * acc(xn[e]), -m * acc(xn[e + 1]), None)
              for e, m in enumerate(m_line)]
    points += [(x, -m * acc(x), None) for x, m in zip(xn, pm) if m > 0]
    return lines, points, s, a0, alpha


def _own_moment(lines, points, x):
    """M(x) by direct summation of the moment of every load aft of x (sagging positive)."""
    M = np.zeros_like(x)
    for x0, x1, q0, q1, _ in lines:
        # the part of the piece aft of x: integral of q(s) (x - s) ds from x0 to min(x, x1)
        b = np.clip(x, x0, x1)
        qb = q0 + (q1 - q0) * (b - x0) / (x1 - x0)
        h = b - x0
        # exact for linear q: h/6 [q0 (x - x0) + 4 qm (x - xm) + qb (x - b)]
        xm, qm = 0.5 * (x0 + b), 0.5 * (q0 + qb)
        M += h / 6.0 * (q0 * (x - x0) + 4 * qm * (x - xm) + qb * (x - b))
    for xp, f, _ in points:
        M += f * np.clip(x - xp, 0.0, None)
    return M


@pytest.mark.parametrize("name", ["holding", "breakout", "full_lift"])
def test_each_design_case_closes_at_both_free_ends(setup, name):
    label, sc, hull, plan, plant, cases = setup
    c = next(c for c in cases if c.name == name)
    st = c.strength
    peak_M, peak_V = abs(st.max_moment.value), abs(st.max_shear.value)
    for end in (0, -1):
        assert abs(st.V[end]) <= 1e-6 * peak_V, (label, name, st.V[end], peak_V)
        assert abs(st.M[end]) <= 1e-6 * peak_M, (label, name, st.M[end], peak_M)
    # the closure against the one built here: scale, accelerations and the moment along the hull
    lines, points, s, a0, alpha = _closed_own(sc, hull, plan, plant, name)
    assert c.closure.scale == pytest.approx(s, rel=1e-9)
    assert c.closure.pitch_acceleration == pytest.approx(alpha, rel=1e-6, abs=1e-12 * abs(alpha) + 1e-15)
    assert abs(c.closure.heave_acceleration) <= 1e-9 * abs(a0) + 1e-12
    F, M_bow = _sums(lines, points, hull.length)
    assert abs(F) <= 1e-9 * peak_V and abs(M_bow) <= 1e-9 * peak_M
    own = _own_moment(lines, points, st.x)
    np.testing.assert_allclose(st.M, own, rtol=0, atol=1e-6 * peak_M)


def test_the_peak_is_no_longer_at_a_free_end(setup):
    label, sc, hull, plan, plant, cases = setup
    for c in cases:
        x = c.strength.max_moment.x
        assert 0.02 * hull.length < x < 0.98 * hull.length, (label, c.name, x)


def test_issue_23_hulls_before_and_after():
    """Today's open case peaked at the free bow; the closed cases put the trawler's peak
    hogging at its engine room and the bulk carrier's inside the hull, smaller."""
    tr = load_scenario(DATA / "trawler.yaml")
    hull = hull_from_scenario(tr)
    plan = plan_lift(tr, hull)
    _, open_st = paper_case(plan, hull)
    assert open_st.max_moment.x == pytest.approx(60.0)  # the artefact the issue reports
    assert open_st.closing_moment / 1e6 == pytest.approx(3.949, abs=1e-3)
    cases = {c.name: c for c in design(tr, hull, plan)}
    hold = cases["holding"].strength
    assert hold.max_moment.value / 1e6 == pytest.approx(-0.835, abs=1e-3)
    assert hold.max_moment.x == pytest.approx(9.4, abs=0.1)  # the engine at node 4, x = 9 m
    bc = load_scenario(DATA / "bulk_carrier.yaml")
    hull = hull_from_scenario(bc)
    plan = plan_lift(bc, hull)
    _, open_st = paper_case(plan, hull)
    assert open_st.closing_moment / 1e6 == pytest.approx(92.45, abs=0.01)
    peak = max(abs(c.strength.max_moment.value) for c in design(bc, hull, plan))
    assert peak / 1e6 == pytest.approx(77.27, abs=0.01)
    assert peak < 0.75 * abs(open_st.max_moment.value)


def test_inertia_uses_the_mass_that_moves_in_water(setup):
    """The pitch acceleration falls as the added mass grows (the moving mass is the structure
    plus the added mass plus the entrained water): with C_a = 0 it is the structure's alone."""
    label, sc, hull, plan, plant, cases = setup
    c = next(c for c in cases if c.name == "full_lift")
    dry = sc.with_changes(**{"hydro.added_mass_coefficient": 0.0})
    c_dry = next(c for c in design(dry, hull, plan, per_element=4) if c.name == "full_lift")
    assert c_dry.closure.moving_mass == pytest.approx(hull.total_mass, rel=1e-12)
    assert c.closure.moving_mass > 1.5 * hull.total_mass
    ratio = c.closure.pitch_acceleration / c_dry.closure.pitch_acceleration
    assert 0.05 < ratio < 0.7


def test_holding_case_uses_the_lifts_the_ascent_holds():
    """A staged pipeline flooded over its first 400 m: each stage's bags share their own
    stretch's weight (the ascent's neutral volumes), not the whole line's equally; the holding
    case takes those lifts and stays small (equal shares would bend it 16 MN m)."""
    sc = load_scenario("pipeline").with_changes(**{
        "pipe.segments": [{"from_m": 0.0, "to_m": 400.0, "contents": "flooded"}]})
    hull = hull_from_scenario(sc)
    plan = plan_lift(sc, hull)
    plant = coupled_plant(sc, hull, plan)
    hold = next(c for c in design(sc, hull, plan, plant, per_element=4) if c.name == "holding")
    expect = plant.neutral_volume * sc.environment.seawater_density_kg_m3 * sc.environment.gravity_m_s2
    np.testing.assert_allclose([hold.lifts[n] for n in plant.names], expect, rtol=1e-9)
    assert np.ptp(expect) > 0.3 * expect.mean()  # the flooded stages hold more
    st = hold.strength
    assert abs(st.max_moment.value) < 0.5e6
    assert abs(st.closing_moment) <= 1e-6 * abs(st.max_moment.value)
