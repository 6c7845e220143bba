"""No silent numerics (issue 23): a negative flexible eigenvalue is a failed solve, not a
third rigid mode; round-off negatives are clipped and recorded."""

from __future__ import annotations

import numpy as np
import pytest

from flexlift.dynamics.statespace import from_control, to_control
from flexlift.errors import InputError, SimulationError
from flexlift.structure import modes as modes_mod
from flexlift.structure.hull import Hull


def _hull():
    return Hull.uniform(78.02, 3.0e12, 3.2e6 / 78.02, 11)


def _solver_returning(first: float):
    """The dense flexible solve with its lowest eigenvalue replaced by ``first`` x omega_1^2."""
    real = modes_mod._dense_flexible

    def fake(beam, R, n_flex):
        lam, V = real(beam, R, n_flex)
        lam = lam.copy()
        lam[0] = first * lam[1]  # relative to the next (the lowest positive) one
        return lam, V
    return fake


def test_a_negative_flexible_eigenvalue_raises(monkeypatch):
    monkeypatch.setattr(modes_mod, "_dense_flexible", _solver_returning(-1e-4))
    with pytest.raises(SimulationError, match="flexible mode 1 has a negative eigenvalue"):
        modes_mod.compute_modes(_hull(), n_modes=8, solver="dense")


def test_a_round_off_negative_is_clipped_and_recorded(monkeypatch):
    monkeypatch.setattr(modes_mod, "_dense_flexible", _solver_returning(-1e-10))
    m = modes_mod.compute_modes(_hull(), n_modes=8, solver="dense")
    assert m.omega[2] == 0.0 and np.all(m.omega[3:] > 0)
    (k, lam), = m.diagnostics["clipped_eigenvalues"]
    assert k == 1 and lam < 0


def test_clean_modes_have_no_diagnostics():
    assert modes_mod.compute_modes(_hull(), n_modes=8).diagnostics == {}


def test_state_space_with_a_negative_mode_is_refused(tanker_modes):
    """A modal block [0 1; +|w^2| ...] is unstable, not rigid: from_control refuses it even
    when it is tiny against the largest omega^2 (once it was made a rigid mode)."""
    import control

    from flexlift.dynamics.statespace import modal_state_space

    sys_ = modal_state_space(tanker_modes, ["f_node_2"], ["w_node_2"], zeta=0.0)
    ss = to_control(sys_)
    A = np.array(ss.A)
    w1 = -A[5, 4]  # the first flexible mode's omega^2 (state pairs: 2 rigid, then flexible)
    assert w1 > 0
    A[5, 4] = 1e-6 * w1  # omega^2 = -1e-6 omega_1^2, far inside rtol * max|A|
    bad = control.StateSpace(A, ss.B, ss.C, ss.D)
    with pytest.raises(InputError, match="must not be negative"):
        from_control(bad)
