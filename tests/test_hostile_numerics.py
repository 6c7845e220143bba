"""Valid scenarios that ended in a crash of the numerics (issue 10): separation and breakout in
one step (UnboundLocalError at the breakout event)."""

import math


def test_release_within_the_separation_step_records_the_breakout(tanker):
    """A release time far below the step: separation and breakout in the same step (this
    ended in UnboundLocalError at the breakout event)."""
    from flexlift.simulate import simulate

    sc = tanker.with_changes(**{"seabed.breakout_time_s": 1.0, "seabed.release_time_s": 0.002})
    r = simulate(sc, duration=35.0)
    ev = {e["kind"]: e["time_s"] for e in r.events}
    assert 20.0 < ev["separation"] < 35.0
    # the suction halves every 0.002 s ln 2: below 0.1 % of H0 some 0.014 s after separation
    assert ev["separation"] < ev["breakout"] <= ev["separation"] + 0.002 * math.log(1000) + 1e-3
