"""Modal state space: structure of A, B, C; gains against a direct static solve with K;
closed-form responses against python-control and scipy; conversion to/from control."""

import numpy as np
import pytest
import scipy.linalg as sla
import scipy.signal as sig

from flexlift.dynamics.statespace import (
    ModalStateSpace,
    bag_siso,
    bag_state_space,
    default_omega_lo,
    flexible_dc_gain,
    frequency_response,
    from_control,
    gain_ranking,
    impulse_response,
    modal_dc_gains,
    modal_state_space,
    mode_gains,
    step_response,
    to_control,
)
from flexlift.errors import InputError
from flexlift.structure.beam import assemble

ZETA = 0.02


@pytest.fixture(scope="module")
def mimo(tanker_modes, tanker_plan):
    return bag_state_space(tanker_modes, tanker_plan.bags, ZETA, velocity=True)


def test_A_block_diagonal_with_damped_eigenvalues(tanker_modes):
    s = modal_state_space(tanker_modes, ["f_node_2"], ["w_node_2"], ZETA)
    m = tanker_modes.n_modes
    assert s.A.shape == (2 * m, 2 * m) and s.n_states == 48
    mask = np.kron(np.eye(m), np.ones((2, 2))).astype(bool)
    assert np.all(s.A[~mask] == 0.0)
    w = tanker_modes.omega
    zeta = np.where(w == 0, 0.0, ZETA)
    for i in range(m):
        block = s.A[2 * i : 2 * i + 2, 2 * i : 2 * i + 2]
        lam = np.sort_complex(np.linalg.eigvals(block))
        wd = w[i] * np.sqrt(1 - zeta[i] ** 2)
        expect = np.sort_complex(np.array([-zeta[i] * w[i] - 1j * wd, -zeta[i] * w[i] + 1j * wd]))
        np.testing.assert_allclose(lam, expect, rtol=1e-10, atol=1e-12 * max(w[i], 1))
    # rigid modes: undamped double integrators at the front of the state vector
    assert np.array_equal(s.A[:4, :4], np.array([[0, 1, 0, 0], [0, 0, 0, 0],
                                                 [0, 0, 0, 1], [0, 0, 0, 0]], float))
    assert s.n_rigid == 2 and list(s.mode_numbers[:3]) == [1, 2, 3]


def test_B_and_C_pick_mode_shapes(tanker_modes):
    phi = tanker_modes.phi
    s = modal_state_space(tanker_modes, ["f_node_3", "f_node_9"],
                          ["w_node_5", "v_node_5", "theta_node_12"], ZETA)
    np.testing.assert_array_equal(s.B[0::2], 0.0)
    np.testing.assert_allclose(s.B[1::2, 0], phi[2 * 2])
    np.testing.assert_allclose(s.B[1::2, 1], phi[2 * 8])
    np.testing.assert_allclose(s.C[0, 0::2], phi[2 * 4])
    np.testing.assert_array_equal(s.C[0, 1::2], 0.0)
    np.testing.assert_allclose(s.C[1, 1::2], phi[2 * 4])  # velocity picks q_dot
    np.testing.assert_array_equal(s.C[1, 0::2], 0.0)
    np.testing.assert_allclose(s.C[2, 0::2], phi[2 * 11 + 1])  # rotation DOF of node 12
    assert s.outputs == ("w_node_5", "v_node_5", "theta_node_12")
    assert s.states[:4] == ("q1", "q1_dot", "q2", "q2_dot")


def _static_flexible(beam, R, f):
    """u with K u = P^T f, u M-orthogonal to the rigid modes R (P removes rigid modes)."""
    MR = np.asarray(beam.M @ R)
    f_flex = f - MR @ (R.T @ f)  # inertia relief: the rigid-body part of the load removed
    n = f.size
    K = beam.K.toarray()
    aug = np.block([[K, MR], [MR.T, np.zeros((2, 2))]])
    return np.linalg.solve(aug, np.concatenate([f_flex, np.zeros(2)]))[:n]


def test_sum_of_flexible_dc_gains_equals_static_solve(tanker_hull, tanker_modes, tanker_plan):
    beam = assemble(tanker_hull)
    R = tanker_modes.phi[:, :2]
    bags = tanker_plan.bags
    s = bag_state_space(tanker_modes, bags, ZETA)
    G = flexible_dc_gain(s)  # (n_bags, n_bags)
    assert np.all(np.isnan(modal_dc_gains(s)[:, :, :2]))
    for k, bag in enumerate(bags):
        f = modal_state_space(tanker_modes, [f"f_{bag.name}"], ["w_node_1"], ZETA, bags).b
        # the load vector of the bag, rebuilt from the modal coefficients (Phi is complete)
        load = np.linalg.solve(tanker_modes.phi.T, f[:, 0])
        u = _static_flexible(beam, R, load)
        y = np.linalg.solve(tanker_modes.phi.T, s.c_disp.T).T @ u  # outputs from DOFs
        np.testing.assert_allclose(G[:, k], y, rtol=1e-8, atol=1e-8 * np.abs(y).max())
    # symmetric (Maxwell reciprocity) and a point-load entry by hand
    np.testing.assert_allclose(G, G.T, rtol=1e-10, atol=1e-22)
    node = bags[0].node
    e = np.zeros(beam.n_dof)
    e[2 * node] = 1.0
    assert G[0, 0] == pytest.approx(_static_flexible(beam, R, e)[2 * node], rel=1e-9)


def test_internal_bag_load_is_uniform_over_its_span(tanker_hull, tanker_modes, tanker_plan):
    bag = tanker_plan.bag("bag_6")
    s = modal_state_space(tanker_modes, ["f_bag_6"], ["w_node_1"], ZETA, tanker_plan.bags)
    f = np.linalg.solve(tanker_modes.phi.T, s.b[:, 0])
    x = tanker_hull.x_nodes
    assert f[0::2].sum() == pytest.approx(1.0, rel=1e-12)  # unit total force
    moment = f[0::2] @ x + f[1::2].sum()  # about the aft end
    assert moment == pytest.approx(0.5 * (bag.span[0] + bag.span[1]), rel=1e-10)
    # no load outside the span's elements
    l = tanker_hull.element_length
    outside = (x < bag.span[0] - l) | (x > bag.span[1] + l)
    assert np.all(np.abs(f[0::2][outside]) < 1e-12)


def test_mode_gains_and_ranking(tanker_modes, tanker_plan):
    bag = tanker_plan.bag("bag_2")
    s = bag_siso(tanker_modes, bag, ZETA)
    phi = tanker_modes.displacement[bag.node]
    w = tanker_modes.omega
    w_lo = default_omega_lo(s)
    assert w_lo == pytest.approx(0.1 * w[2])
    g = mode_gains(s)
    np.testing.assert_allclose(g[2:], phi[2:] ** 2 / w[2:] ** 2, rtol=1e-12)
    np.testing.assert_allclose(g[:2], phi[:2] ** 2 / w_lo**2, rtol=1e-12)
    order = gain_ranking(s)
    assert np.all(np.diff(g[order]) <= 0) and sorted(order) == list(range(24))
    # external bags sit on the nodes of flexible mode 3 (mode 5): its gain is tiny
    assert g[4] < 1e-3 * g[2]


def test_frequency_response_matches_direct_solve_and_control(mimo):
    import control

    w = np.array([0.3, 3.0, 31.4, 87.0, 300.0, 2000.0, 9000.0])
    G = frequency_response(mimo, w)
    assert G.shape == (mimo.D.shape[0], mimo.D.shape[1], w.size)
    I = np.eye(mimo.n_states)
    for k, wk in enumerate(w):
        direct = mimo.C @ np.linalg.solve(1j * wk * I - mimo.A, mimo.B) + mimo.D
        np.testing.assert_allclose(G[:, :, k], direct, rtol=1e-8, atol=1e-9 * np.abs(direct).max())
    ref = control.frequency_response(to_control(mimo), w)
    np.testing.assert_allclose(G, ref.complex, rtol=1e-7, atol=1e-9 * np.abs(G).max())


def test_step_and_impulse_exact_against_scipy(tanker_modes, tanker_plan):
    s = bag_siso(tanker_modes, tanker_plan.bag("bag_1"), ZETA)
    s = s.with_modes(range(8), feedthrough=np.array([[2e-10]]))  # include a feedthrough
    t = np.linspace(0.0, 1.5, 301)
    lti = sig.StateSpace(s.A, s.B, s.C, s.D)
    _, y_step = sig.step(lti, T=t)
    _, y_imp = sig.impulse(lti, T=t)
    np.testing.assert_allclose(step_response(s, t)[0, 0], y_step, rtol=1e-7,
                               atol=1e-9 * np.abs(y_step).max())
    np.testing.assert_allclose(impulse_response(s, t)[0, 0], y_imp, rtol=1e-7,
                               atol=1e-9 * np.abs(y_imp).max())


def test_rigid_step_is_free_body_motion(tanker_modes):
    """A step force at the centre of mass: heave only, w = F t^2 / (2 m_total)."""
    s = modal_state_space(tanker_modes, ["f_node_1", "f_node_12"], ["w_node_1"], ZETA)
    both = ModalStateSpace.from_modal(s.omega[:2], s.zeta[:2], s.b[:2].sum(1, keepdims=True),
                                      s.c_disp[:, :2], s.c_vel[:, :2])
    t = np.array([0.0, 1.0, 3.0])
    m_total = tanker_modes.hull.total_mass
    np.testing.assert_allclose(step_response(both, t)[0, 0], 2.0 * t**2 / (2 * m_total),
                               rtol=1e-9)


def test_round_trip_with_control(mimo):
    import control

    ss = to_control(mimo)
    assert isinstance(ss, control.StateSpace)
    assert list(ss.input_labels) == list(mimo.inputs)
    assert list(ss.output_labels) == list(mimo.outputs)
    back = from_control(ss)
    for name in ("A", "B", "C", "D", "omega", "b", "c_disp", "c_vel"):
        np.testing.assert_allclose(getattr(back, name), getattr(mimo, name), rtol=1e-12,
                                   atol=0, err_msg=name)
    np.testing.assert_allclose(back.zeta, mimo.zeta, rtol=1e-10)
    assert back.inputs == mimo.inputs and back.outputs == mimo.outputs
    # a realisation that is not modal is refused with one clear line
    T = sla.block_diag(*[np.array([[1.0, 0.5], [0.2, 1.0]])] * mimo.n_modes)
    other = control.similarity_transform(ss, T)
    with pytest.raises(InputError, match="modal form"):
        from_control(other)


def test_subsystem_and_names(mimo, tanker_modes, tanker_plan):
    sub = mimo.subsystem(["w_bag_3"], ["f_bag_3"])
    ref = bag_siso(tanker_modes, tanker_plan.bag("bag_3"), ZETA)
    np.testing.assert_allclose(sub.A, ref.A)
    np.testing.assert_allclose(sub.B, ref.B)
    np.testing.assert_allclose(sub.C, ref.C)
    with pytest.raises(InputError, match="known outputs"):
        mimo.subsystem(["w_bag_9"])


@pytest.mark.parametrize(
    "inputs, outputs, match",
    [
        (["f_node_13"], ["w_node_1"], "nodes are 1..12"),
        (["f_node_1"], ["x_node_1"], "w/v/theta_node_N"),
        (["w_node_1"], ["w_node_1"], "f_node_N"),
        (["f_bag_9"], ["w_node_1"], "known bags"),
        (["f_node_1"], ["theta_bag_6"], "rotation needs a bag at a node"),
        ([("shape", np.ones(5))], ["w_node_1"], "24 DOF loads"),
    ],
)
def test_bad_signal_names(tanker_modes, tanker_plan, inputs, outputs, match):
    with pytest.raises(InputError, match=match) as err:
        modal_state_space(tanker_modes, inputs, outputs, ZETA, tanker_plan.bags)
    assert "\n" not in str(err.value)


def test_damping_validation(tanker_modes):
    z = np.full(tanker_modes.n_modes, 0.05)
    with pytest.raises(InputError, match="rigid modes take zeta = 0"):
        modal_state_space(tanker_modes, ["f_node_1"], ["w_node_1"], z)
    with pytest.raises(InputError, match="zeta"):
        modal_state_space(tanker_modes, ["f_node_1"], ["w_node_1"], 1.2)
    z[:2] = 0.0
    z[5] = 0.1
    s = modal_state_space(tanker_modes, ["f_node_1"], ["w_node_1"], z)
    assert s.A[11, 11] == pytest.approx(-2 * 0.1 * tanker_modes.omega[5])
