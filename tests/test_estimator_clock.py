"""When the lift separated (docs/theory/estimation.md#clock): each released member is given its
own separation time, drawn over the interval the readings bound it to; its controllers'
references and its seabed's release move with it, and what is still to come moves by as
much."""

import math

import numpy as np
import pytest

from flexlift import load_scenario
from flexlift.ascent.batch import advance_batch
from flexlift.ascent.loop import prepare
from flexlift.estimate.ensemble import Ensemble, separation_time, shift_clock
from flexlift.estimate.filter import Estimator
from flexlift.sensors.config import sensors_of
from flexlift.sensors.log import Reading


@pytest.fixture(scope="module")
def tanker():
    return load_scenario("tanker")


def test_released_members_separate_at_the_times_drawn_for_them(tanker):
    """Released at 300 s with the separation bounded to (299, 300] s: once separated, each
    member's controllers noted its own draw in that interval (not the step after the
    release), its groups' release times moved by as much, its clock the move; a member
    already separated when a later release comes is given nothing."""
    ens = Ensemble(tanker, 4, seed=2, control="decentralized")
    ens.advance(3001)
    ens.release((299.0, 300.0), np.random.default_rng(5))
    drawn = ens._pending.copy()
    assert np.all((drawn > 299.0) & (drawn <= 300.0)) and np.unique(drawn).size == 4
    ens.advance(3002)  # separated at this step; the controllers note it at their next sample
    assert all(run.state.sep.all() for run in ens.runs)
    own = np.array([run.state.release[0, 0] for run in ens.runs]) - ens.clock
    assert all(math.isnan(separation_time(run)) for run in ens.runs)  # not yet noted
    ens.advance(3001 + ens.runs[0].settings.k_ctrl + 1)
    noted = np.array([separation_time(run) for run in ens.runs])
    assert noted == pytest.approx(drawn, abs=1e-9)
    assert np.isnan(ens._pending).all()
    released = np.array([run.state.release[0, 0] for run in ens.runs])
    assert released - ens.clock == pytest.approx(own, abs=1e-9)  # moved with the clock
    assert np.all(ens.clock < 0.0) and np.all(ens.clock > -1.2)  # earlier, within a period
    free = np.array([np.nanmin(run.control_state.t_free) for run in ens.runs])
    assert free == pytest.approx(noted, abs=1e-9)
    clock = ens.clock.copy()
    ens.release((310.0, 311.0), np.random.default_rng(6))  # nobody held: nothing drawn
    assert np.isnan(ens._pending).all()
    ens.advance(3200)
    assert np.array_equal(ens.clock, clock)


def test_a_clock_moved_moves_what_is_still_to_come(tanker):
    """A run just after its separation, forked, one fork's clock moved 2 s later: its
    breakout and its last arrival come 2 s later, to the step; the other fork's are the
    run's own (docs/theory/estimation.md#clock: the ascent follows the reference's time
    line)."""
    run = prepare(tanker, "decentralized", share=False)
    run.start()
    advance_batch([run], 19_000)  # separation at 1,877.5 s
    assert run.state.sep.all() and math.isfinite(separation_time(run))
    late, same = run.fork(), run.fork()
    shift_clock(late, 2.0)
    advance_batch([late, same])
    a, b = (f.finish(summary_only=True) for f in (late, same))
    dt = run.settings.dt
    assert b.headline["breakout_time_s"] + 2.0 == pytest.approx(a.headline["breakout_time_s"],
                                                               abs=dt)
    last_a, last_b = (float(np.nanmax(r.dataset.arrival_time.values)) for r in (a, b))
    assert last_a - last_b == pytest.approx(2.0, abs=dt)


def test_the_separation_is_bounded_by_the_first_open_dump_valve(tanker):
    """The window's first dump-valve reading more than 3 predicted standard deviations above
    the members bounds the separation to one period of its sensor before it; with none, the
    window bounds it; a second release keeps the first one's interval."""
    names = prepare(tanker).plant.names
    sensors = sensors_of(tanker, names, for_log=True)
    est = Estimator(tanker, sensors, members=2)
    purge = [s for s in sensors if s.quantity == "purge"][:2]
    readings = [Reading(101.5, purge[1].name, 0.5), Reading(100.5, purge[0].name, 0.4),
                Reading(101.0, purge[0].name, 0.0)]
    z = np.array([r.value for r in readings])
    Y = np.zeros((3, 2))
    sigma = np.full(3, 0.05)
    feedback = np.array([True, True, True])
    period = purge[0].period_s
    assert est._separated_in(readings, z, Y, sigma, feedback, (99.0, 102.0)) == \
        (100.5 - period, 100.5)
    shut = np.zeros(3)
    assert est._separated_in(readings, shut, Y, sigma, feedback, (99.0, 102.0)) == \
        (99.0, 102.0)


def test_resampling_parts_the_clocks_and_keeps_each_members_own_separation(tanker):
    """After the separation, with the clocks spread, the weights on two members: each copy's
    clock is drawn from the kernel (the copies part), and each copy's controllers stand at
    its parent's own separation moved by its clock, the original and every fork alike (a
    fork copies its parent as it stands: moved by the parent's draw already)."""
    ens = Ensemble(tanker, 6, seed=4, control="decentralized")
    ens.advance(3001)
    ens.release((299.0, 300.0), np.random.default_rng(5))
    ens.advance(3100)
    own = np.array([separation_time(run) for run in ens.runs]) - ens.clock
    assert np.ptp(ens.clock) > 0.1
    log_w = np.full(6, -1e3)
    log_w[[2, 4]] = 0.0
    assert ens.resample(log_w, np.random.default_rng(9))
    assert np.unique(ens.clock).size == 6  # parted
    noted = np.array([separation_time(run) for run in ens.runs])
    parent = noted - ens.clock
    assert all(min(abs(p - own[2]), abs(p - own[4])) < 1e-9 for p in parent), (parent, own)
