"""Free-free eigen analysis: rigid modes, normalisation, peers, symmetry, solvers, convergence."""

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.sparse as sp

from flexlift.errors import InputError
from flexlift.structure.beam import assemble, deformation_matrix, dof_scale, element_deformation
from flexlift.structure.convergence import convergence_rate, convergence_study, is_uniform
from flexlift.structure.eigen import sparse_flexible
from flexlift.structure.hull import Hull
from flexlift.structure.modes import (
    BETA_L_FREE_FREE,
    analytic_free_free_hz,
    compute_modes,
    mode_nodes,
    rigid_modes,
    zero_crossings,
)


def rough(n=12, seed=3):
    """A non-uniform hull: random EI and mass per element, two point masses."""
    rng = np.random.default_rng(seed)
    pm = np.zeros(n + 1)
    pm[2], pm[n - 1] = 8e4, 3e4
    return Hull(78.02, 3e12 * (0.5 + rng.random(n)), 4.1e4 * (0.5 + rng.random(n)), pm)


def analytic_shape(x, L, k):
    """Displacement of the k-th (1-based) flexible free-free mode of a uniform beam."""
    b = BETA_L_FREE_FREE[k - 1] / L
    bl = b * L
    s = (np.cosh(bl) - np.cos(bl)) / (np.sinh(bl) - np.sin(bl))
    return np.cosh(b * x) + np.cos(b * x) - s * (np.sinh(b * x) + np.sin(b * x))


def test_beta_l_are_the_free_free_roots():
    np.testing.assert_allclose(np.cos(BETA_L_FREE_FREE) * np.cosh(BETA_L_FREE_FREE), 1.0,
                               atol=1e-7)
    np.testing.assert_allclose(BETA_L_FREE_FREE[:5], [4.7300, 7.8532, 10.9956, 14.1372, 17.2788],
                               atol=5e-5)


def test_tanker_first_mode_about_5_hz(tanker_modes):
    f = tanker_modes.frequencies_hz
    assert f.size == 24  # 2 DOFs x 12 nodes
    np.testing.assert_array_equal(f[:2], 0.0)
    assert 4.9 < f[2] < 5.1
    assert np.all(np.diff(f[2:]) > 0)


def test_exactly_two_near_zero_eigenvalues_of_the_full_problem(tanker_hull):
    beam = assemble(tanker_hull)
    lam = sla.eigh(beam.K.toarray(), beam.M.toarray(), eigvals_only=True)
    assert np.sum(np.abs(lam) < 1e-6 * lam[2]) == 2
    # the clean solver's flexible frequencies are the peer's (scipy eigh on K, M)
    modes = compute_modes(tanker_hull)
    np.testing.assert_allclose(modes.omega[2:] ** 2, lam[2:], rtol=1e-8)


@pytest.mark.parametrize("make", [lambda: None, rough], ids=["tanker", "non-uniform"])
def test_mass_normalised_and_diagonal_stiffness(make, tanker_hull):
    hull = make() or tanker_hull
    modes = compute_modes(hull)
    beam = assemble(hull)
    phi = modes.phi
    np.testing.assert_allclose(phi.T @ (beam.M @ phi), np.eye(modes.n_modes), atol=1e-10)
    KK = phi.T @ (beam.K @ phi)
    scale = modes.omega.max() ** 2
    np.testing.assert_allclose(KK, np.diag(modes.omega**2), rtol=0, atol=1e-9 * scale)
    # low modes to relative accuracy
    np.testing.assert_allclose(np.diag(KK)[2:8], modes.omega[2:8] ** 2, rtol=1e-8)


def test_rigid_modes_are_exact_heave_and_pitch():
    hull = rough()
    beam = assemble(hull)
    R = rigid_modes(beam)
    heave, pitch = R[:, 0], R[:, 1]
    np.testing.assert_array_equal(heave[1::2], 0.0)  # no rotation
    assert np.ptp(heave[0::2]) == 0.0  # uniform translation
    np.testing.assert_allclose(pitch[1::2], pitch[1])  # one rotation ...
    np.testing.assert_allclose(np.diff(pitch[0::2]), pitch[1] * hull.element_length)  # ... w = theta x
    np.testing.assert_allclose(R.T @ (beam.M @ R), np.eye(2), atol=1e-12)
    k_scale = abs(beam.K).max() * np.abs(R).max()
    assert np.abs(beam.K @ R).max() < 1e-12 * k_scale
    modes = compute_modes(hull)
    np.testing.assert_array_equal(modes.omega[:2], 0.0)
    np.testing.assert_array_equal(modes.phi[:, :2], R)


def test_mirrored_hull_gives_mirrored_modes():
    hull = rough(15)
    assert not is_uniform(hull)
    a, b = compute_modes(hull, 12), compute_modes(hull.mirrored(), 12)
    np.testing.assert_allclose(b.omega, a.omega, rtol=1e-9)
    for j in range(2, 12):
        wa, wb = a.displacement[:, j], b.displacement[::-1, j]
        ta, tb = a.rotation[:, j], -b.rotation[::-1, j]  # rotations change sign end for end
        s = np.sign(wa @ wb)
        np.testing.assert_allclose(s * wb, wa, atol=1e-8 * np.abs(wa).max())
        np.testing.assert_allclose(s * tb, ta, atol=1e-8 * np.abs(ta).max())


def accurate_rayleigh(hull, phi):
    """omega^2 of shapes phi from the factor form D^T W D of K (no cancellation of the
    ~EI/l^3 entries of an assembled K)."""
    D = deformation_matrix(hull)
    _, C = element_deformation()
    l = hull.element_length
    W = sp.block_diag([e / l**3 * C for e in hull.EI])
    d = D @ (phi / dof_scale(hull)[:, None])
    M = assemble(hull).M
    return np.einsum("ij,ij->j", d, W @ d) / np.einsum("ij,ij->j", phi, M @ phi)


@pytest.mark.parametrize("n, rtol", [(30, 1e-9), (300, 1e-5)])  # dense path, Lanczos path
def test_sparse_and_dense_solvers_agree(n, rtol):
    hull = rough(n, seed=n)
    d = compute_modes(hull, 14, solver="dense")
    s = compute_modes(hull, 14, solver="sparse")
    # the dense solve of the assembled K loses digits as eps (N / 4.73)^4 (the trap) ...
    np.testing.assert_allclose(s.omega, d.omega, rtol=rtol)
    M = assemble(hull).M
    overlap = np.abs(np.einsum("ij,ij->j", s.phi, M @ d.phi))
    np.testing.assert_allclose(overlap, 1.0, atol=1e-6)
    # ... but its mode shapes are right: their exact Rayleigh quotients are the sparse omega^2
    np.testing.assert_allclose(accurate_rayleigh(hull, d.phi[:, 2:]), s.omega[2:] ** 2,
                               rtol=1e-10)


def test_shift_invert_method_agrees_on_a_moderate_mesh():
    hull = rough(200, seed=1)
    beam = assemble(hull)
    R = rigid_modes(beam)
    lam_f, V_f, _ = sparse_flexible(beam, R, 8, method="flexibility")
    lam_s, V_s, _ = sparse_flexible(beam, R, 8, method="shift-invert")
    np.testing.assert_allclose(lam_s, lam_f, rtol=1e-6)
    # both in the M-orthogonal complement of the rigid modes
    for V in (V_f, V_s):
        np.testing.assert_allclose(R.T @ (beam.M @ V), 0.0, atol=1e-10 * np.abs(V).max() * 1e3)


def test_all_modes_of_a_small_mesh_match_the_peer():
    hull = rough(5)
    beam = assemble(hull)
    lam = sla.eigh(beam.K.toarray(), beam.M.toarray(), eigvals_only=True)
    s = compute_modes(hull, solver="sparse")
    np.testing.assert_allclose(s.omega[2:] ** 2, lam[2:], rtol=1e-9)


def test_node_of_mode_matches_analytic_zero_crossings():
    L = 78.02
    hull = Hull.uniform(L, 3e12, 4.1e4, 200)
    modes = compute_modes(hull, 8)
    x = np.linspace(0, L, 20001)
    for k in (1, 2, 3):
        w = analytic_shape(x, L, k)
        i = np.nonzero(np.sign(w[:-1]) != np.sign(w[1:]))[0]
        xz = zero_crossings(modes, modes.flexible_index(k))
        assert xz.size == k + 1
        np.testing.assert_allclose(xz, x[i], atol=2 * L / 20000)
        assert mode_nodes(modes, modes.flexible_index(k)) == [int(round(v / hull.element_length))
                                                               for v in xz]


def test_tanker_third_flexible_mode_nodes(tanker_modes):
    # docs/theory/factors.md#bag-count: the four external bags sit at the nodes of the third flexible mode
    col = tanker_modes.flexible_index(3)
    assert [n + 1 for n in mode_nodes(tanker_modes, col)] == [2, 5, 8, 11]


def test_shapes_interpolate_and_unit_peak(tanker_modes):
    x = tanker_modes.hull.x_nodes
    np.testing.assert_allclose(tanker_modes.shape_at(x), tanker_modes.displacement, atol=1e-14)
    np.testing.assert_allclose(tanker_modes.shape_at(x, columns=4)[:, 0],
                               tanker_modes.displacement[:, 4], atol=1e-14)
    up = tanker_modes.unit_peak()
    np.testing.assert_allclose(np.abs(up).max(axis=0), 1.0)
    assert np.all(tanker_modes.displacement[-1, 2:] > 0)  # sign convention: bow up


def test_bad_requests_raise_input_error(tanker_hull):
    with pytest.raises(InputError, match="modes"):
        compute_modes(tanker_hull, 2)
    with pytest.raises(InputError, match="modes"):
        compute_modes(tanker_hull, 25)
    with pytest.raises(InputError, match="solver"):
        compute_modes(tanker_hull, 5, solver="qr")
    with pytest.raises(InputError, match="dense"):
        compute_modes(tanker_hull.refined(3000), 5, solver="dense")
    with pytest.raises(InputError, match="flexible mode"):
        compute_modes(tanker_hull, 5).flexible_index(4)


def test_large_models_default_to_twenty_flexible_modes(tanker_hull):
    modes = compute_modes(tanker_hull.refined(1000))
    assert modes.n_modes == 22
    np.testing.assert_allclose(modes.frequencies_hz[2:7], analytic_free_free_hz(tanker_hull),
                               rtol=1e-9)


# --------------------------------------------------------------------------- convergence
def test_convergence_rate_of_synthetic_data():
    n = np.array([4, 8, 16, 32, 64])
    assert convergence_rate(n, 3.0 * n**-4.0) == pytest.approx(-4.0)
    assert convergence_rate(n, 1e-14 * np.ones(5)) != convergence_rate(n, 1e-14 * np.ones(5))


def test_uniform_beam_converges_at_h4_to_analytic(tanker_hull):
    conv = convergence_study(tanker_hull)
    assert conv.reference == "analytic"
    np.testing.assert_allclose(conv.reference_hz, analytic_free_free_hz(tanker_hull))
    np.testing.assert_allclose(conv.rates, -4.0, atol=0.1)
    err = np.abs(conv.rel_error)
    assert np.all(conv.frequencies_hz[np.isfinite(err)] > 0)
    # FE frequencies converge from above (consistent mass: an upper bound)
    assert np.all(conv.rel_error[np.isfinite(err)] > 0)
    i11 = list(conv.elements).index(11)  # the paper's mesh
    assert err[i11, 0] < 1e-4 and err[i11, 4] < 1e-2
    assert err[-1, 0] < err[0, 0] * (conv.elements[0] / conv.elements[-1]) ** 3.5


def test_non_uniform_hull_converges_to_its_fine_mesh():
    conv = convergence_study(rough(6), n_flex=3)
    assert conv.reference.endswith("elements")
    assert list(conv.elements) == [6, 12, 24, 48, 96]
    np.testing.assert_allclose(conv.rates, -4.0, atol=0.2)


def test_convergence_rejects_bad_input(tanker_hull):
    with pytest.raises(InputError):
        convergence_study(tanker_hull, n_flex=6)
    with pytest.raises(InputError):
        convergence_study(tanker_hull, element_counts=(0, 4))
