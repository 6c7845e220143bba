"""docs/theory/modes.md#mass-normalisation for every mode returned: Phi^T M Phi = I and Phi^T K Phi = diag(omega^2).

The stiffness Gram matrix is computed from the factor form D^T W D of K (no cancellation of
the ~EI/l^3 entries of an assembled K), each entry relative to the larger omega^2 of its pair:
the error that an M-orthonormality error of the same size implies for exact eigenvectors.
"""

import json
import logging

import numpy as np
import pytest
import scipy.sparse as sp

import flexlift.structure.eigen as modes_sparse
from flexlift.cli import main
from flexlift.structure.beam import assemble, deformation_matrix, dof_scale, element_deformation
from flexlift.structure.eigen import GRAM_TOL, flexibility_flexible, orthonormalised
from flexlift.structure.hull import Hull
from flexlift.structure.modes import analytic_free_free_hz, compute_modes, rigid_modes

L, EI, MASS = 78.02, 3.0e12, 3.2e6 / 78.02


def uniform(n):
    return Hull.uniform(L, EI, MASS, n)


def rough(n, seed):
    """A non-uniform hull: random EI and mass per element, two point masses."""
    rng = np.random.default_rng(seed)
    pm = np.zeros(n + 1)
    pm[2], pm[n - 1] = 8e4, 3e4
    return Hull(L, 3e12 * (0.5 + rng.random(n)), 4.1e4 * (0.5 + rng.random(n)), pm)


def gram_errors(modes):
    """(max |Phi^T M Phi - I|, max |Phi^T K Phi - diag(omega^2)|_ij / max(omega_i^2,
    omega_j^2, omega_3^2)) of all modes returned."""
    hull = modes.hull
    beam = assemble(hull)
    phi = modes.phi
    m_err = np.abs(phi.T @ (beam.M @ phi) - np.eye(modes.n_modes)).max()
    _, C = element_deformation()
    W = sp.block_diag([e / hull.element_length**3 * C for e in hull.EI])
    d = deformation_matrix(hull) @ (phi / dof_scale(hull)[:, None])
    w2 = modes.omega**2
    scale = np.maximum(np.maximum.outer(w2, w2), w2[2])
    k_err = (np.abs(d.T @ (W @ d) - np.diag(w2)) / scale).max()
    return m_err, k_err


@pytest.mark.parametrize(
    "make", [lambda: uniform(300), lambda: uniform(400), lambda: rough(300, seed=300)],
    ids=["300 uniform", "400 uniform", "300 non-uniform"],
)
def test_all_modes_are_orthonormal_and_diagonalise_K(make):
    hull = make()
    modes = compute_modes(hull)  # all 2 (N + 1) modes
    assert modes.n_modes == modes.n_requested == 2 * hull.n_nodes
    m_err, k_err = gram_errors(modes)
    assert m_err < GRAM_TOL
    assert k_err < GRAM_TOL
    # rigid modes still exact, frequencies ascending
    R = rigid_modes(assemble(hull))
    np.testing.assert_array_equal(modes.omega[:2], 0.0)
    np.testing.assert_array_equal(modes.phi[:, :2], R)
    assert np.all(np.diff(modes.omega[2:]) >= 0)  # the top pair of a uniform beam: degenerate


@pytest.mark.parametrize("n", [1000, 5000])
def test_default_request_on_fine_meshes(n):
    hull = uniform(n)
    modes = compute_modes(hull)
    assert modes.n_modes == modes.n_requested == 22
    m_err, k_err = gram_errors(modes)
    assert m_err < GRAM_TOL
    assert k_err < GRAM_TOL
    np.testing.assert_allclose(modes.frequencies_hz[2:7], analytic_free_free_hz(hull),
                               rtol=1e-10)


def test_flexibility_form_alone_loses_the_highest_modes():
    # the cause: mode k is resolved to ~eps lambda_k / lambda_1, and all modes of 300
    # elements reach lambda / lambda_1 ~ 6e10
    hull = uniform(300)
    beam = assemble(hull)
    lam, _, err = flexibility_flexible(beam, rigid_modes(beam), 600)
    assert err[19] < 1e-11  # the lowest twenty: fine
    assert err[-1] > 1e-7  # the highest: far off the SPEC's 1e-10
    # the stiffness form that replaces them agrees with the dense peer up there
    modes = compute_modes(hull)
    dense = compute_modes(hull, solver="dense")
    np.testing.assert_allclose(modes.omega[100:], dense.omega[100:], rtol=1e-10)
    assert np.max(np.abs(np.sqrt(lam[98:]) / dense.omega[100:] - 1)) > 1e-7


def test_unresolved_modes_are_dropped_and_reported(monkeypatch, caplog):
    # without the dense stiffness completion (as above DENSE_MAX_DOF) the flexibility form
    # resolves only the lowest ~100 modes of 300 elements: the rest are not returned
    monkeypatch.setattr(modes_sparse, "DENSE_MAX_DOF", 0)
    hull = uniform(300)
    with caplog.at_level(logging.WARNING, logger="flexlift.structure.modes"):
        modes = compute_modes(hull)
    assert modes.n_requested == 602
    assert 50 < modes.n_modes < 300
    assert f"{modes.n_modes} of the 602 requested modes are resolved" in caplog.text
    m_err, k_err = gram_errors(modes)
    assert m_err < GRAM_TOL and k_err < GRAM_TOL


def test_json_reports_requested_and_resolved_modes(capsys, monkeypatch):
    assert main(["modes", "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["modes_requested"] == s["modes_resolved"] == 24
    monkeypatch.setattr(modes_sparse, "DENSE_MAX_DOF", 0)
    assert main(["modes", "--elements", "300", "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    assert s["modes_requested"] == 602
    assert s["modes_resolved"] == len(s["frequencies_hz"]) < 602
    assert main(["modes", "--elements", "300"]) == 0
    assert f"only {s['modes_resolved']} of the 602 requested modes" in capsys.readouterr().out


def test_orthonormalised_checks_and_drops_dependent_columns():
    rng = np.random.default_rng(0)
    M = sp.diags(rng.uniform(1.0, 2.0, 12))
    K = sp.diags(rng.uniform(1.0, 2.0, 12) * 1e3)
    lam, Y = np.array([1.0, 2.0, 3.0, 4.0]), rng.standard_normal((12, 4))
    Y[:, 2] = 3.0 * Y[:, 0]  # linearly dependent: no Cholesky factor from column 3 on
    lam2, Y2, err = orthonormalised(M, lam, Y, stiffness=K)
    assert lam2.size == Y2.shape[1] == err.size == 2
    np.testing.assert_allclose(Y2.T @ (M @ Y2), np.eye(2), atol=1e-14)
    assert err[-1] > 1.0  # random vectors are no eigenvectors: the check says so
    # exact eigenvectors pass
    lam_e, Y_e, err_e = orthonormalised(M, K.diagonal() / M.diagonal(), np.eye(12) * 5.0,
                                     stiffness=K)
    np.testing.assert_allclose(Y_e.T @ (M @ Y_e), np.eye(12), atol=1e-15)
    assert err_e[-1] < 1e-15
