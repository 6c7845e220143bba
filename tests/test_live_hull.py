"""The master controller's hull observer (flexlift.live.hull): the seabed's hold run on the
load cells tells the separation, and the rigid-body filter driven by the sling forces gives
the bags' speeds without the lag of the depths' differences
(docs/reference/live.md#what-it-achieves)."""

from importlib.resources import files

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent.plant import coupled_plant
from flexlift.live.hull import HullTrack

DEPTH_SD, PITCH_SD, FORCE_SD = 0.02, 0.002, 5000.0
DEPTH0 = 345.0


@pytest.fixture(scope="module")
def plant():
    return coupled_plant(load_scenario(files("flexlift.scenarios") / "tanker.yaml"))


def test_the_hold_tells_the_separation_after_the_law_and_within_a_second(plant):
    """Uplift ramped from 0 to U = 1.47 MN over 500 s, then held: the timer law's hold
    H0 - (1/T_b) int U dt falls to U at t* = 250 s + (H0 - U) T_b / U; 10 Hz load cells of
    5 kN: the separation is told after t* and less than 1.5 s after it, by the hold."""
    hull = HullTrack(plant, DEPTH_SD, PITCH_SD, FORCE_SD)
    rng = np.random.default_rng(3)
    seabed, names = plant.records.seabed, plant.names
    H0, W, Tb, U = float(seabed.H0[0]), float(seabed.group_weight[0]), seabed.breakout_time, 1.47e6
    t_star = 250.0 + (H0 - U) * Tb / U
    share = np.full(len(names), 1.0 / len(names))
    told = None
    for k in range(int((t_star + 5.0) * 10)):
        t = 0.1 * k
        uplift = U * min(t / 500.0, 1.0)
        for b, f in zip(names, (W + uplift) * share + FORCE_SD * rng.standard_normal(len(names))):
            hull.force(b, t, f)
        if hull.separated:
            told = t
            break
    assert told is not None and t_star < told < t_star + 1.5, (told, t_star)
    assert hull.how == "hold"


def test_the_speed_follows_the_buoyancy_at_once(plant):
    """Separated and balanced, then every bag's buoyancy 20 kN more at t = 20 s: the heave
    the plant's rigid model makes of it, read by 10 Hz gauges of 0.02 m; 1 s after the step
    the filter's speed is within 2 mm/s of the true one (a slope of the depths alone would
    lag it by half its window)."""
    hull = HullTrack(plant, DEPTH_SD, PITCH_SD, FORCE_SD)
    rng = np.random.default_rng(1)
    names, nb = plant.names, len(plant.names)
    W = float(plant.records.seabed.group_weight[0])
    for k in range(20):  # the rest levels
        for b in names:
            hull.depth(b, 0.1 * k, DEPTH0 + DEPTH_SD * rng.standard_normal())
    hull.forces[:] = W / nb
    hull.uplift = 0.0
    hull._separate(2.0, "hold")
    hull.H_sep = 0.0
    truth = hull.x.copy()  # the true rigid state, moved by the same model
    t, errors = 2.0, []
    while t < 25.0:
        force = W / nb + (20e3 if t >= 20.0 else 0.0)
        for b in names:
            hull.force(b, t, force + FORCE_SD * rng.standard_normal())
        saved = hull.forces.copy()  # the truth: the plant's rigid model, exact forces
        hull.forces[:] = force
        a = hull._accel(t, truth[2:4])
        hull.forces[:] = saved
        truth[:2] += 0.1 * truth[2:4] + 0.005 * a
        truth[2:4] += 0.1 * a
        t += 0.1
        z = hull.shape @ truth[:2]
        for i, b in enumerate(names):
            hull.depth(b, t, DEPTH0 - z[i] + DEPTH_SD * rng.standard_normal())
        if t >= 21.0 - 1e-9 and not errors:
            _, zd = hull.now(t)
            errors = list(zd - hull.shape @ truth[2:4])
            speed = float(hull.shape[0] @ truth[2:4])
    assert speed > 0.01, "the step moved the hull"
    assert max(abs(e) for e in errors) < 0.002, errors


def test_the_rise_test_weighs_only_the_last_window(plant):
    """Held, noise-free gauges: every bag 0.015 m up for 3 s (below MIN_RISE_M: no
    separation), back down for 10 s (the bump has left the window: still none), then 0.05 m
    up: separated by the rise within the window."""
    from flexlift.live.hull import RISE_WINDOW_S

    hull = HullTrack(plant, DEPTH_SD, PITCH_SD, FORCE_SD)
    told, k = None, 0
    for span, rise in ((2.0, 0.0), (3.0, 0.015), (10.0, 0.0), (3.0, 0.05)):
        for _ in range(int(span * 10)):
            t, k = 0.1 * k, k + 1
            for b in plant.names:
                hull.depth(b, t, DEPTH0 - rise)
            if hull.separated and told is None:
                told = t
    assert hull.how == "rise" and 15.0 < told <= 15.0 + RISE_WINDOW_S, told
