"""Hermite beam elements and their assembly, against hand values and energy identities."""

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from flexlift.structure.beam import (
    assemble,
    deformation_matrix,
    dof_scale,
    element_deformation,
    element_mass,
    element_stiffness,
    shape_functions,
)
from flexlift.structure.hull import Hull


def test_element_stiffness_hand_values():
    # EI = 2 N m^2, l = 3 m: EI / l^3 = 2/27
    K = element_stiffness(2.0, 3.0)
    c = 2.0 / 27.0
    assert K[0, 0] == pytest.approx(12 * c)
    assert K[0, 1] == pytest.approx(18 * c)  # 6 l
    assert K[1, 1] == pytest.approx(36 * c)  # 4 l^2
    assert K[1, 3] == pytest.approx(18 * c)  # 2 l^2
    assert K[0, 2] == pytest.approx(-12 * c)
    assert K[2, 3] == pytest.approx(-18 * c)  # -6 l
    np.testing.assert_allclose(K, K.T)


def test_element_mass_hand_values():
    # m = 2 kg/m, l = 3 m: m l / 420 = 1/70
    M = element_mass(2.0, 3.0)
    c = 1.0 / 70.0
    assert M[0, 0] == pytest.approx(156 * c)
    assert M[0, 1] == pytest.approx(66 * c)  # 22 l
    assert M[0, 2] == pytest.approx(54 * c)
    assert M[0, 3] == pytest.approx(-39 * c)  # -13 l
    assert M[1, 1] == pytest.approx(36 * c)  # 4 l^2
    assert M[1, 3] == pytest.approx(-27 * c)  # -3 l^2
    assert M[3, 3] == pytest.approx(36 * c)
    np.testing.assert_allclose(M, M.T)


def test_element_energies_match_continuum():
    EI, m, l = 7.0, 3.0, 2.5
    K, M = element_stiffness(EI, l), element_mass(m, l)
    # translation: kinetic energy of the whole element mass; no strain
    u = np.array([1.0, 0.0, 1.0, 0.0])
    assert u @ M @ u == pytest.approx(m * l)
    np.testing.assert_allclose(K @ u, 0.0, atol=1e-12)
    # rotation about the left end: moment of inertia m l^3 / 3
    r = np.array([0.0, 1.0, l, 1.0])
    assert r @ M @ r == pytest.approx(m * l**3 / 3)
    np.testing.assert_allclose(K @ r, 0.0, atol=1e-12)
    # constant curvature w = x^2 / 2: strain energy 1/2 EI l, so u^T K u = EI l
    c = np.array([0.0, 0.0, l**2 / 2, l])
    assert c @ K @ c == pytest.approx(EI * l)


def test_factor_form_of_the_element():
    EI, l = 5.0, 0.7
    G, C = element_deformation()
    S = np.diag([1.0, 1.0 / l, 1.0, 1.0 / l])  # [w, theta] = S [w, l theta]
    np.testing.assert_allclose(S @ element_stiffness(EI, l) @ S, EI / l**3 * G.T @ C @ G)


def test_shape_functions_interpolate_nodal_values():
    l = 2.0
    N = shape_functions(np.array([0.0, 1.0, 0.3]), l)
    np.testing.assert_allclose(N[0], [1, 0, 0, 0], atol=1e-15)
    np.testing.assert_allclose(N[1], [0, 0, 1, 0], atol=1e-15)
    assert N[2, 0] + N[2, 2] == pytest.approx(1.0)  # partition of unity for w
    # a linear field w = a + b x is reproduced exactly
    a, b, x = 0.4, -1.3, 0.3 * l
    assert N[2] @ [a, b, a + b * l, b] == pytest.approx(a + b * x)


@pytest.fixture(scope="module")
def rough_hull():
    rng = np.random.default_rng(7)
    n = 9
    return Hull(
        30.0,
        1e9 * (1 + rng.random(n)),
        500 * (1 + rng.random(n)),
        point_masses=np.r_[0, 2e3, 0, 0, 5e3, 0, 0, 0, 0, 1e3],
    )


def test_global_matrices_symmetric_and_definite(rough_hull):
    beam = assemble(rough_hull)
    K, M = beam.K.toarray(), beam.M.toarray()
    np.testing.assert_allclose(K, K.T, rtol=0, atol=1e-9 * abs(K).max())
    np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-12 * abs(M).max())
    s = dof_scale(rough_hull)  # scaled, so that the spectrum is readable
    k_eig = sla.eigvalsh(s[:, None] * K * s[None, :])
    m_eig = sla.eigvalsh(s[:, None] * M * s[None, :])
    assert m_eig.min() > 0  # M positive definite
    assert k_eig.min() > -1e-10 * k_eig.max()  # K positive semi-definite
    assert np.sum(np.abs(k_eig) < 1e-10 * k_eig.max()) == 2  # exactly two rigid motions
    assert k_eig[2] > 1e-6 * k_eig.max()


def test_assembled_band_and_mass(rough_hull):
    beam = assemble(rough_hull)
    rows, cols = beam.K.nonzero()
    assert np.abs(rows - cols).max() == 3  # half-bandwidth 3
    heave = np.zeros(beam.n_dof)
    heave[0::2] = 1.0
    assert heave @ (beam.M @ heave) == pytest.approx(rough_hull.total_mass)
    np.testing.assert_allclose(beam.K @ heave, 0.0, atol=1e-6)


def test_factor_form_assembles_to_K(rough_hull):
    beam = assemble(rough_hull)
    D = deformation_matrix(rough_hull)
    _, C = element_deformation()
    l = rough_hull.element_length
    W = sp.block_diag([e / l**3 * C for e in rough_hull.EI])
    S = sp.diags(dof_scale(rough_hull))
    diff = (D.T @ W @ D - S @ beam.K @ S).toarray()
    assert np.abs(diff).max() < 1e-12 * abs(beam.K).max()
    assert D.shape == (2 * rough_hull.n_elements, beam.n_dof)
