"""The assembled, compiled plant against each law (docs/theory/loop.md#state, §8).

tests/test_physics.py checks each law of flexlift.physics on its own. These tests check that
the compiled ascent applies the laws with the scenario's coefficients: they build the tanker's
coupled plant and a run's state (flexlift.ascent.loop.Ascent), put the hull in a known state
(held on the seabed, or clear of it, moving, in a current), advance the loop's own compiled
step (flexlift.ascent.kernel.advance) and compare what it did with the law written out here
from the scenario's numbers. Where a piece is easier to reach directly (the strip loads, the
implicit mechanics) a small compiled harness calls the loop's function on the plant's records,
as the kernel does (``as_struct`` on the named tuples).

Unless a test needs them, the controllers are off: their sample period is made longer than the
run and the loop starts after its first sample, so the fill and purge commands are the ones a
test sets. The mutation check (benchmarks/mutate.py) runs these tests.
"""

import math

import numba
import numpy as np
import pytest

from flexlift import load_scenario
from flexlift._struct import as_struct
from flexlift.ascent import kernel, simulate
from flexlift.ascent.loop import Ascent
from flexlift.ascent.mechanics import (
    contact_matrices,
    implicit_matrix,
    strip_loads,
    trapezoidal_step,
)
from flexlift.ascent.paper import paper_plant
from flexlift.ascent.plant import coupled_plant
from flexlift.ascent.state import EV_SEPARATION, RET_DONE
from flexlift.constants import R_GAS
from flexlift.structure.hull import hull_from_scenario
from flexlift.structure.modes import compute_modes

SC = load_scenario("tanker")
ENV, HULL, HY, SB, GAS = SC.environment, SC.hull, SC.hydro, SC.seabed, SC.gas
RHO, G = ENV.seawater_density_kg_m3, ENV.gravity_m_s2
RHO_G = RHO * G
RT = R_GAS * ENV.sea_temperature_K
L, B, MASS = HULL.length_m, HULL.breadth_m, HULL.displacement_t * 1e3
A33 = HY.added_mass_coefficient * RHO * math.pi * B**2 / 4.0  # added mass per length [kg/m]
M_WET = MASS + A33 * L  # the hull and its added mass [kg]
W_WET = MASS * G * (1.0 - RHO / ENV.steel_density_kg_m3)  # W' [N]
RELIEF = GAS.relief_pressure_bar * 1e5  # [Pa]
EXTERNAL, INTERNAL = [0, 1, 2, 3], [4, 5, 6]  # the tanker's bags


def pressure(height):
    """Ambient pressure at ``height`` above the seabed [Pa] (docs/theory/gas.md#ambient-pressure)."""
    return ENV.atmospheric_pressure_Pa + RHO_G * (ENV.water_depth_m - height)


@pytest.fixture(scope="module")
def plant():
    return coupled_plant(SC)


def start(plant, scenario=SC, mode="decentralized", control=False):
    """A run at its start: the hull at rest on the held seabed; controllers off unless
    ``control`` (the loop then samples them at its first step)."""
    run = Ascent(scenario, plant, mode, 600.0, "table")
    if not control:
        run.settings = run.settings._replace(k_ctrl=10**9)
        run.state.counters[0] = 1
    return run


def clear(run, height, speed=0.0):
    """The hull separated, free of suction and of the seabed, rigidly at ``height`` [m] above
    it and moving at ``speed`` [m/s] (rigid heave only)."""
    R, a = run.state, run.plant
    R.sep[:], R.broken[:], R.H[:] = True, True, 0.0
    R.q[:], R.v[:] = 0.0, 0.0
    R.q[0], R.v[0] = height / a.modal.heave_row[0], speed / a.modal.heave_row[0]
    R.counters[1] = 0  # recompute the bags' motion and gas; no force history


def settle(run):
    """Held: the hull at rest on the seabed springs under the loads of its present gas (twice:
    the second time with the gas at the heights the first found). Returns the net uplift
    U = rho g sum V - W' [N] there, V by Boyle at the bags' heights."""
    R = run.state
    for _ in range(2):
        R.counters[1] = 0
        kernel.initial_equilibrium(run.inputs())
    R.v[:] = 0.0
    z = run.plant.bags.shape @ R.q
    V = np.minimum(R.n * RT / pressure(z), run.plant.bags.capacity)
    return RHO_G * V.sum() - W_WET


def advance(run, n=1):
    """``n`` steps of the compiled loop."""
    k = int(run.state.counters[0])
    code = kernel.advance(run.inputs(), k + n)
    assert code == RET_DONE and run.state.counters[0] == k + n


# ----------------------------------------------------------------------------- the plant
def test_the_hull_starts_neutral_on_the_seabed(plant):
    """The bags' buoyancy rho g V balances W' = m g (1 - rho / rho_steel) at the seabed's
    pressure, and the hull rests (on millimetres of static flexure: 1e-6 of the lift)."""
    run = start(plant)
    R = run.state
    assert RHO_G * R.V.sum() == pytest.approx(W_WET, rel=1e-12)
    advance(run)
    assert R.point.sum() == pytest.approx(W_WET, rel=1e-6)
    np.testing.assert_allclose(R.V[INTERNAL], plant.bags.capacity[INTERNAL], rtol=1e-12)
    assert np.abs(R.zd).max() < 1e-6


def test_wet_modes_include_the_added_mass(plant):
    """Heave is mass-normalised on the hull plus C_a rho pi B^2 / 4 per metre, and each
    flexible mode of the uniform hull is slower than the dry one by sqrt(m / (m + a_33))."""
    a = plant
    np.testing.assert_allclose(a.strips.shape[:, 0], 1.0 / math.sqrt(M_WET), rtol=1e-9)
    dry = compute_modes(hull_from_scenario(SC)).omega[2:a.modal.nr]
    wet = np.sqrt(a.modal.omega2[2:])
    m = MASS / L
    np.testing.assert_allclose(wet / dry, math.sqrt(m / (m + A33)), rtol=1e-8)


def test_the_wet_heave_on_the_seabed_springs(plant):
    """The contact springs in the implicit step: heave stiffness k L / M_wet, damping c L /
    M_wet, and every modal entry the springs' integral over the strips."""
    a = plant
    active = np.ones(a.strips.ns, np.bool_)
    stiff, damp = _contact(a.records, active)
    assert stiff[0, 0] == pytest.approx(SB.contact_stiffness_N_m2 * L / M_WET, rel=1e-9)
    assert damp[0, 0] == pytest.approx(SB.contact_damping_Ns_m2 * L / M_WET, rel=1e-9)
    np.testing.assert_allclose(stiff, (a.strips.force * SB.contact_stiffness_N_m2) @ a.strips.shape,
                               rtol=1e-12, atol=1e-12 * stiff[0, 0])
    np.testing.assert_allclose(damp, stiff * SB.contact_damping_Ns_m2 / SB.contact_stiffness_N_m2,
                               rtol=1e-12, atol=1e-12 * damp[0, 0])


# ----------------------------------------------------------------------------- loads
@pytest.mark.parametrize("current, speed", [(0.3, 0.0), (0.0, -0.4), (-0.2, 0.5)])
def test_a_hull_clear_of_the_seabed_feels_strip_and_bag_drag(plant, current, speed):
    """Clear of the seabed, in a vertical current: the strips feel -1/2 rho C_D B |u| u per
    metre and the external bags -1/2 rho C_D,bag (pi D^2 / 4) |u| u (D of a sphere of their
    capacity), u the velocity relative to the water; the heave accelerates at F / M_wet."""
    run = start(plant)
    clear(run, 20.0, speed)
    run.switches.current[0] = current
    R, a = run.state, plant
    n0 = R.n.copy()
    advance(run)
    u = speed - current
    strip = -0.5 * RHO * HY.drag_coefficient * B * abs(u) * u
    np.testing.assert_allclose(R.line, strip, rtol=1e-12)
    assert R.line @ a.strips.weight == pytest.approx(strip * L, rel=1e-12)
    V = np.minimum(n0 * RT / pressure(20.0), a.bags.capacity)  # Boyle at 20 m, capped
    D = (6.0 * a.bags.capacity / math.pi) ** (1.0 / 3.0)
    bag = -0.5 * RHO * HY.bag_drag_coefficient * math.pi * D**2 / 4.0 * abs(u) * u
    bag[INTERNAL] = 0.0  # inside the hull
    np.testing.assert_allclose(R.point, RHO_G * V + bag, rtol=1e-12)
    force = strip * L + R.point.sum() - W_WET
    heave_speed = a.modal.heave_row @ R.v
    assert heave_speed - speed == pytest.approx(run.settings.dt * force / M_WET, rel=1e-9)


def test_a_broken_sling_lifts_nothing(plant):
    """The bags' force on the hull is rho g V while the sling holds, zero after it breaks; the
    uplift the hold sees loses that bag too."""
    run = start(plant)
    clear(run, 20.0)
    run.switches.attached[1] = 0.0
    R = run.state
    V = np.minimum(R.n * RT / pressure(20.0), plant.bags.capacity)
    advance(run)
    attached = np.arange(7) != 1
    np.testing.assert_allclose(R.point, np.where(attached, RHO_G * V, 0.0), rtol=1e-12)
    assert R.gap[0] + R.H_old[0] == pytest.approx(RHO_G * V[attached].sum() - W_WET, rel=1e-9)


def test_released_suction_pulls_down_in_its_shape(plant):
    """After separation the remaining hold H is a downward line load H s(x), s linear from
    0.5 / L at the stern to 1.5 / L at the bow, and releases exactly as H exp(-t / tau_r)."""
    run = start(plant)
    clear(run, 20.0)
    R, a = run.state, plant
    R.H[0], R.broken[0] = 1.0e6, False
    advance(run)
    x = plant.strip_x
    shape = (SB.stern_ratio + (SB.bow_ratio - SB.stern_ratio) * x / L) / L
    np.testing.assert_allclose(R.line, -1.0e6 * shape, rtol=1e-12)
    assert R.line @ a.strips.weight == pytest.approx(-1.0e6, rel=1e-12)
    advance(run, 9)
    assert R.H[0] == pytest.approx(1.0e6 * math.exp(-10 * run.settings.dt / SB.release_time_s), rel=1e-12)


@numba.njit
def _strip_loads(plant, q, v, H, sep, current):
    """The loop's strip loads of ``plant`` (its records) at modal state q, q' (no force
    noise)."""
    ns = plant.strips.ns
    w, wv, line, contact = np.empty(ns), np.empty(ns), np.empty(ns), np.empty(ns)
    active = np.zeros(ns, np.bool_)
    strip_loads(as_struct(plant), q, v, H, sep, current, np.zeros(ns), w, wv, line, contact,
                active)
    return line, contact, active


@pytest.mark.parametrize("held, w, wdot, load", [
    (False, 0.01, 0.0, 0.0),  # above the seabed: nothing
    (False, -0.01, 0.0, "k"),  # below: the spring pushes up
    (False, -0.01, -0.1, "k+c"),  # sinking in: spring and damper
    (False, -0.01, 0.1, 0.0),  # lifting off fast: the damper would pull, the seabed cannot
    (True, 0.01, 0.0, "k"),  # held by suction: the spring holds it down (tension)
    (True, -0.01, 0.1, "k+c"),
])
def test_seabed_contact_as_the_loop_applies_it(plant, held, w, wdot, load):
    """Contact q = -k w - c w' per metre: one-sided once separated, bilateral while held."""
    a = plant
    k, c = SB.contact_stiffness_N_m2, SB.contact_damping_Ns_m2
    expected = {"k": -k * w, "k+c": -k * w - c * wdot}.get(load, load)
    q, v = np.zeros(a.modal.nr), np.zeros(a.modal.nr)
    q[0], v[0] = w / a.modal.heave_row[0], wdot / a.modal.heave_row[0]
    line, contact, active = _strip_loads(a.records, q, v, np.zeros(1), np.array([not held]), 0.0)
    np.testing.assert_allclose(contact, expected, rtol=1e-12, atol=1e-9)
    assert active.all() == (held or expected != 0.0) and active.all() == active.any()


# ----------------------------------------------------------------------------- gas
def test_gas_follows_boyle_and_closed_bags_vent_at_their_relief(plant):
    """Rising at 0.5 m/s with no flows: the open bags keep their gas, V = n R T / p(z); the
    closed (full) bags vent down to (p + relief) V_max / (R T)."""
    run = start(plant)
    clear(run, 20.0, 0.5)
    R, a = run.state, plant
    n0, V0 = R.n.copy(), R.V.copy()
    advance(run, 20)
    p = pressure(R.z)
    np.testing.assert_array_equal(R.n[EXTERNAL], n0[EXTERNAL])
    np.testing.assert_allclose(R.V[EXTERNAL], n0[EXTERNAL] * RT / p[EXTERNAL], rtol=1e-12)
    assert np.all(R.V[EXTERNAL] > 1.05 * V0[EXTERNAL])  # it did expand
    np.testing.assert_allclose(R.n[INTERNAL], (p[INTERNAL] + RELIEF) * a.bags.capacity[INTERNAL] / RT,
                               rtol=1e-12)
    np.testing.assert_allclose(R.V[INTERNAL], a.bags.capacity[INTERNAL], rtol=1e-12)


def test_spill_at_capacity_and_relief_at_its_setting(plant):
    """Over-filled: an open bag spills to its capacity at ambient pressure, a closed bag vents
    to its capacity at ambient plus the relief setting; the vented gas is counted."""
    run = start(plant)
    R, a = run.state, plant
    for i in (0, 4):
        R.n[i] = 1.5 * R.p[i] * a.bags.capacity[i] / RT
    settle(run)
    n0 = R.n.copy()
    advance(run)
    assert R.n[0] * RT / R.p[0] == pytest.approx(a.bags.capacity[0], rel=1e-12)
    assert R.n[4] * RT / a.bags.capacity[4] - R.p[4] == pytest.approx(RELIEF, rel=1e-6)
    assert R.vented[0] == pytest.approx((n0[0] - R.n[0]) * RT / R.p[0], rel=1e-9)
    assert R.vented[1] == 0.0 and R.n[1] == n0[1]  # within its capacity: nothing


@pytest.mark.parametrize("opening", [0.3, 1.0])
def test_the_purge_flow_integrated_is_the_orifice_law(plant, opening):
    """Valve open at u on a held bag: dV/dt = -u Q_out,max sqrt(V / V_max), so sqrt(V) falls
    linearly, sqrt(V) = sqrt(V_0) - u Q t / (2 sqrt(V_max)); the purged volume is counted."""
    run = start(plant)
    R, a = run.state, plant
    R.opening[0] = opening
    V0, n0, p0 = R.V[0], R.n[0], R.p[0]
    advance(run, 100)
    t = 100 * run.settings.dt
    Q, Vmax = GAS.purge_rate_max_m3_s, a.bags.capacity[0]
    V = (math.sqrt(V0) - opening * Q * t / (2.0 * math.sqrt(Vmax))) ** 2
    assert R.purged[0] == pytest.approx(V0 - V, rel=1e-5)
    # the gas left, at the starting pressure (the bag sinks ~4 mm as it loses lift: p + 1e-5)
    assert R.n[0] * RT / p0 == pytest.approx(V, rel=1e-6)
    assert R.n[1] == n0  # the other bags are shut


def test_a_bag_purged_empty_within_a_step_counts_that_steps_purge(plant):
    """The purge account adds 0.5 dt (Q_0 + Q_1) a step (Heun); a bag whose predicted gas runs
    out within the step (so Q_1 = 0, the valve still open) counts its start-of-step purge Q_0:
    the step's account is not skipped."""
    run = start(plant)
    R, a = run.state, plant
    dt, Q = run.settings.dt, GAS.purge_rate_max_m3_s
    R.opening[0] = 1.0
    V_small = 0.5 * (dt * Q) ** 2 / a.bags.capacity[0]  # below (dt Q)^2 / V_max: empty in a step
    R.n[0] = V_small * R.p[0] / RT
    advance(run)
    purge0 = R.flow0[1, 0]
    assert purge0 > 0.0 and dt * purge0 > V_small  # the Euler prediction is empty: Q_1 = 0
    assert R.purged[0] == pytest.approx(0.5 * dt * purge0, rel=1e-12)


def test_fill_and_a_failed_supply(plant):
    """A fill command Q_in at local pressure adds p Q_in / (R T) mol/s; with the supply failed
    the same command adds nothing."""
    run = start(plant)
    R, W = run.state, run.switches
    R.fill[0] = R.fill[1] = 0.5
    W.supply[1] = 0.0
    n0, p0 = R.n.copy(), R.p.copy()
    advance(run, 50)
    t = 50 * run.settings.dt
    assert R.gas_local[0] == pytest.approx(0.5 * t, rel=1e-12)
    assert R.n[0] - n0[0] == pytest.approx(p0[0] * 0.5 * t / RT, rel=1e-5)
    assert R.gas_local[1] == 0.0 and R.n[1] == n0[1]


def test_a_ruptured_bag_leaks_at_one_over_its_leak_time(plant):
    """dn/dt = -n / tau: after tau the bag holds 1/e of its gas (to the second-order accuracy
    of the gas step: an Euler step would be 2.5e-3 off here)."""
    run = start(plant)
    R = run.state
    tau = 20.0
    run.switches.leak[4] = 1.0 / tau
    n0 = R.n.copy()
    advance(run, int(round(tau / run.settings.dt)))
    assert R.n[4] / n0[4] == pytest.approx(math.exp(-1.0), rel=5e-5)
    assert R.n[5] == n0[5]


# ----------------------------------------------------------------------------- the hold
@pytest.mark.parametrize("frac", [0.25, 0.9])
def test_the_hold_decays_under_the_pull(plant, frac):
    """Held under a net uplift U < H_0: dH/dt = -(H_0 / T_b) min(U / H_0, 1)."""
    run = start(plant)
    R, a = run.state, plant
    H0 = a.seabed.H0[0]
    assert H0 == pytest.approx((SC.lift.breakout_factor - 1.0) * W_WET, rel=1e-9)
    R.n[EXTERNAL] += (frac * H0 / RHO_G / 4) * R.p[EXTERNAL] / RT
    U = settle(run)
    assert U == pytest.approx(frac * H0, rel=1e-3)
    advance(run, 20)
    rate = (H0 / SB.breakout_time_s) * min(U / H0, 1.0)
    assert H0 - R.H[0] == pytest.approx(20 * run.settings.dt * rate, rel=1e-6)
    assert not R.sep[0]


def test_separation_is_located_inside_the_step_then_the_hold_releases(plant):
    """The hold falls below the uplift 30 % into a step: separation is logged there, and the
    hold released exactly from U over the remaining 70 % (then H exp(-dt / tau_r) a step)."""
    run = start(plant)
    R, a, dt = run.state, plant, run.settings.dt
    H0 = a.seabed.H0[0]
    R.n[EXTERNAL] += (0.5 * H0 / RHO_G / 4) * R.p[EXTERNAL] / RT
    U = settle(run)
    rate = (H0 / SB.breakout_time_s) * U / H0
    R.H[0] = U + 0.3 * dt * rate
    t = R.counters[0] * dt
    advance(run)
    rec = run.recorder
    events = [(rec.ev_t[k], rec.ev_code[k]) for k in range(rec.counts[2])]
    assert [e[1] for e in events] == [EV_SEPARATION]
    assert events[0][0] == pytest.approx(t + 0.3 * dt, abs=1e-9)
    assert R.sep[0]
    tau = SB.release_time_s
    assert R.H[0] == pytest.approx(U * math.exp(-0.7 * dt / tau), rel=1e-9)
    advance(run, 10)
    assert R.H[0] == pytest.approx(U * math.exp(-10.7 * dt / tau), rel=1e-9)


# ----------------------------------------------------------------------------- mechanics
@numba.njit
def _contact(plant, active):
    """The loop's modal contact stiffness and damping of the ``active`` strips."""
    nr = plant.modal.nr
    stiff, damp = np.zeros((nr, nr)), np.zeros((nr, nr))
    contact_matrices(as_struct(plant), active, stiff, damp)
    return stiff, damp


@numba.njit
def _mechanics(plant, q, v, b, h, active, n):
    """``n`` steps of ``h`` [s] of the loop's implicit mechanics on ``plant`` (its records)
    under a constant force ``b``, with the contact springs of the ``active`` strips; q at
    every step."""
    ps = as_struct(plant)
    nr = q.size
    stiff, damp = np.zeros((nr, nr)), np.zeros((nr, nr))
    implicit, work = np.zeros((nr, nr)), np.zeros(nr)
    contact_matrices(ps, active, stiff, damp)
    implicit_matrix(ps, h, stiff, damp, implicit)
    out = np.empty((n, nr))
    for k in range(n):
        trapezoidal_step(ps, q, v, b, h, implicit, stiff, damp, work)
        out[k] = q
    return out


def test_modal_damping_is_two_zeta_omega(plant):
    """Free vibration of each retained flexible mode decays as exp(-zeta omega t) with the
    hull's zeta: q'' + 2 zeta omega q' + omega^2 q = 0 (2000 steps a period: the integrator's
    own error is below 1e-4)."""
    a = plant
    zeta = HULL.modal_damping
    for j in range(2, a.modal.nr):
        om = math.sqrt(a.modal.omega2[j])
        h = 2 * math.pi / om / 2000
        q = np.zeros(a.modal.nr)
        q[j] = 1.0
        out = _mechanics(a.records, q, np.zeros(a.modal.nr), np.zeros(a.modal.nr), h, np.zeros(a.strips.ns, np.bool_), 6000)
        t = h * np.arange(1, 6001)
        wd = om * math.sqrt(1 - zeta**2)
        exact = np.exp(-zeta * om * t) * (np.cos(wd * t) + zeta * om / wd * np.sin(wd * t))
        np.testing.assert_allclose(out[:, j], exact, atol=1e-4, err_msg=f"mode {j}")


@pytest.mark.parametrize("contact", [False, True])
def test_the_step_is_the_trapezoidal_rule(plant, contact):
    """One step of the simulation's length against the trapezoidal rule solved here:
    q1 = q0 + h/2 (v0 + v1), v1 = v0 + h/2 (a0 + a1), a = b - K q - C v, with K, C the modal
    stiffness and damping plus the seabed springs of the strips in contact."""
    a = plant
    h = SC.simulation.time_step_s
    rng = np.random.default_rng(7)
    q0, v0, b = rng.normal(size=(3, a.modal.nr))
    active = np.full(a.strips.ns, contact)
    K, C = np.diag(a.modal.omega2), np.diag(2 * HULL.modal_damping * np.sqrt(a.modal.omega2))
    if contact:
        K = K + (a.strips.force * SB.contact_stiffness_N_m2) @ a.strips.shape
        C = C + (a.strips.force * SB.contact_damping_Ns_m2) @ a.strips.shape
    I = np.eye(a.modal.nr)
    M = np.block([[I, -h / 2 * I], [h / 2 * K, I + h / 2 * C]])
    rhs = np.concatenate([q0 + h / 2 * v0, v0 + h / 2 * (b - K @ q0 - C @ v0) + h / 2 * b])
    q1 = np.linalg.solve(M, rhs)[:a.modal.nr]
    out = _mechanics(a.records, q0.copy(), v0.copy(), b, h, active, 1)
    np.testing.assert_allclose(out[0], q1, rtol=1e-10, atol=1e-12)


# ----------------------------------------------------------------------------- the paper's plant
def test_the_papers_bag_feels_its_tributary_share(plant):
    """docs/theory/loop.md#paper-plant: the force on each uncoupled bag model is its own lift and bag drag minus its
    tributary share (by hull length) of the wet weight net of the internal bags, of the
    suction and of the hull drag; each bag starts neutral on its share."""
    pp = paper_plant(SC, coupled=plant)
    a = pp
    x = pp.x_point
    order = np.argsort(x)
    edges = np.concatenate([[0.0], 0.5 * (x[order][1:] + x[order][:-1]), [L]])
    trib = np.empty(x.size)
    trib[order] = np.diff(edges)
    net = W_WET - RHO_G * plant.bags.capacity[INTERNAL].sum()
    share = net * trib / L
    np.testing.assert_allclose(RHO_G * pp.neutral_volume, share, rtol=1e-12)
    run = Ascent(SC, pp, "paper", 600.0, "table")
    run.settings = run.settings._replace(k_ctrl=10**9)
    R = run.state
    R.counters[0], R.counters[1] = 1, 0
    R.sep[:], R.broken[:] = True, True
    R.H[:] = np.array([1e5, 2e5, 3e5, 4e5])
    speed = -0.3
    for k in range(a.bags.nb):
        sl = slice(2 * k, 2 * k + 2)
        c = a.bags.shape[k, sl]
        R.q[sl], R.v[sl] = 20.0 * c / (c @ c), speed * c / (c @ c)
    V = R.n * RT / pressure(20.0)
    advance(run)
    D = (6.0 * a.bags.capacity / math.pi) ** (1.0 / 3.0)
    bag_drag = -0.5 * RHO * HY.bag_drag_coefficient * math.pi * D**2 / 4.0 * abs(speed) * speed
    hull_drag = -0.5 * RHO * HY.drag_coefficient * B * abs(speed) * speed * trib
    expected = RHO_G * V + bag_drag - share + hull_drag - R.H / math.exp(-0.1 / SB.release_time_s)
    for k in range(a.bags.nb):
        sl = slice(2 * k, 2 * k + 2)
        f = a.bags.force[sl, k]
        np.testing.assert_allclose(R.b[sl], f * expected[k], rtol=1e-9, err_msg=f"bag {k}")


# ----------------------------------------------------------------------------- coordination
@pytest.mark.parametrize("what", ["angle", "rate"])
def test_coordination_in_the_loop_opposes_a_pitching_hull(plant, what):
    """Coordinated mode, the hull clear and pitched (or pitching) bow-up: the loop's sample
    shifts every desired volume by -k theta xi_i (or -k' theta' xi_i), less gas at the bow."""
    theta = 1e-3
    key = {"angle": "pitch_gain_m3_rad", "rate": "pitch_rate_gain_m3s_rad"}[what]
    V_d = []
    for sc in (SC, SC.with_changes(**{f"control.coordination.{key}": 0.0})):
        run = start(plant, sc, "coordinated", control=True)
        clear(run, 20.0)
        row = 0 if what == "angle" else 1
        [run.state.q, run.state.v][row][1] = theta / plant.modal.pitch_row[1]
        advance(run)
        V_d.append(run.control_state.V_d.copy())
    gain = getattr(SC.control.coordination, key)
    lever = run.controllers.lever
    np.testing.assert_allclose(V_d[0] - V_d[1], -gain * theta * lever, rtol=1e-6)
    assert lever[-1] > 0 and V_d[0][-1] < V_d[1][-1]  # the bow bag is asked for less


# ----------------------------------------------------------------------------- faults
QUICK = {"control.target_height_m": 40.0, "seabed.breakout_time_s": 100.0}


def test_a_sling_break_fault_removes_the_bag(plant):
    fault = {"kind": "sling_break", "bag": "bag_1", "time_s": 10.0}
    r = simulate(SC.with_changes(**QUICK, faults=[fault]), duration=20.0, plant=plant)
    ds = r.dataset
    lift = ds.sling_force.sel(bag="bag_1").values  # the sling: 0 once broken
    t = ds.time.values
    assert np.all(lift[t < 10.0] > 1e6) and np.all(lift[t >= 10.0] == 0.0)
    V = ds.gas_volume.values[-1]
    assert ds.uplift.values[-1] == pytest.approx(RHO_G * V[1:].sum() - W_WET, rel=1e-9)


def test_a_supply_failure_fault_stops_filling(plant):
    fault = {"kind": "supply_failure", "bag": "bag_2", "time_s": 0.0}
    r = simulate(SC.with_changes(**QUICK, faults=[fault]), control="open-loop", duration=30.0,
                 plant=plant)
    ds = r.dataset
    used = ds.gas_used_local.values
    assert used[1] == 0.0 and np.all(used[[0, 2, 3]] > 10.0)
    assert np.all(ds.fill_rate.sel(bag="bag_2").values == 0.0)


def test_a_fill_valve_stuck_closed_stops_that_bags_fill_from_its_step(plant):
    """From 10 s bag_2's fill valve is stuck closed: its gas (p V, Boyle at the sea's
    temperature) does not grow after the fault's step while the open-loop commands still ask
    for fill; the other bags' commands are those of the run without the fault, to the bit, and
    their gas too (within the cm the hull moves on the seabed). Its purge still works."""
    t_f = 10.0
    fault = {"kind": "fill_valve_stuck_closed", "bag": "bag_2", "time_s": t_f}
    sc = SC.with_changes(**QUICK)
    r = simulate(sc.with_changes(faults=[fault]), control="open-loop", duration=30.0,
                 plant=plant)
    free = simulate(sc, control="open-loop", duration=30.0, plant=plant)
    ds, ds0 = r.dataset, free.dataset
    t = ds.time.values
    k0 = int(np.searchsorted(t, t_f))
    assert t[k0] == t_f  # the fault's step starts at an output sample
    env = SC.environment

    def gas(d, bag):  # p V of the bag [Pa m^3], proportional to its moles
        p = env.atmospheric_pressure_Pa + RHO_G * (env.water_depth_m - d.height.sel(bag=bag))
        return (p * d.gas_volume.sel(bag=bag)).values

    pv, pv0 = gas(ds, "bag_2"), gas(ds0, "bag_2")
    np.testing.assert_array_equal(pv[: k0 + 1], pv0[: k0 + 1])  # the same up to the step
    # then no gas in: p V per 1 s sample within 1e-8 (p from the point's recorded height;
    # one sample of the free fill is ~1e-3 of it)
    assert np.all(np.diff(pv[k0:]) <= 1e-8 * pv[k0])
    assert pv0[k0 + 1] > pv[k0 + 1] and pv0[-1] > 1.01 * pv[-1]  # which the free bag takes
    q = ds.fill_rate.sel(bag="bag_2").values
    assert np.all(q[t > t_f] == 0.0) and np.all(ds0.fill_rate.sel(bag="bag_2").values[t > t_f] > 0)
    others = [b for b in ds.bag.values if b != "bag_2"]
    for var in ("fill_rate", "purge_opening"):
        np.testing.assert_array_equal(ds[var].sel(bag=others).values,
                                      ds0[var].sel(bag=others).values)
    for b in others:
        np.testing.assert_allclose(gas(ds, b), gas(ds0, b), rtol=1e-6)
    np.testing.assert_array_equal(ds.purge_opening.sel(bag="bag_2").values,
                                  ds0.purge_opening.sel(bag="bag_2").values)


def test_a_rupture_fault_leaks_at_its_leak_time(plant):
    fault = {"kind": "bag_rupture", "bag": "bag_5", "time_s": 0.0, "leak_time_s": 20.0}
    r = simulate(SC.with_changes(**QUICK, faults=[fault]), control="open-loop", duration=20.0,
                 plant=plant)
    V = r.dataset.gas_volume.sel(bag="bag_5").values
    assert V[-1] == pytest.approx(plant.bags.capacity[4] * math.exp(-1.0), rel=2e-4)
