"""Step control while every holding group is held (kernel.held_block): the same ascent as
every step alike, on the tanker, the pipeline and an own hull (the trawler of tests/data):
the criteria identical, the events at the same times within one base step, the headline
peaks within 1e-3 relative, the recorded rows at their times."""

from pathlib import Path

import numpy as np
import pytest

from flexlift.ascent import simulate
from flexlift.ascent.loop import HELD_STEP_S, held_steps
from flexlift.ascent.state import Settings
from flexlift.scenario import load_scenario

TRAWLER = Path(__file__).parent / "data" / "trawler.yaml"
CASES = {"tanker": lambda: load_scenario("tanker"),
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


def _settings(dt, k_out):
    return Settings(dt=dt, n_steps=10, k_ctrl=1, k_out=k_out, k_str=k_out, target=1.0, tol=0.1,
                    hold_time=1.0, v_limit=1.0, v_down_limit=1.0, pitch_limit=1.0,
                    top_limit=np.zeros(1), external=False, held_steps=1, held_margin=0.05)


@pytest.mark.parametrize("dt, k_out, m", [(0.1, 10, 10), (0.1, 20, 10), (0.1, 15, 5),
                                          (0.05, 30, 15), (0.5, 4, 2), (2.0, 5, 1),
                                          (0.1, 7, 7), (0.1, 1, 1)])
def test_a_held_block_divides_the_row_interval(dt, k_out, m):
    got = held_steps(_settings(dt, k_out))
    assert got == m
    assert k_out % got == 0 and (got == 1 or got * dt <= HELD_STEP_S + 1e-9)


def test_blocks_end_before_the_uplift_nears_the_hold():
    """Held blocks run early in the fill and have ended, with base steps, before the step of
    the separation (the uplift within the margin of the hold)."""
    from flexlift.ascent import kernel
    from flexlift.ascent.loop import Ascent
    from flexlift.ascent.plant import coupled_plant
    from flexlift.ascent.state import F_HELD

    sc = load_scenario("tanker")
    plant = coupled_plant(sc)
    t_sep = next(e["time_s"] for e in simulate(sc, plant=plant).events
                 if e["kind"] == "separation")
    dt = sc.simulation.time_step_s
    for k, held in ((1005, True), (int(t_sep / dt) - 1, False)):
        run = Ascent(sc, plant, "coordinated", 3000.0, "table")
        run._room(k)
        kernel.advance(run.inputs(), k)
        assert bool(run.state.counters[1] & F_HELD) is held, k
        assert not run.state.sep.any()
