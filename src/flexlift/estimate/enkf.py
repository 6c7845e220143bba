"""The ensemble Kalman filter's update, deterministic (docs/theory/estimation.md).

An ensemble of ``m`` members (columns) stands for the state's mean and covariance. The
analysis is the ensemble transform Kalman filter's (ETKF, Bishop et al. 2001; Hunt et al.
2007): with anomalies ``A = X - mean`` and the members' predicted readings ``Y``, the mean
moves by the Kalman gain of the sample covariance and the anomalies are transformed by the
symmetric square root of the posterior's weight covariance. No perturbed observations: the
update is deterministic, and on a linear plant whose ensemble's sample covariance equals the
Kalman filter's ``P`` it gives the Kalman filter's mean and covariance to rounding
(tests/test_enkf.py, filterpy's ``KalmanFilter`` as the oracle).
"""

from __future__ import annotations

import numpy as np


def analysis(X: np.ndarray, Y: np.ndarray, z: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The members after readings ``z``.

    Parameters
    ----------
    X : (n, m) array
        The members' states (SI), one a column.
    Y : (p, m) array
        Each member's predicted readings h(x) (SI).
    z : (p,) array
        The readings.
    R : (p, p) array
        Their noise covariance (SI squared).

    Returns
    -------
    (n, m) array
        The members after the update.
    """
    m = X.shape[1]
    x_mean, y_mean = X.mean(axis=1), Y.mean(axis=1)
    A, S = X - x_mean[:, None], Y - y_mean[:, None]
    C = np.linalg.solve(R, S).T  # (m, p): S' R^-1
    precision = (m - 1) * np.eye(m) + C @ S
    values, vectors = np.linalg.eigh(precision)
    P_w = (vectors / values) @ vectors.T  # weight covariance
    w_mean = P_w @ (C @ (z - y_mean))
    W = vectors @ np.diag(np.sqrt((m - 1) / values)) @ vectors.T  # symmetric square root
    return x_mean[:, None] + A @ (w_mean[:, None] + W)


def members_of(mean: np.ndarray, P: np.ndarray, m: int) -> np.ndarray:
    """``m`` members (columns) whose sample mean is ``mean`` and sample covariance ``P``
    exactly (``m`` > the state's size): the mean plus ``sqrt(m - 1)`` times a square root of
    ``P`` rotated onto zero-mean columns."""
    n = mean.size
    if m <= n:
        raise ValueError(f"an ensemble of {m} members cannot hold a covariance of size {n}")
    values, vectors = np.linalg.eigh(P)
    root = vectors * np.sqrt(np.maximum(values, 0.0))  # root @ root.T == P
    # m orthonormal zero-mean columns: an orthonormal basis orthogonal to ones(m)
    basis = np.linalg.qr(np.column_stack([np.ones(m), np.eye(m)[:, : m - 1]]))[0][:, 1:]
    return mean[:, None] + np.sqrt(m - 1) * root @ basis[:, :n].T
