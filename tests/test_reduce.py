"""Reductions: del is truncation, mdc keeps the static flexible gain exactly, both agree with
python-control's modred, rigid poles survive, and the paper's ranking of the methods."""

import warnings

import numpy as np
import pytest

from flexlift.dynamics.reduce import (
    METHODS,
    compare,
    kept_modes,
    paper_bag_model,
    reduce_all,
    reduce_model,
    truncate,
)
from flexlift.dynamics.statespace import (
    ModalStateSpace,
    bag_siso,
    bag_state_space,
    default_omega_lo,
    flexible_dc_gain,
    frequency_response,
    mode_gains,
    to_control,
)
from flexlift.errors import InputError

ZETA = 0.02
W_CHECK = np.array([0.7, 12.0, 95.0, 410.0, 2600.0])  # rad/s, away from the poles


@pytest.fixture(scope="module")
def siso(tanker_modes, tanker_plan):
    return bag_siso(tanker_modes, tanker_plan.bag("bag_1"), ZETA)


@pytest.fixture(scope="module")
def mimo(tanker_modes, tanker_plan):
    return bag_state_space(tanker_modes, tanker_plan.bags, ZETA, velocity=True)


def _elim_states(full: ModalStateSpace, reduced: ModalStateSpace) -> list[int]:
    elim = [i for i, n in enumerate(full.mode_numbers) if n not in set(reduced.mode_numbers)]
    return sorted([2 * i for i in elim] + [2 * i + 1 for i in elim])


def test_del_is_plain_truncation(siso):
    for order in (2, 3, 5):
        for ordering in ("unsorted", "sorted"):
            r = reduce_model(siso, order, ordering, "del")
            keep = kept_modes(siso, order, ordering)
            states = np.ravel(np.column_stack([2 * keep, 2 * keep + 1]))
            np.testing.assert_array_equal(r.A, siso.A[np.ix_(states, states)])
            np.testing.assert_array_equal(r.B, siso.B[states])
            np.testing.assert_array_equal(r.C, siso.C[:, states])
            np.testing.assert_array_equal(r.D, siso.D)
            assert r.n_states == 2 * order


@pytest.mark.parametrize("order", [2, 3, 4, 7])
@pytest.mark.parametrize("ordering", ["unsorted", "sorted"])
def test_mdc_static_gain_exact(mimo, order, ordering):
    full = flexible_dc_gain(mimo)
    r = reduce_model(mimo, order, ordering, "mdc")
    np.testing.assert_allclose(flexible_dc_gain(r), full, rtol=1e-12, atol=1e-15 * np.abs(full).max())
    d = reduce_model(mimo, order, ordering, "del")
    if order < mimo.n_modes:  # del loses the eliminated modes' static part
        assert np.abs(flexible_dc_gain(d) - full).max() > 1e-3 * np.abs(full).max()


@pytest.mark.parametrize("method, ctl", [("del", "truncate"), ("mdc", "matchdc")])
@pytest.mark.parametrize("order, ordering", [(2, "unsorted"), (4, "unsorted"), (5, "sorted")])
def test_agrees_with_control_modred(mimo, method, ctl, order, ordering):
    import control

    ours = reduce_model(mimo, order, ordering, method)
    elim = _elim_states(mimo, ours)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no "unstable" warning is expected with the flag off
        ref = control.modred(to_control(mimo), elim, method=ctl, warn_unstable=False)
    assert ref.nstates == ours.n_states
    G_ref = ref(1j * W_CHECK)
    G = frequency_response(ours, W_CHECK)
    np.testing.assert_allclose(G, G_ref, rtol=1e-9, atol=1e-12 * np.abs(G).max())
    np.testing.assert_allclose(ours.D, ref.D, rtol=1e-10, atol=1e-24)


def test_reduced_models_keep_rigid_poles(mimo):
    for name, r in reduce_all(mimo, 3).items():
        lam = np.linalg.eigvals(r.A)
        assert np.sum(np.abs(lam) < 1e-9) == 4, name  # two double-integrator rigid modes
        assert {1, 2} <= set(r.mode_numbers.tolist())
        assert r.n_rigid == 2


def test_sorted_keeps_largest_gains(siso):
    # bag_1 sits on a node of flexible mode 3 (mode 5): sorted truncation skips it
    g = mode_gains(siso)
    flex = np.arange(2, siso.n_modes)
    best3 = flex[np.argsort(-g[flex])[:3]]
    keep = kept_modes(siso, 5, "sorted")
    assert set(keep.tolist()) == {0, 1} | set(best3.tolist())
    assert 4 not in keep and list(kept_modes(siso, 5, "unsorted")) == [0, 1, 2, 3, 4]
    # at order 2 both orderings keep only the rigid modes
    assert list(kept_modes(siso, 2, "sorted")) == list(kept_modes(siso, 2, "unsorted")) == [0, 1]


def test_mdc_by_hand_two_modes():
    """One rigid and one flexible mode; eliminating the flexible one adds c b / w^2 to D."""
    s = ModalStateSpace.from_modal([0.0, 4.0], [0.0, 0.1], [[2.0], [3.0]], [[1.0, 5.0]],
                                   [[0.0, 0.0]])
    m = truncate(s, [0], "mdc")
    assert m.D[0, 0] == pytest.approx(3.0 * 5.0 / 16.0)
    assert truncate(s, [0], "del").D[0, 0] == 0.0
    np.testing.assert_array_equal(m.A, [[0.0, 1.0], [0.0, 0.0]])
    # G_mdc(jw) = -2/w^2 + 15/16 exactly
    w = np.array([0.5, 2.0])
    np.testing.assert_allclose(frequency_response(m, w)[0, 0], -2 / w**2 + 15 / 16)


def test_order_and_keep_validation(siso):
    with pytest.raises(InputError, match=r"keep 2\.\.24 modes"):
        reduce_model(siso, 1)
    with pytest.raises(InputError, match=r"keep 2\.\.24 modes"):
        reduce_model(siso, 25)
    with pytest.raises(InputError, match="whole number"):
        reduce_model(siso, 2.5)
    with pytest.raises(InputError, match="rigid modes"):
        truncate(siso, [0, 2, 3], "mdc")
    with pytest.raises(InputError, match="'del' or 'mdc'"):
        truncate(siso, [0, 1], "balanced")
    with pytest.raises(InputError, match="'unsorted' or 'sorted'"):
        kept_modes(siso, 3, "random")


def test_paper_bag_model(tanker_modes, tanker_plan):
    node = tanker_plan.bag("bag_2").node
    p = paper_bag_model(tanker_modes, node, ZETA)
    assert p.A.shape == (4, 4) and p.B.shape == (4, 1) and p.C.shape == (1, 4)
    assert p.D.shape == (1, 1)
    phi = tanker_modes.displacement[node]
    w = tanker_modes.omega
    assert p.D[0, 0] == pytest.approx(np.sum(phi[2:] ** 2 / w[2:] ** 2), rel=1e-12)
    np.testing.assert_allclose(p.B[1::2, 0], phi[:2])
    np.testing.assert_allclose(p.C[0, 0::2], phi[:2])
    np.testing.assert_array_equal(p.A, [[0, 1, 0, 0], [0, 0, 0, 0], [0, 0, 0, 1], [0, 0, 0, 0]])
    via_bag = reduce_model(bag_siso(tanker_modes, tanker_plan.bag("bag_2"), ZETA), 2, "unsorted",
                           "mdc")
    np.testing.assert_allclose(p.D, via_bag.D, rtol=1e-14)
    for bad in (-1, 12, 2.0):
        with pytest.raises(InputError, match="node"):
            paper_bag_model(tanker_modes, bad)


def test_comparison_errors_by_hand(siso):
    models = reduce_all(siso, 2)
    cmp = compare(models)
    w_lo = default_omega_lo(siso)
    assert cmp.omega_lo == w_lo and cmp.band[1] == pytest.approx(siso.omega.max())
    I = np.eye(siso.n_states)
    g_full = abs((siso.C @ np.linalg.solve(1j * w_lo * I - siso.A, siso.B) + siso.D)[0, 0])
    for name in METHODS:
        r = models[name]
        Ir = np.eye(r.n_states)
        g = abs((r.C @ np.linalg.solve(1j * w_lo * Ir - r.A, r.B) + r.D)[0, 0])
        assert cmp.row(name).dc_error_pct == pytest.approx(100 * (g - g_full) / g_full, rel=1e-9)
        assert cmp.row(name).states == 4
    # the full model compared with itself has no error
    same = compare({"full": siso, "unsorted_mdc": reduce_model(siso, 24)})
    assert same.rows[0].dc_error_pct == pytest.approx(0, abs=1e-10)
    assert same.rows[0].peak_error_pct == pytest.approx(0, abs=1e-10)


def test_paper_conclusion_unsorted_mdc_most_accurate(tanker_modes, tanker_plan):
    for bag in tanker_plan.external:
        s = bag_siso(tanker_modes, bag, ZETA)
        for order in (2, 3, 4):
            cmp = compare(reduce_all(s, order))
            assert cmp.most_accurate == "unsorted_mdc", (bag.name, order)
            assert abs(cmp.row("unsorted_mdc").dc_error_pct) < abs(cmp.row("unsorted_del").dc_error_pct)
            assert abs(cmp.row("sorted_mdc").dc_error_pct) < abs(cmp.row("sorted_del").dc_error_pct)
        # the 4-state model: del over-estimates the gain at w_lo (the flexible static part,
        # of opposite sign to the rigid part there, is lost), mdc is within 0.05 %
        cmp = compare(reduce_all(s, 2))
        assert cmp.row("unsorted_del").dc_error_pct > 0.1
        assert abs(cmp.row("unsorted_mdc").dc_error_pct) < 0.05
        # neither 4-state model has the first flexible resonance
        assert cmp.resonance_omega == pytest.approx(tanker_modes.omega[2], rel=0.01)
        assert cmp.row("unsorted_mdc").resonance_error_pct < -50
