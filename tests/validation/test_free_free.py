"""Validation: a 20,000-element free-free beam against the analytic Euler-Bernoulli solution.

With 20,000 elements of the tanker (l = 3.9 mm) K's entries reach ~1e20: the regime where a
shift-invert of the assembled matrices returns rigid modes of ~1 Hz and loses the low flexible
frequencies. The discretisation error there is ~1e-15, so any difference from the analytic
frequencies is numerical.
"""

import numpy as np
import pytest

from flexlift.structure.beam import assemble
from flexlift.structure.hull import Hull
from flexlift.structure.modes import (
    BETA_L_FREE_FREE,
    analytic_free_free_hz,
    compute_modes,
    mode_nodes,
)

L, EI, MASS = 78.02, 3.0e12, 3.2e6 / 78.02
N = 20_000


@pytest.fixture(scope="module")
def big():
    hull = Hull.uniform(L, EI, MASS, N)
    return hull, compute_modes(hull, n_modes=22)


def test_entries_of_K_are_in_the_trap_regime(big):
    hull, _ = big
    assert abs(assemble(hull).K).max() > 1e19


def test_frequencies_match_analytic_at_20000_elements(big):
    hull, modes = big
    f = modes.frequencies_hz
    np.testing.assert_array_equal(f[:2], 0.0)
    np.testing.assert_allclose(f[2:7], analytic_free_free_hz(hull), rtol=1e-10)
    # the higher modes follow f_n = (beta_n L)^2 / (2 pi L^2) sqrt(EI/m),
    # beta_n L -> (n + 1/2) pi for n > 5
    bl = np.r_[BETA_L_FREE_FREE, (np.arange(6, 21) + 0.5) * np.pi]
    fa = bl**2 / (2 * np.pi * L**2) * np.sqrt(EI / MASS)
    np.testing.assert_allclose(f[2:], fa, rtol=1e-9)


def test_modes_orthonormal_and_rigid_clean_at_20000_elements(big):
    hull, modes = big
    beam = assemble(hull)
    phi = modes.phi
    np.testing.assert_allclose(phi.T @ (beam.M @ phi), np.eye(22), atol=1e-10)
    # rigid modes: exact shapes with no stiffness beyond the round-off of K's own entries
    KR = beam.K @ phi[:, :2]
    assert np.abs(KR).max() < 1e-12 * abs(beam.K).max() * np.abs(phi[:, :2]).max()


def test_mode_shape_and_nodes_match_analytic_at_20000_elements(big):
    hull, modes = big
    x = hull.x_nodes
    b = BETA_L_FREE_FREE[0] / L
    s = (np.cosh(b * L) - np.cos(b * L)) / (np.sinh(b * L) - np.sin(b * L))
    w = np.cosh(b * x) + np.cos(b * x) - s * (np.sinh(b * x) + np.sin(b * x))
    fe = modes.displacement[:, 2]
    fe = fe / fe[-1] * w[-1]
    np.testing.assert_allclose(fe, w, atol=1e-8 * np.abs(w).max())
    # nodes of the first flexible mode: x = 0.2242 L and 0.7758 L
    nodes = np.array(mode_nodes(modes, 2))
    np.testing.assert_allclose(nodes / N, [0.224159, 0.775841], atol=1.5 / N)
