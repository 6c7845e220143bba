"""Step control where nothing moves (kernel.held_block, kernel.quiet_step: the pull, every
group held and no bag filling or purging): the same ascent as every step alike, on the tanker
in both control modes, the pipeline and an own hull (the trawler of tests/data): the criteria
identical, the events at the same times within one base step, the headline peaks within 1e-3
relative (they agree to ~1e-5 and better), the recorded rows at their times; the fill itself
in base steps, bit for bit the run without step control; a fault in the pull ends the
quiet."""

from pathlib import Path

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent import simulate
from flexlift.ascent.loop import HELD_STEP_S, held_steps
from flexlift.ascent.state import Settings

TRAWLER = Path(__file__).parent / "data" / "trawler.yaml"
CASES = {"tanker": lambda: load_scenario("tanker"),
         "tanker coordinated": lambda: load_scenario("tanker").with_changes(
             **{"control.mode": "coordinated"}),
         "pipeline": lambda: load_scenario("pipeline"),
         "trawler": lambda: load_scenario(TRAWLER)}


@pytest.fixture(scope="module", params=sorted(CASES))
def pair(request):
    sc = CASES[request.param]()
    return sc, simulate(sc, step_control=False), simulate(sc, step_control=True)


def _peak(ds, name):
    return float(np.nanmax(np.abs(ds[name].values)))


def test_the_criteria_are_identical(pair):
    _, base, held = pair
    assert held.criteria == base.criteria
    assert held.outcome["kind"] == base.outcome["kind"]


def test_the_events_are_within_one_base_step(pair):
    sc, base, held = pair
    assert [(e["kind"], e["bag"]) for e in held.events] == [
        (e["kind"], e["bag"]) for e in base.events]
    dt = sc.simulation.time_step_s
    for a, b in zip(base.events, held.events):
        assert abs(a["time_s"] - b["time_s"]) <= dt + 1e-9, (a, b)


def test_the_headline_peaks_are_within_1e_3(pair):
    _, base, held = pair
    a, b = base.dataset, held.dataset
    names = ["ascent_velocity", "sling_force", "heave"]
    names += [n for n in ("pitch", "bending_moment", "shear_force") if n in a]
    for name in names:
        assert _peak(b, name) == pytest.approx(_peak(a, name), rel=1e-3), name
    for key in ("max_ascent_velocity_ms", "max_descent_velocity_ms", "max_pitch_deg"):
        if base.headline.get(key) is not None:  # rounded to 4 decimals
            assert held.headline[key] == pytest.approx(base.headline[key], rel=1e-3, abs=1e-4)


def test_the_rows_are_at_their_times_and_step_control_is_on(pair):
    _, base, held = pair
    np.testing.assert_array_equal(held.dataset.time.values, base.dataset.time.values)
    # the held phase is stepped differently (not the same numbers to the last bit)
    assert not np.array_equal(held.dataset.contact_force.values,
                              base.dataset.contact_force.values)


def test_force_noise_keeps_every_step():
    """Force noise changes the loads every step: no held blocks, the run bit for bit the same."""
    sc = load_scenario("tanker").with_changes(**{
        "control.target_height_m": 40.0, "seabed.breakout_time_s": 100.0,
        "simulation.hold_time_s": 60.0, "simulation.duration_s": 400.0,
        "disturbance.force_noise_N_m": 500.0})
    a, b = simulate(sc, step_control=False), simulate(sc, step_control=True)
    np.testing.assert_array_equal(a.dataset.height.values, b.dataset.height.values)
    np.testing.assert_array_equal(a.dataset.contact_force.values,
                                  b.dataset.contact_force.values)


def _settings(dt, k_out, k_ctrl=1):
    return Settings(dt=dt, n_steps=10, k_ctrl=k_ctrl, k_out=k_out, k_str=k_out, target=1.0,
                    tol=0.1, hold_time=1.0, v_limit=1.0, v_down_limit=1.0, pitch_limit=1.0,
                    top_limit=np.zeros(1), external=False, held_steps=1, held_margin=0.05,
                    release_step=0.9)


@pytest.mark.parametrize("dt, k_out, k_ctrl, m", [
    (0.1, 10, 1, 10), (0.1, 20, 1, 10), (0.1, 15, 1, 5), (0.05, 30, 1, 15), (0.5, 4, 1, 2),
    (2.0, 5, 1, 1), (0.1, 7, 1, 7), (0.1, 1, 1, 1),
    (0.1, 10, 3, 1), (0.1, 12, 3, 6), (0.1, 10, 2, 10), (0.1, 10, 5, 10), (0.05, 20, 4, 20)])
def test_a_held_block_divides_the_row_interval_in_whole_samples(dt, k_out, k_ctrl, m):
    """A block is a divisor of the row interval, a whole number of control samples (its first
    step is a sample) and at most HELD_STEP_S long; 1 (off) where none is."""
    got = held_steps(_settings(dt, k_out, k_ctrl))
    assert got == m
    assert k_out % got == 0 and (got == 1 or (got * dt <= HELD_STEP_S + 1e-9
                                              and got % k_ctrl == 0))


def _run_to(sc, plant, k):
    from flexlift.ascent import kernel
    from flexlift.ascent.loop import Ascent

    run = Ascent(sc, plant, "coordinated", 3000.0, "table")
    run._room(k)
    kernel.advance(run.inputs(), k)
    return run


def test_blocks_run_in_the_quiet_pull_only():
    """No block while the bags fill (the step after the last fill command is still a base
    step); blocks, quiet, in the pull; base steps again before the step of the separation (the
    uplift within the margin of the hold)."""
    from flexlift.ascent.plant import coupled_plant
    from flexlift.ascent.state import F_HELD, F_QUIET

    sc = load_scenario("tanker")
    plant = coupled_plant(sc)
    ref = simulate(sc, plant=plant, control="coordinated")
    t_sep = next(e["time_s"] for e in ref.events if e["kind"] == "separation")
    ds = ref.dataset
    filling = ds.time.values[(np.nan_to_num(ds.fill_rate.values) > 0).any(axis=1)
                             & (ds.time.values < t_sep)]
    dt = sc.simulation.time_step_s
    last_fill = int(round(filling.max() / dt))
    for k, held in ((last_fill, False), (10005, True), (int(t_sep / dt) - 1, False)):
        run = _run_to(sc, plant, k)
        flags = run.state.counters[1]
        assert bool(flags & F_HELD) is held, k
        assert bool(flags & F_QUIET) is held, k
        assert not run.state.sep.any()
        if not held and k == last_fill:
            assert run.state.fill.any()  # still filling: base steps


def test_the_fill_is_the_run_without_step_control_bit_for_bit():
    """Until the first block (the fill, to its end) the two runs are the same numbers."""
    sc = load_scenario("tanker")
    a, b = (simulate(sc, control="coordinated", step_control=s, duration=150.0)
            for s in (False, True))
    ta = a.dataset.time.values
    fill = (np.nan_to_num(a.dataset.fill_rate.values) > 0).any(axis=1)
    upto = ta <= ta[fill].max()  # the run ends before separation: the fill's rows
    assert 50.0 < ta[fill].max() < 140.0
    for name in ("height", "gas_volume", "fill_rate", "contact_force"):
        np.testing.assert_array_equal(a.dataset[name].values[upto], b.dataset[name].values[upto],
                                      err_msg=name)


@pytest.mark.parametrize("fault", [
    {"kind": "sensor_drift", "bag": "bag_1", "time_s": 500.0, "rate_m_s": 0.001},
    {"kind": "bag_rupture", "bag": "bag_1", "time_s": 500.05, "leak_time_s": 200.0}])
def test_a_fault_in_the_quiet_pull_ends_the_quiet(fault):
    """A fault inside a held block (the rupture between a block's steps) ends it: the steps
    from the fault on are base steps, the run as every step alike to 1e-6 (of a metre, a cubic
    metre, the largest contact force)."""
    from flexlift.ascent.plant import coupled_plant
    from flexlift.ascent.state import F_HELD, F_QUIET

    sc = load_scenario("tanker").with_changes(faults=[fault])
    plant = coupled_plant(sc)
    run = _run_to(sc, plant, 5003)
    assert run.state.counters[1] & F_QUIET and run.state.counters[1] & F_HELD
    run._fault(sc.faults[0], 5003 * 0.1)
    assert not run.state.counters[1] & (F_QUIET | F_HELD)
    a, b = (simulate(sc, plant=plant, control="coordinated", step_control=s, duration=1500.0)
            for s in (False, True))
    assert [(e["kind"], e["bag"]) for e in a.events] == [(e["kind"], e["bag"]) for e in b.events]
    for name in ("height", "gas_volume", "contact_force"):
        ref = a.dataset[name].values
        np.testing.assert_allclose(b.dataset[name].values, ref, rtol=1e-6,
                                   atol=1e-6 * max(np.abs(ref).max(), 1.0), err_msg=name)


def _ascent(sc, plant, **settings):
    from flexlift.ascent.loop import Ascent

    run = Ascent(sc, plant, "coordinated", 1950.0, "table")  # to past the lift-off
    run.settings = run.settings._replace(**settings)
    return run


def test_a_separation_inside_a_block_ends_its_quiet():
    """A snapshot at every step (each inner step the whole step but its control sample) and
    blocks up to the hold itself (no margin): the separation falls in a whole step inside a
    block, which ends the quiet there: the next step moves the structure. The run agrees
    with every step alike (the criteria, the events within one base step)."""
    from flexlift.ascent import kernel
    from flexlift.ascent.plant import coupled_plant
    from flexlift.ascent.state import F_QUIET

    sc = load_scenario("tanker")
    plant = coupled_plant(sc)
    res = _ascent(sc, plant, k_str=1, held_margin=-1.0).run(summary_only=True)
    ref = simulate(sc, plant=plant, control="coordinated", step_control=False, duration=1950.0)
    assert res.criteria == ref.criteria
    dt = sc.simulation.time_step_s
    for a, b in zip(ref.events, res.events):
        assert (a["kind"], a["bag"]) == (b["kind"], b["bag"])
        assert abs(a["time_s"] - b["time_s"]) <= dt + 1e-9, (a, b)
    t_sep = next(e["time_s"] for e in res.events if e["kind"] == "separation")
    k_sep = int(t_sep / dt)  # the step whose interval holds the separation
    run = _ascent(sc, plant, k_str=1, held_margin=-1.0)
    run._room(k_sep + 2)
    kernel.advance(run.inputs(), k_sep)
    assert run.state.counters[1] & F_QUIET and not run.state.sep.any()
    kernel.advance(run.inputs(), k_sep + 1)
    assert run.state.sep.all() and not run.state.counters[1] & F_QUIET
    q = run.state.q.copy()
    kernel.advance(run.inputs(), k_sep + 2)
    assert not np.array_equal(run.state.q, q)  # the step after the separation moves


def test_a_fault_outside_a_block_changes_nothing_else():
    """Without step control a fault that does nothing (a drift of 0 m/s) leaves the run bit
    for bit as without it: no block to end, no force extrapolation restarted."""
    sc = load_scenario("tanker").with_changes(**{"simulation.duration_s": 300.0})
    drift = sc.with_changes(faults=[{"kind": "sensor_drift", "bag": "bag_1", "time_s": 30.0,
                                     "rate_m_s": 0.0}])
    a, b = (simulate(x, control="coordinated", step_control=False) for x in (sc, drift))
    for name in ("height", "gas_volume", "contact_force"):
        np.testing.assert_array_equal(a.dataset[name].values, b.dataset[name].values,
                                      err_msg=name)


def test_a_quiet_blocks_later_inner_steps_are_its_first_inner_steps_bit_for_bit():
    """After a quiet block's first inner step only the hold's part of the step's start is
    taken again (``F_STILL``): the run is the run that takes every inner step whole (the flag
    cleared before each step), to the bit, through the pull and a separation inside a quiet
    block (blocks up to the hold itself: it redoes its step from the q, q' kept at the
    step's start): every recorded row, snapshot and event, and the state at the end."""
    from flexlift.ascent import kernel
    from flexlift.ascent.loop import Ascent
    from flexlift.ascent.plant import coupled_plant
    from flexlift.ascent.state import F_QUIET, F_STILL

    sc = load_scenario("tanker").with_changes(**{"seabed.breakout_time_s": 150.0})
    plant = coupled_plant(sc)
    fast, whole = (Ascent(sc, plant, "coordinated", 800.0, "table") for _ in range(2))
    n = fast.settings.n_steps
    for run in (fast, whole):
        run.settings = run.settings._replace(held_margin=-1.0)
        run._room(n + 1)
    kernel.advance(fast.inputs(), n + 1)
    still = quiet = 0
    for k in range(n + 1):
        still += bool(whole.state.counters[1] & F_STILL)
        quiet += bool(whole.state.counters[1] & F_QUIET)
        was_still = bool(whole.state.counters[1] & F_STILL)
        whole.state.counters[1] &= ~F_STILL
        separated = whole.state.sep.any()
        if kernel.advance(whole.inputs(), k + 1) != 0:
            break
        if whole.state.sep.any() and not separated:  # inside a quiet block, past its first
            assert was_still and k % whole.settings.held_steps > 1, k  # inner step
    assert quiet > 1000 and still > 1000  # the fast path was there to be taken
    # stepped alone, the flag is set by an inner step and cleared by any other step
    lone = Ascent(sc, plant, "coordinated", 800.0, "table")
    lone.settings = lone.settings._replace(held_margin=-1.0)
    lone._room(n + 1)
    s = lone.settings
    for k in range(n + 1):
        inner = (bool(lone.state.counters[1] & F_QUIET) and k % s.held_steps != 0
                 and k % s.k_str != 0)
        if kernel.advance(lone.inputs(), k + 1) != 0:
            break
        assert bool(lone.state.counters[1] & F_STILL) is inner, k
    assert whole.state.sep.all() and fast.state.sep.all()  # through the separation
    for name in ("q", "v", "n", "H", "z", "V", "p", "gas_local", "vented"):
        np.testing.assert_array_equal(getattr(fast.state, name), getattr(whole.state, name),
                                      err_msg=name)
    for name, a in fast.recorder._asdict().items():
        np.testing.assert_array_equal(a, getattr(whole.recorder, name), err_msg=name)


def test_the_steps_constants_are_the_laws_to_the_bit():
    """The loop's per-step constants, computed once: a released hold's factor over a step is
    the law's own H exp(-dt / tau_r) of 1 N, and the measurement filter's gain the formula
    the controller evaluated at every sample before."""
    import math

    from flexlift.ascent.loop import Ascent
    from flexlift.ascent.plant import coupled_plant
    from flexlift.physics.seabed import released_holding

    sc = load_scenario("tanker").with_changes(**{"control.measurement_filter_s": 2.0})
    run = Ascent(sc, coupled_plant(sc), "coordinated", 100.0, "table")
    dt, tau = run.settings.dt, run.records.seabed.release_time
    assert run.settings.release_step == released_holding(1.0, dt, tau) == math.exp(-dt / tau)
    for H in (1.0, 3.7e6, 1e-300, 0.0):
        assert H * run.settings.release_step == released_holding(H, dt, tau)
    c = run.controllers
    assert c.filter_time == 2.0
    assert c.filter_gain == 1.0 - math.exp(-c.period / c.filter_time)


def test_the_pitch_limit_and_largest_pitch_are_every_steps_own_atan():
    """The loop takes the pitch's arc tangent only at a new largest |tan|: the largest pitch
    and the step of the pitch-limit event are, to the bit, those of |atan| taken at every
    step (the loop's own dot product, in order), stepping the run one step at a time."""
    import math

    from flexlift.ascent import kernel
    from flexlift.ascent.loop import Ascent
    from flexlift.ascent.plant import coupled_plant
    from flexlift.ascent.state import EV_LIMIT_PITCH

    sc = load_scenario("tanker").with_changes(**{"seabed.breakout_time_s": 60.0,
                                                 "limits.pitch_deg": 0.05})
    run = Ascent(sc, coupled_plant(sc), "coordinated", 900.0, "table")
    n, s = run.settings.n_steps, run.state
    run._room(n + 1)
    row = run.records.modal.pitch_row
    largest, first = 0.0, None
    for k in range(n + 1):
        if s.sep.any():  # limits() runs at the start of every step once separated
            tan = 0.0
            for i in range(row.size):
                tan += row[i] * s.q[i]
            pitch = abs(math.atan(tan))
            largest = max(largest, pitch)
            if first is None and pitch > run.settings.pitch_limit:
                first = k
        if kernel.advance(run.inputs(), k + 1) != 0:
            break
    rec = run.recorder
    codes = rec.ev_code[: rec.counts[2]]
    assert first is not None and (codes == EV_LIMIT_PITCH).sum() == 1
    j = int(np.flatnonzero(codes == EV_LIMIT_PITCH)[0])
    assert rec.ev_t[j] == first * run.settings.dt
    assert s.scalars[1] == largest
