"""The master controller's Kalman filter per bag (flexlift.live.track): the height and speed
predicted to the control sample from 1 Hz depth gauges, the volume from the load cell, and
the rest level a separation is judged from (docs/reference/live.md#the-master-controller)."""

import numpy as np
import pytest

from flexlift.live.track import BagTrack

DEPTH_SD, VOLUME_SD = 0.02, 0.5
DEPTH0, V0 = 350.0, 300.0


def _rising(speed, t_rise, t_end, rng):
    """A bag held at DEPTH0 until t_rise, then rising at ``speed``: 1 Hz noisy depths."""
    track = BagTrack(DEPTH_SD, VOLUME_SD)
    track.start(0.0, DEPTH0 + rng.normal() * DEPTH_SD, V0)
    for t in np.arange(1.0, t_end + 0.5, 1.0):
        true = DEPTH0 - speed * max(t - t_rise, 0.0)
        track.depth(float(t), true + rng.normal() * DEPTH_SD)
        track.volume(float(t), V0 + rng.normal() * VOLUME_SD)
    return track


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_height_and_speed_are_those_of_the_control_sample_not_of_the_last_reading(seed):
    """0.9 s after the last 1 Hz reading of a bag rising at 0.2 m/s: the speed within
    0.05 m/s and the height within 0.12 m of the bag's now (a height held at the last
    reading would be 0.18 m behind)."""
    rng = np.random.default_rng(seed)
    speed, t_rise, t_end = 0.2, 20.0, 120.0
    track = _rising(speed, t_rise, t_end, rng)
    t = t_end + 0.9
    z, zd, V, sd = track.now(t)
    assert zd == pytest.approx(speed, abs=0.05)
    assert z == pytest.approx(speed * (t - t_rise), abs=0.12)
    assert 0 < sd < 0.1
    assert V == pytest.approx(V0, abs=1.0)


def test_the_volume_is_smoothed_below_a_reading_s_noise():
    """The load cell's volume, 0.5 m3 noise a reading: the estimate of a steady bag errs
    less than 0.8 of that (RMS over seeds; the random walk of 0.5 m3/s^0.5 keeps it quick)."""
    errors = [_rising(0.0, 1e9, 40.0, np.random.default_rng(s)).now(40.0)[2] - V0
              for s in range(20)]
    assert np.sqrt(np.mean(np.square(errors))) < 0.8 * VOLUME_SD


def test_a_wild_first_reading_is_not_a_separation():
    """The first depth 4 sigma deep (0.08 m), the bag held still for 30 min: the rise above
    the rest level (the mean of the depths while held) never passes 0.1 m; a real rise of
    0.3 m then does, and the rest level stays where it was."""
    rng = np.random.default_rng(7)
    track = BagTrack(DEPTH_SD, VOLUME_SD)
    track.start(0.0, DEPTH0 + 4 * DEPTH_SD, V0)
    rises = []
    for t in range(1, 1800):
        track.depth(float(t), DEPTH0 + rng.normal() * DEPTH_SD)
        rises.append(track.risen())
    assert max(rises) < 0.1 and not track.separated
    assert track.depth0 == pytest.approx(DEPTH0, abs=0.005)
    for t in range(1800, 1810):
        track.depth(float(t), DEPTH0 - 0.3 + rng.normal() * DEPTH_SD)
    assert track.risen() > 0.1 and track.separated
    rest = track.depth0
    track.depth(1810.0, DEPTH0 - 0.5)
    assert track.depth0 == rest


def test_late_and_repeated_readings_are_left():
    """A reading older than the filter's last is not taken (the board already orders them)."""
    track = _rising(0.2, 0.0, 10.0, np.random.default_rng(1))
    before = track.kf.x.copy()
    track.depth(5.0, 0.0)
    track.depth(10.0, 0.0)
    assert np.array_equal(track.kf.x, before)
