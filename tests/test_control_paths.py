"""The controller's float-by-float fast path and its array path are the same controller.

Decentralized and coordinated runs with lookup tables take the fast path; paper mode and the
exact fuzzy engine take the array path. A change to one must not silently split the two."""

import numpy as np
import pytest

from flexlift.control import Controller, control_params, fuzzy_engines


def _twins(tanker, mode):
    x = [7.09, 28.37, 49.65, 70.93]
    params = control_params(tanker, x, [310.0, 320.0, 330.0, 340.0], [504.0] * 4, 1025.0, 9.81,
                            hold_centroid=45.5, mode=mode)
    fast = Controller(params, *fuzzy_engines(tanker))
    slow = Controller(params, *fuzzy_engines(tanker))
    slow._scalar = False
    assert fast._scalar, "lookup-table engines must select the fast path"
    return fast, slow


@pytest.mark.parametrize("mode", ["decentralized", "coordinated"])
def test_fast_and_array_paths_agree_sample_by_sample(tanker, mode):
    fast, slow = _twins(tanker, mode)
    rng = np.random.default_rng(3)
    z = np.zeros(4)
    V = np.array([310.0, 320.0, 330.0, 340.0])
    period = 0.1
    for k in range(3000):
        t = k * period
        separated = t >= 20.0
        if separated:  # rise roughly on plan, with scatter between the bags
            zdot = 0.2 + 0.05 * rng.standard_normal(4)
            z = z + period * zdot
            V = V + rng.normal(0.0, 0.5, 4)  # expansion and noise: purging and filling
        else:
            zdot = np.zeros(4)
        if k == 2000:  # a bag lost (sling break): both must stop controlling it
            fast.lose(2)
            slow.lose(2)
        a = fast.step(t, z.copy(), zdot.copy(), V.copy(), separated)
        b = slow.step(t, z.copy(), zdot.copy(), V.copy(), separated)
        for name, u, w in zip(("fill", "purge", "u", "V_d", "z_ref"), a, b):
            np.testing.assert_allclose(np.asarray(u, float), np.asarray(w, float),
                                       rtol=1e-12, atol=1e-12,
                                       err_msg=f"{name} differs at t = {t:.1f} s ({mode})")
