"""The dashboard's state at a glance from what live has read (flexlift.live.view): noise on
the seabed is not an ascent; a risen hull with gas going in is breaking out; risen and rising
is ascending; stale readings stop it, arrival holds it."""

from types import SimpleNamespace

import pytest

from flexlift.live.dashboard import BagView
from flexlift.live.view import MOVING_M, MOVING_M_S, _state

SEABED_M = 350.0
#: a 1 Hz gauge's 2-s slopes on the seabed (0.02 m noise): one passes MOVING_M_S alone
NOISY = [0.006, 0.006, -0.013, 0.014, 0.003, 0.046, 0.0003]


def _live(stale=False, arrived=False):
    return SimpleNamespace(stale=stale, arrived=lambda: arrived, first_depth={})


def _bags(rise_m=0.0, speeds=NOISY, fill=0.0):
    return [BagView(f"bag_{i + 1}", depth_m=SEABED_M - rise_m - 0.01 * (i % 2),
                    speed_m_s=v, fill=fill) for i, v in enumerate(speeds)]


def _states(live, *steps):
    return [_state(live, bags) for bags in steps]


def test_noise_on_the_seabed_is_filling_not_ascending():
    assert max(NOISY) > MOVING_M_S  # the trap: one bag's slope alone
    live = _live()
    assert _states(live, _bags(), _bags(0.02, fill=0.3), _bags(-0.02, fill=1.0)) == \
        ["filling"] * 3


def test_a_lift_passes_through_its_states_in_order():
    live = _live()
    steps = [_bags(), _bags(0.5 * MOVING_M, fill=0.5), _bags(2 * MOVING_M, fill=0.5),
             _bags(20.0, speeds=[0.2] * 7)]
    assert _states(live, *steps) == ["filling", "filling", "breaking out", "ascending"]


def test_rising_without_having_risen_is_not_ascending():
    live = _live()
    assert _states(live, _bags(speeds=[0.1] * 7), _bags(speeds=[0.1] * 7)) == ["filling"] * 2


@pytest.mark.parametrize("stale, arrived, state", [(True, False, "stopped"),
                                                   (False, True, "holding"),
                                                   (True, True, "stopped")])
def test_stale_stops_and_arrival_holds(stale, arrived, state):
    assert _state(_live(stale, arrived), _bags(20.0, speeds=[0.2] * 7)) == state
