"""Valid scenarios that ended in a crash of the numerics (issue 10): separation and breakout in
one step (UnboundLocalError at the breakout event), and a model reduced to no modes at all
(the frequency response could not reshape an empty array)."""

import math

import numpy as np

from flexlift.cli import main


def test_release_within_the_separation_step_records_the_breakout(tanker):
    """A release time far below the step: separation and breakout in the same step (this
    ended in UnboundLocalError at the breakout event)."""
    from flexlift.ascent import simulate

    sc = tanker.with_changes(**{"seabed.breakout_time_s": 1.0, "seabed.release_time_s": 0.002})
    r = simulate(sc, duration=35.0)
    ev = {e["kind"]: e["time_s"] for e in r.events}
    assert 20.0 < ev["separation"] < 35.0
    # the suction halves every 0.002 s ln 2: below 0.1 % of H0 some 0.014 s after separation
    assert ev["separation"] < ev["breakout"] <= ev["separation"] + 0.002 * math.log(1000) + 1e-3


def test_an_order_0_model_has_its_feedthrough_as_its_response(tanker_modes):
    """A model of flexible modes reduced to order 0 is its static gain D (the frequency
    response crashed reshaping an empty array)."""
    from flexlift.dynamics.reduce import reduce_model
    from flexlift.dynamics.statespace import (
        frequency_response,
        impulse_response,
        modal_state_space,
        step_response,
    )

    full = modal_state_space(tanker_modes, ["f_node_1", "f_node_6"], ["w_node_1", "v_node_3"])
    flexible = full.with_modes(range(2, tanker_modes.n_modes))
    r0 = reduce_model(flexible, 0, method="mdc")
    assert r0.n_states == 0
    G = frequency_response(r0, [0.0, 1.0, 100.0])
    assert G.shape == (2, 2, 3)
    np.testing.assert_array_equal(G, np.repeat(r0.D[:, :, None], 3, axis=-1))
    w = np.array([1e-6])  # the static gain of the flexible part, matched exactly by mdc
    np.testing.assert_allclose(frequency_response(r0, w)[0].real,
                               frequency_response(flexible, w)[0].real, rtol=1e-6)
    assert step_response(r0, [0.0, 1.0]).shape == (2, 2, 2)
    assert not impulse_response(r0, [0.0, 1.0]).any()
    assert reduce_model(flexible, 0, method="del").D.any() == False  # noqa: E712


def test_reduce_order_0_on_the_cli_is_one_line(capsys):
    assert main(["reduce", "--order", "0", "--json"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--order must be at least 1" in err and "Traceback" not in err
