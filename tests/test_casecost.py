"""A sweep case's Python work outside the loop made cheaper without changing a number
(issue 28, "a cheaper case"): each shortcut against the code it replaced, bit for bit."""

from __future__ import annotations

import numpy as np

from flexlift.control.profile import _passes, valve_profile
from flexlift.loads.strength import shear_moment


def _passes_before(cap: np.ndarray, accel: float, dz: float) -> np.ndarray:
    """The forward-backward passes as they were written on numpy's scalars."""
    v = cap.copy()
    v[0] = 0.0
    for i in range(1, v.size):
        v[i] = min(v[i], np.sqrt(v[i - 1] ** 2 + 2.0 * accel * dz))
    v[-1] = 0.0
    for i in range(v.size - 2, -1, -1):
        v[i] = min(v[i], np.sqrt(v[i + 1] ** 2 + 2.0 * accel * dz))
    return v


def test_passes_on_python_floats_are_the_numpy_scalars_bit_for_bit():
    rng = np.random.default_rng(7)
    for k in range(30):
        n = int(rng.integers(2, 3000))
        cap = rng.uniform(0.0, 1.5, n) * (rng.uniform(size=n) > 0.05)  # some zero caps
        accel, dz = float(rng.uniform(1e-4, 0.05)), float(rng.uniform(1e-3, 1.0))
        want = _passes_before(cap, accel, dz)
        got = np.array(_passes(cap.tolist(), float(2.0 * accel * dz)))
        assert np.array_equal(got.view(np.uint64), want.view(np.uint64)), k


def test_valve_profile_binds_and_is_finite():
    """A purge limit that binds gives a profile slower than the plain speed (the passes ran)."""
    p = valve_profile(300.0, 0.5, 0.01, np.array([400.0]), np.array([500.0]), 0.5, 0.8,
                      350.0, 101325.0, 1025.0 * 9.81)
    assert p is not None and p.limit_from is not None
    assert np.all(np.isfinite(p.v)) and 0.0 < p.v.max() < 0.5 and p.v[0] == 0.0


def test_shear_moment_at_kept_points_is_the_full_result_there():
    rng = np.random.default_rng(3)
    x = np.sort(np.concatenate([np.linspace(0.0, 200.0, 301), [50.0, 50.0, 120.0]]))
    q = rng.normal(size=(17, x.size)) * 1e4
    pts = [(50.0, rng.normal(size=17) * 1e6), (0.0, 3e5), (133.3, rng.normal(size=17) * 1e6),
           (200.0, -1e5)]
    keep = np.sort(rng.choice(x.size, 60, replace=False))
    V, M = shear_moment(x, q, pts)
    Vk, Mk = shear_moment(x, q, pts, keep)
    assert Vk.shape == (17, 60)
    assert np.array_equal(Vk, V[:, keep]) and np.array_equal(Mk, M[:, keep])
