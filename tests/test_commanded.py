"""Commanded control mode: the valves as set from outside between chunks (issue 42)."""

import numpy as np
import pytest

from flexlift.ascent.loop import prepare


@pytest.fixture(scope="module")
def run(tanker):
    run = prepare(tanker, "commanded", duration=60.0)
    run.start()
    return run


def _advance_to(run, t):
    k = int(round(t / run.settings.dt))
    run._room(k)
    run._advance(k)


def test_commanded_valves_stay_where_they_are(run):
    n0 = run.state.n.copy()
    _advance_to(run, 2.0)
    assert np.allclose(run.state.n, n0, rtol=1e-9), "no command: no gas in or out"
    assert not run.clusters.shared, "one loop bag per commanded bag"
    run.command(0, fill=0.05)
    _advance_to(run, 4.0)
    filled = run.state.n - n0
    assert filled[run.controllers.bags[0]] > 0, "the fill command fills"
    others = np.delete(filled, run.controllers.bags[0])
    assert np.allclose(others, 0.0, atol=1e-9)
    n1 = run.state.n.copy()
    _advance_to(run, 6.0)  # no new command: the fill valve stays open
    assert run.state.n[run.controllers.bags[0]] > n1[run.controllers.bags[0]]
    assert run.state.fill[run.controllers.bags[0]] == pytest.approx(0.05)
    run.command(0, fill=0.0, opening=1.0)
    _advance_to(run, 8.0)
    assert run.state.opening[run.controllers.bags[0]] == 1.0
    assert run.state.fill[run.controllers.bags[0]] == 0.0
    assert run.state.n[run.controllers.bags[0]] < n1[run.controllers.bags[0]] + 1e-9 or \
        run.state.purged[run.controllers.bags[0]] > 0


def test_command_refused_outside_commanded_mode(tanker):
    other = prepare(tanker, "coordinated", duration=10.0)
    with pytest.raises(ValueError, match="commanded"):
        other.command(0, fill=0.1)
