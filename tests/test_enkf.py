"""The ensemble filter's update on a linear plant is the Kalman filter's (filterpy's
KalmanFilter the closed-form oracle)."""

import numpy as np
from filterpy.kalman import KalmanFilter

from flexlift.estimate.enkf import analysis, members_of


def _stats(X):
    return X.mean(axis=1), np.cov(X)


def test_members_hold_the_mean_and_covariance_exactly():
    rng = np.random.default_rng(0)
    L = rng.standard_normal((3, 3))
    P = L @ L.T + np.eye(3)
    mean, cov = _stats(members_of(np.array([1.0, -2.0, 3.0]), P, 8))
    assert np.allclose(mean, [1, -2, 3]) and np.allclose(cov, P)


def test_on_a_linear_plant_the_filter_is_the_kalman_filter():
    """Heave and its speed under a constant force, the depth read with noise: twenty
    predict/update cycles, the ensemble re-formed from its own forecast (the plant's
    noise Q added to the forecast covariance), mean and covariance as filterpy's."""
    dt, rng = 1.0, np.random.default_rng(1)
    F = np.array([[1.0, dt], [0.0, 1.0]])
    H = np.array([[1.0, 0.0]])
    Q, R = np.diag([1e-3, 1e-4]), np.array([[0.25]])
    kf = KalmanFilter(dim_x=2, dim_z=1)
    kf.F, kf.H, kf.Q, kf.R = F, H, Q, R
    kf.x, kf.P = np.array([0.0, 0.1]), np.diag([1.0, 0.01])
    X = members_of(kf.x.copy(), kf.P.copy(), 6)
    truth = np.array([0.2, 0.12])
    for _ in range(20):
        truth = F @ truth
        z = H @ truth + rng.normal(0, 0.5, 1)
        kf.predict()
        Xf = F @ X  # the members advanced by the plant
        mean, cov = _stats(Xf)
        X = members_of(mean, cov + Q, 6)
        X = analysis(X, H @ X, z, R)
        kf.update(z)
        mean, cov = _stats(X)
        assert np.allclose(mean, kf.x, rtol=1e-9, atol=1e-12)
        assert np.allclose(cov, kf.P, rtol=1e-9, atol=1e-14)


def test_a_wrong_gain_would_show():
    """The update moves the mean toward the reading by the gain P H' / (H P H' + R)."""
    X = members_of(np.array([0.0]), np.array([[1.0]]), 4)
    after = analysis(X, X.copy(), np.array([2.0]), np.array([[1.0]]))
    assert np.isclose(after.mean(), 1.0) and np.isclose(np.var(after, ddof=1), 0.5)
